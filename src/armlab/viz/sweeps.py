"""Pictures of a sweep's table: a metric against one parameter, heat maps over two, histograms
and scatter plots of Monte Carlo draws, with the stable/unstable boundary marked.

A sweep file's ``[[plot]]`` tables choose them (``docs/sweeps.md``)::

    kind = "line"        x = "omega_n"  y = ["settling_time", "peak_torque"]  by = "simulation.torque_limit"
    kind = "heatmap"     x = "controller.kp"  y = "controller.kd"  metric = "overshoot"
    kind = "histogram"   y = ["rms_error"]
    kind = "ecdf"        y = ["rms_error"]       (empirical CDF: the fraction of runs ≤ each value)
    kind = "scatter"     x = "mismatch"  y = ["rms_error"]

A Monte Carlo sweep's page in the report (:func:`sweep_section`) also lists its worst runs
(:func:`worst_runs`): the runs of largest error, with the values drawn for them.

Without ``[[plot]]`` tables, :func:`default_plots` picks them from the sweep's axes.  Runs that
diverged are drawn as red crosses (line, scatter) or hatched cells (heat maps, with the
boundary between stable and diverged cells drawn as a line); invalid runs are left out and
counted in the title.
"""

from __future__ import annotations

import importlib.util
import math
import warnings
from pathlib import Path

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import FormatStrFormatter  # noqa: E402

from armlab.errors import SweepFileError  # noqa: E402
from armlab.files import replacing  # noqa: E402
from armlab.sweep.metrics import METRICS  # noqa: E402

UNITS = dict(METRICS)
KINDS = ("line", "heatmap", "histogram", "ecdf", "scatter")
# The metric a Monte Carlo sweep's worst runs are ranked by: the first of these the runs have.
WORST_BY = ("rms_error", "max_error", "position_error", "force_error", "steady_state_error", "peak_torque")
WORST_COUNT = 5
KEYS = {"kind", "x", "y", "by", "metric", "logx", "logy", "title"}


def check_plots(spec) -> list[dict]:
    """The sweep's plot tables, checked against its columns (one-line errors naming the file)."""
    columns = set(spec.parameter_names) | set(UNITS)
    plots = []
    for i, table in enumerate(spec.plots):
        where = f"plot[{i}]"
        unknown = sorted(set(table) - KEYS)
        if unknown:
            raise SweepFileError(spec.source, f"{where}.{unknown[0]}",
                                 f"unknown key (use {', '.join(sorted(KEYS))})")
        kind = table.get("kind")
        if kind not in KINDS:
            raise SweepFileError(spec.source, f"{where}.kind", f"{kind!r} is not one of {', '.join(KINDS)}")
        plot = dict(table)
        y = plot.get("y", plot.get("metric", []))
        plot["y"] = [y] if isinstance(y, str) else y
        if not isinstance(plot["y"], list) or not plot["y"]:
            raise SweepFileError(spec.source, f"{where}.y", "expected a column name or an array of them")
        needed = {"line": ("x",), "heatmap": ("x", "y", "metric"), "scatter": ("x",), "histogram": (),
                  "ecdf": ()}[kind]
        for key in needed:
            if key not in table:
                raise SweepFileError(spec.source, f"{where}.{key}", "missing")
        names = [("y", name) for name in plot["y"]]
        names += [(k, table[k]) for k in ("x", "by", "metric") if k in table]
        if kind == "heatmap":
            plot["y"] = [table["y"]] if isinstance(table["y"], str) else table["y"]
        for key, name in names:
            if not isinstance(name, str) or name not in columns:
                raise SweepFileError(spec.source, f"{where}.{key}", f"{name!r} is not a column of this sweep "
                                                                    f"({', '.join(sorted(columns))})")
        for key in ("logx", "logy"):
            if not isinstance(table.get(key, False), bool):
                raise SweepFileError(spec.source, f"{where}.{key}", "expected true or false")
        plots.append(plot)
    return plots


def default_plots(spec, frame) -> list[dict]:
    """Plots for a sweep without ``[[plot]]``: the metrics that some run has, against the axes
    (two finite numeric axes: heat maps; one: lines, one per value of a short other axis); none
    when no run has a metric."""
    metrics = [m for m in UNITS if m in frame and frame[m].notna().any() and m != "divergence_time"]
    if not metrics:
        return []  # no run gave a number (every run invalid): nothing to draw
    axes = [a for a in spec.grid + spec.zipped if len(a.values) > 1]
    numeric = [a.key for a in axes if all(isinstance(v, float) and math.isfinite(v) for v in a.values)]
    if spec.random:
        plots = [{"kind": "histogram", "y": metrics[:4]}, {"kind": "ecdf", "y": metrics[:4]}]
        plots += [{"kind": "scatter", "x": a.key, "y": metrics[:4]} for a in spec.random[:2]]
        return plots
    if len(numeric) >= 2:
        return [{"kind": "heatmap", "x": numeric[0], "y": [numeric[1]], "metric": m} for m in metrics[:4]]
    if numeric:
        short = [a.key for a in axes if a.key != numeric[0] and len(a.values) <= 6]
        return [{"kind": "line", "x": numeric[0], "y": metrics[:4], **({"by": short[0]} if short else {})}]
    return [{"kind": "histogram", "y": metrics[:4]}]


def _label(name: str) -> str:
    unit = UNITS.get(name, "")
    return f"{name.replace('_', ' ')} [{unit}]" if unit else name


def _figure(rows: int, width=7.0, height=2.6):
    fig = Figure(figsize=(width, 0.6 + height * rows), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _title(spec, frame, extra=""):
    """The sweep's title, the plot's note and the run counts of the whole table."""
    status = frame.attrs.get("status", frame["status"])
    invalid = int((status == "invalid").sum())
    diverged = int((status == "diverged").sum())
    notes = [f"{len(status)} runs"] + ([f"{diverged} diverged"] if diverged else []) + (
        [f"{invalid} invalid (left out)"] if invalid else [])
    return f"{spec.title}{extra}\n{', '.join(notes)}"


def _log_x(ax, values):
    """A log x axis; symmetric-log when the values include 0 (K_I = 0: no integral action)."""
    positive = values[values > 0]
    if positive.size == 0:
        return
    if (values <= 0).any():
        ax.set_xscale("symlog", linthresh=float(positive.min()))
    else:
        ax.set_xscale("log")
        if positive.max() / positive.min() < 100:
            # A short decade range: plain numbers (4, 6, 10, 20, …) rather than 4×10⁰.
            ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
            ax.xaxis.set_minor_formatter(FormatStrFormatter("%g"))


def _line(spec, frame, plot):
    x, metrics, by = plot["x"], plot["y"], plot.get("by")
    fig = _figure(len(metrics))
    axes = fig.subplots(len(metrics), 1, sharex=True, squeeze=False)[:, 0]
    groups = [(None, frame)] if by is None else list(frame.groupby(by, sort=True))
    for ax, metric in zip(axes, metrics, strict=True):
        for value, group in groups:
            group = group.sort_values(x)
            label = None if by is None else f"{by} = {value:g}" if isinstance(value, float) else (
                f"{by} = {value}")
            ok = group[group["status"] == "ok"]
            ax.plot(ok[x], ok[metric], marker="o", markersize=3, label=label)
            bad = group[group["status"] == "diverged"]
            if len(bad):
                # A diverged run has no steady state: a cross at the bottom of the panel.
                ax.plot(bad[x], np.full(len(bad), 0.03), "x", color="tab:red",
                        transform=ax.get_xaxis_transform(),
                        label="diverged" if metric == metrics[0] else None)
                ax.axvspan(bad[x].min(), bad[x].max(), color="tab:red", alpha=0.08)
        ax.set_ylabel(_label(metric))
        ax.grid(True, alpha=0.3)
        if plot.get("logx"):
            _log_x(ax, frame[x].to_numpy(dtype=float))
        if plot.get("logy") and (frame[metric] > 0).any():
            ax.set_yscale("log")
    axes[-1].set_xlabel(x)
    if by is not None or (frame["status"] == "diverged").any():
        axes[0].legend(fontsize=8)
    fig.suptitle(_title(spec, frame), fontsize=9)
    return fig


def _heatmap(spec, frame, plot):
    x, y, metric = plot["x"], plot["y"][0], plot["metric"]
    xs, ys = np.sort(frame[x].unique()), np.sort(frame[y].unique())
    grid = np.full((ys.size, xs.size), np.nan)
    unstable = np.zeros((ys.size, xs.size), dtype=bool)
    # Several runs per cell (other axes): their mean; a cell is unstable if any run diverged.
    for (vx, vy), cell in frame.groupby([x, y]):
        i, j = np.searchsorted(ys, vy), np.searchsorted(xs, vx)
        grid[i, j] = cell[metric].mean()
        unstable[i, j] = (cell["status"] == "diverged").any()
    fig = _figure(1, height=4.2)
    ax = fig.subplots()
    # An axis with a value such as inf (no torque limit) is drawn by position, labelled.
    px, py = (v if np.isfinite(v).all() else np.arange(v.size, dtype=float) for v in (xs, ys))
    mesh = ax.pcolormesh(px, py, np.ma.masked_invalid(grid), shading="nearest", cmap="viridis")
    for values, positions, set_ticks in ((xs, px, ax.set_xticks), (ys, py, ax.set_yticks)):
        if positions is not values:
            set_ticks(positions, [f"{v:g}" for v in values])
    xs, ys = px, py
    fig.colorbar(mesh, ax=ax, label=_label(metric))
    if unstable.any():
        ax.contourf(xs, ys, unstable.astype(float), levels=[0.5, 1.5], colors="none", hatches=["xx"])
        if (~unstable).any() and xs.size > 1 and ys.size > 1:
            ax.contour(xs, ys, unstable.astype(float), levels=[0.5], colors="tab:red", linewidths=1.5)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    if plot.get("logx"):
        ax.set_xscale("log")
    if plot.get("logy"):
        ax.set_yscale("log")
    extra = " (hatched: diverged, red line: stability boundary)" if unstable.any() else ""
    fig.suptitle(_title(spec, frame, extra), fontsize=9)
    return fig


def _histogram(spec, frame, plot):
    metrics = plot["y"]
    fig = _figure(len(metrics))
    axes = fig.subplots(len(metrics), 1, squeeze=False)[:, 0]
    ok = frame[frame["status"] == "ok"]
    for ax, metric in zip(axes, metrics, strict=True):
        values = ok[metric].dropna().to_numpy()
        if values.size:
            ax.hist(values, bins=max(5, min(50, int(math.sqrt(values.size)) * 2)), color="tab:blue",
                    alpha=0.8)
            for q, style in ((0.5, "-"), (0.95, "--")):
                ax.axvline(np.quantile(values, q), color="k", linestyle=style, linewidth=1,
                           label=f"{int(q * 100)} %: {np.quantile(values, q):.3g}")
            ax.legend(fontsize=8)
        ax.set_xlabel(_label(metric))
        ax.set_ylabel("runs")
    fig.suptitle(_title(spec, frame), fontsize=9)
    return fig


def _ecdf(spec, frame, plot):
    """F̂(x) = #{runs with value ≤ x} / #runs of each metric over the runs that are ok, a step
    per run, its median and 95th percentile marked."""
    metrics = plot["y"]
    fig = _figure(len(metrics))
    axes = fig.subplots(len(metrics), 1, squeeze=False)[:, 0]
    ok = frame[frame["status"] == "ok"]
    for ax, metric in zip(axes, metrics, strict=True):
        values = np.sort(ok[metric].dropna().to_numpy())
        if values.size:
            ax.step(values, np.arange(1, values.size + 1) / values.size, where="post", color="tab:blue")
            for q, style in ((0.5, "-"), (0.95, "--")):
                ax.axvline(np.quantile(values, q), color="k", linestyle=style, linewidth=1,
                           label=f"{int(q * 100)} %: {np.quantile(values, q):.3g}")
            ax.legend(fontsize=8, loc="lower right")
        ax.set_ylim(0.0, 1.02)
        ax.grid(True, alpha=0.3)
        ax.set_xlabel(_label(metric))
        ax.set_ylabel("fraction of runs ≤")
    fig.suptitle(_title(spec, frame), fontsize=9)
    return fig


def worst_runs(frame, parameters, count: int = WORST_COUNT):
    """(metric, rows): the ``count`` runs that are ok with the largest value of the first metric
    of :data:`WORST_BY` the table has, largest first, each row its run number, its
    ``parameters`` (the drawn and derived values) and that metric; (None, []) when no run has
    one.  Runs that diverged are worse still, and are counted in the run counts."""
    ok = frame[frame["status"] == "ok"]
    metric = next((m for m in WORST_BY if m in ok and ok[m].notna().any()), None)
    if metric is None:
        return None, []
    top = ok[ok[metric].notna()].sort_values([metric, "run"], ascending=[False, True]).head(count)
    return metric, [[int(row["run"]), *(row[p] for p in parameters), float(row[metric])]
                    for _, row in top.iterrows()]


def _scatter(spec, frame, plot):
    x, metrics = plot["x"], plot["y"]
    fig = _figure(len(metrics))
    axes = fig.subplots(len(metrics), 1, sharex=True, squeeze=False)[:, 0]
    ok, bad = frame[frame["status"] == "ok"], frame[frame["status"] == "diverged"]
    for ax, metric in zip(axes, metrics, strict=True):
        ax.scatter(ok[x], ok[metric], s=6, alpha=0.6)
        if len(bad):
            ax.scatter(bad[x], np.zeros(len(bad)), marker="x", color="tab:red", s=12, label="diverged")
            ax.legend(fontsize=8)
        ax.set_ylabel(_label(metric))
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(x)
    fig.suptitle(_title(spec, frame), fontsize=9)
    return fig


DRAW = {"line": _line, "heatmap": _heatmap, "histogram": _histogram, "ecdf": _ecdf, "scatter": _scatter}


def plot_sweep(spec, folder) -> list[Path]:
    """Draw the sweep's plots from the table in ``folder`` into ``folder/plots``; returns the
    PNG files written."""
    from armlab.sweep.store import read_results

    plots = check_plots(spec)
    frame = read_results(folder).to_pandas()
    valid = frame[frame["status"] != "invalid"].copy()
    valid.attrs["status"] = frame["status"]
    if not plots:
        plots = default_plots(spec, valid)
    out = Path(folder) / "plots"
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for i, plot in enumerate(plots):
        fig = DRAW[plot["kind"]](spec, valid if len(valid) else frame, plot)
        path = out / f"{spec.name}-{i}-{plot['kind']}.png"
        with replacing(path) as temporary:      # atomic: complete or not at all
            fig.savefig(temporary, format="png")
        written.append(path)
    return written


def sweep_section(folder, index: int = 0) -> str:
    """The report's page of the sweep in ``folder``: its title, description, run counts, the
    summary of each metric over the runs that are ok, and its plots (drawn now from its sweep
    file when the folder has none)."""
    import json

    from armlab.errors import ArmlabError
    from armlab.sweep import load_sweep_file, read_results
    from armlab.viz import html

    folder = Path(folder)
    try:
        manifest = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        from armlab.errors import SweepStoreError

        raise SweepStoreError(f"{folder}: has no readable manifest.json "
                              "(not an output folder of armlab sweep)") from None
    frame = read_results(folder).to_pandas()
    pngs = sorted((folder / "plots").glob("*.png"))
    note = ""
    if not pngs:
        try:
            pngs = plot_sweep(load_sweep_file(manifest.get("source", "")), folder)
        except (ArmlabError, OSError) as error:
            note = f'<p class="missing">No plots: {html.escape(error)}</p>'
    counts = frame["status"].value_counts()
    ok = frame[frame["status"] == "ok"]
    rows = []
    for name, unit in METRICS:
        values = ok[name].dropna()
        if len(values):
            rows.append([name, unit, f"{values.min():.4g}", f"{values.median():.4g}", f"{values.max():.4g}",
                         str(len(values))])
    summary = html.table(["metric", "unit", "min", "median", "max", "runs"], rows, numeric={2, 3, 4, 5},
                         caption=f"{len(frame)} runs: " + ", ".join(f"{n} {s}" for s, n in counts.items()))
    worst = ""
    try:
        spec = load_sweep_file(manifest.get("source", ""))
    except (ArmlabError, OSError):
        spec = None
    if spec is not None and spec.random:
        # Only the drawn columns: the fields derived from them follow and would widen the
        # table past the page without telling more.
        parameters = [axis.key for axis in spec.random if axis.key in frame]
        metric, rows = worst_runs(frame, parameters)
        if rows:
            shown = [[str(r[0]), *(f"{v:.4g}" if isinstance(v, float) else str(v) for v in r[1:])]
                     for r in rows]
            worst = html.table(["run", *parameters, metric], shown, numeric=set(range(len(parameters) + 2)),
                               caption=f"The {len(rows)} runs of largest {metric.replace('_', ' ')} "
                                       "(of the runs that are ok) and the values drawn for them")
    figures = "".join(html.figure(html.png_data_uri(p.read_bytes()), p.stem, kind="scope",
                                  ident=f"sweep{index}-{k}") for k, p in enumerate(pngs))
    title = html.escape(manifest.get("title", folder.name))
    described = f"<p>{html.escape(spec.description)}</p>" if spec is not None and spec.description else ""
    files = (f"{_shown(manifest.get('source', ''), 'sweep')}; "
             f"{_shown(manifest.get('scenario', ''), 'scenario')}")
    return (f'<section class="assignment" id="sweep{index}" data-sweep="{html.escape(folder.name)}">'
            f'<h2>Sweep — {title}</h2>{described}<p class="note">{files}</p>'
            f"{summary}{worst}{note}{figures}</section>")


def _shown(path: str, kind: str) -> str:
    """A sweep's or scenario's file as the report names it: a bundled one by its name (not the
    path of this installation), any other by its path."""
    from armlab.viz import html

    package = Path(__file__).resolve().parents[1]
    try:
        Path(path).resolve().relative_to(package)
    except (ValueError, OSError):
        return f"{kind} {html.escape(path)}"
    return f"bundled {kind} {html.escape(Path(path).stem)}"


SEED_SWEEPS = ("a11_stiffness", "a8_quadratic_friction")
"""The bundled sweeps behind two of the seed's claims — A11 "the softer the environment, the
closer to the desired pose", A8 "no visible change unless F₂ is increased a lot" — run into
``<out_dir>/sweeps`` and shown by a full report of the seed's robot."""


def seed_sweep_pages(names, out_dir: Path, first_index: int) -> list:
    """[(folder, page)] of the sweeps ``names``, run (or resumed) into ``out_dir/sweeps``; a
    machine without the sweep extra (Parquet) gets a page saying how to add them."""
    if not names:
        return []
    if importlib.util.find_spec("pyarrow") is None:
        note = (f"The seed's sweeps ({', '.join(names)}) need Parquet: pip install 'armlab[sweep]'.")
        return [("seed sweeps", f'<section id="sweep{first_index}"><h2>Sweeps</h2>'
                                f'<p class="missing">{note}</p></section>')]
    from armlab.errors import SweepStoreError
    from armlab.sweep import load_sweep, sweep

    pages = []
    for k, name in enumerate(names):
        folder = out_dir / "sweeps" / name
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sweep(load_sweep(name), folder, threads=1)
            except SweepStoreError:        # the folder of another version of the sweep
                sweep(load_sweep(name), folder, threads=1, overwrite=True)
        pages.append((folder, sweep_section(folder, first_index + k)))
    return pages
