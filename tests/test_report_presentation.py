"""What the report prints and draws of a run: no metrics of a diverged run and its scopes
drawn up to the divergence, no numbers on rounding residue, no steady state of a periodic run
(armlab.viz.metrics, armlab.viz.layout).  Expected values are computed here from the data."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armlab.simulation.results import SimulationResult
from armlab.viz.layout import before_divergence, scope_layout
from armlab.viz.metrics import ZERO_TO_ROUNDING, measure

JOINTS = ("d1", "theta2", "d3")
UNITS = ("m", "rad", "m")


def _result(t, q, q_err, *, status="ok", meta=None, tau=None) -> SimulationResult:
    n = len(t)
    labels = {name: JOINTS for name in ("q", "qd", "qdd", "tau", "q_err")}
    labels["z"] = ()
    units = {name: UNITS for name in ("q", "qd", "qdd", "tau", "q_err")}
    units["z"] = ()
    qd = np.gradient(q, t, axis=0)
    return SimulationResult(t=t, q=q, qd=qd, qdd=np.gradient(qd, t, axis=0),
                            tau=np.ones((n, 3)) if tau is None else tau, z=np.zeros((n, 0)),
                            signals={"q_err": q_err}, labels=labels, units=units,
                            meta={"scenario": "handmade", **(meta or {})}, status=status,
                            diagnosis="" if status == "ok" else f"simulation {status} at t = {t[-1]:g} s")


def _step(t):
    """A damped step response per joint: e(t) = e^{−t}(cos 3t) (overshoots), and joint 2 at
    rounding level (1e-17 noise)."""
    rng = np.random.default_rng(1)
    e = np.exp(-t)[:, None] * np.cos(3 * t)[:, None] * np.ones((1, 3))
    e[:, 1] = 1e-17 * rng.normal(size=t.size)
    return e


def test_a_diverged_run_has_no_metrics_and_its_scopes_stop_before_the_blow_up():
    t = np.linspace(0.0, 2.0, 401)
    q = np.sin(t)[:, None] * np.ones((1, 3))
    q[-5:] *= 10.0 ** np.arange(1, 6)[:, None] * 1e3  # the last samples run away to 1e8
    result = _result(t, q, q.copy(), status="diverged", tau=q.copy())
    assert measure(result) == []
    kept, note = before_divergence(result)
    assert len(kept.t) < len(t) - 4 and "blow-up" in note
    early = np.abs(q[:200]).max()
    for scope in scope_layout(result):
        assert note in scope.caption
        for panel in scope.panels:
            for _, times, values, _ in panel.curves:
                assert times[-1] < t[-5]
                assert np.nanmax(np.abs(values)) <= 3.0 * early + 1e-9, scope.name


def test_a_run_that_did_not_diverge_is_drawn_whole():
    t = np.linspace(0.0, 2.0, 401)
    q = np.exp(3 * t)[:, None] * np.ones((1, 3))   # grows, but the run ended as planned
    result = _result(t, q, q.copy())
    assert before_divergence(result) == (result, "")
    assert measure(result)


def test_rounding_residue_reads_zero_to_rounding_and_gets_no_response_numbers():
    t = np.linspace(0.0, 6.0, 1201)
    e = _step(t)
    tau = np.ones((t.size, 3))
    tau[:, 1] = 2e-15 * np.sin(t)
    metrics = measure(_result(t, e, e, tau=tau))
    theta = [m for m in metrics if m.component == "θ2"]
    assert {m.value for m in theta} == {ZERO_TO_ROUNDING}
    assert {m.quantity for m in theta} == {"steady-state q_err (mean, last 5 %)", "peak |τ|"}
    # The real components keep their numbers: overshoot by its definition, from the data.
    overshoot = next(m.value for m in metrics if m.quantity == "overshoot of q_err" and m.component == "d1")
    final = e[t >= t[-1] - 0.05 * t[-1], 0].mean()
    expected = 100 * np.max(-(e[:, 0] - final)) / abs(e[0, 0] - final)
    assert np.isclose(overshoot, expected)


def test_a_periodic_run_has_no_steady_state_but_rms_and_peak_over_its_second_half():
    t = np.linspace(0.0, 10.0, 2001)
    e = 0.2 * np.sin(2 * t)[:, None] * np.ones((1, 3)) - 0.05
    meta = {"controller": {"type": "JointPDGravity", "reference": {"type": "Sinusoid"}}}
    metrics = measure(_result(t, e, e, meta=meta))
    quantities = {m.quantity for m in metrics}
    assert not any(q.startswith(("steady-state", "oscillation", "settling", "overshoot")) for q in quantities)
    half = e[t.size // 2:, 0]
    rms = next(m.value for m in metrics if m.quantity == "RMS q_err (2nd half)" and m.component == "d1")
    peak = next(m.value for m in metrics if m.quantity == "peak |q_err| (2nd half)" and m.component == "d1")
    assert np.isclose(rms, np.sqrt(np.mean(half ** 2))) and np.isclose(peak, np.abs(half).max())
    disturbed = {"disturbance": [{"type": "SinusoidalTorque", "amplitude": [0, 0.05, 0.5], "omega": 3.0}]}
    assert not any(m.quantity.startswith("steady-state") for m in measure(_result(t, e, e, meta=disturbed)))


def _notation_row(tag: str) -> str:
    """The equation cell of ``tag``'s row in docs/notation.md, read here line by line."""
    from armlab.viz.notes import DOCS

    for line in (DOCS / "notation.md").read_text(encoding="utf-8").splitlines():
        if line.startswith(f"| {tag} |"):
            return line.split(" | ")[1].strip()
    raise AssertionError(tag)


def test_the_tag_legend_defines_each_tag_from_its_source():
    import armlab.theory
    from armlab.viz.tags import legend

    rows = legend("the law (C2) settles where (H1) says, x̃ of (T1), unlike T_3^0 or C2H")
    assert [(tag, source) for tag, source, _ in rows] == [("C2", "docs/notation.md"), ("H1", "armlab.theory"),
                                                          ("T1", "docs/notation.md")]
    assert rows[0][2] == _notation_row("C2").replace("`", "")
    assert "B̂(q) K_P q̃ + n̂(q, 0) = g(q)" in rows[1][2] and "B̂(q) K_P q̃" in armlab.theory.__doc__
    assert rows[2][2] == _notation_row("T1").replace("`", "")


def test_every_tag_has_one_definition_source_and_every_prediction_s_tag_is_the_theory_s():
    """A tag (letter + number) is defined by the notation table or by armlab.theory, never
    both, and the two sets share no letter; H1–H6 are each stated once in armlab.theory (the
    statics (H6) too, which a bullet of (H3) used to swallow), and the tag of every prediction
    the report prints is one of them."""
    import re

    import armlab.theory
    from armlab.viz.tags import TAG, notation_tags, theory_tags

    notation, theory = notation_tags(), theory_tags()
    assert notation and sorted(theory) == [f"H{k}" for k in range(1, 7)]
    assert not set(notation) & set(theory)
    assert not {t[0] for t in notation} & {t[0] for t in theory}
    # Each defining line of armlab.theory's docstring is found once, and each statement is its own.
    ends = re.findall(r"\s{3,}\((H\d)\)\s*$", armlab.theory.__doc__, flags=re.M)
    assert sorted(ends) == sorted(theory)
    assert "closed-loop statics" in theory["H6"] and "x_e = (K_P + K)⁻¹" in theory["H3"]
    assert "Admittance" not in theory["H4"] and "(H6)" in theory["H3"]
    # Every tag of a notation row and of the theory is matched by the report's tag pattern.
    assert all(TAG.fullmatch(tag) for tag in (*notation, *theory))
    source = open(armlab.theory.__file__, encoding="utf-8").read()
    printed = set(re.findall(r'Prediction\(f?"[^"]*\((\w\d)[,)]', source)) | set(
        re.findall(r'tag = "\((\w\d)\)"', source))
    assert printed and printed <= set(theory), printed - set(theory)


def _contact_run(offset: float = 2e-4, force: float = 1.996) -> SimulationResult:
    """A compliance-like run: p_y settles ``offset`` above a spring's rest plane y_r = −0.2 while
    x_d asks for −0.1, pressing with ``force``."""
    t = np.linspace(0.0, 10.0, 2001)
    q = np.zeros((t.size, 3))
    rest = np.array([0.0, -0.2, 0.5])
    p = np.tile(rest, (t.size, 1))
    p[:, 1] += offset * (1 - np.exp(-3 * t))
    p[:, 2] = 0.4 + 0.1 * np.exp(-2 * t)
    h = np.zeros((t.size, 6))
    h[:, 1] = force * (1 - np.exp(-3 * t))
    stiffness = np.diag([0.0, 1e4, 0.0, 0.0, 0.0, 0.0])
    result = _result(t, q, q.copy(), meta={"environment": {"type": "Spring", "stiffness": stiffness.tolist(),
                                                           "rest_position": rest.tolist(),
                                                           "rest_rotation": np.eye(3).tolist()}})
    signals = {**result.signals, "p": p, "p_des": np.tile([0.0, -0.1, 0.4], (t.size, 1)), "h_e": h}
    labels = {**result.labels, "p": ("x", "y", "z"), "p_des": ("x", "y", "z"),
              "h_e": ("fx", "fy", "fz", "mux", "muy", "muz")}
    units = {**result.units, "p": ("m",) * 3, "p_des": ("m",) * 3, "h_e": ("N",) * 3 + ("N·m",) * 3}
    from dataclasses import replace

    return replace(result, signals=signals, labels=labels, units=units)


def test_an_equilibrium_near_the_rest_plane_is_printed_to_its_digits_and_zoomed():
    result = _contact_run()
    rows = {m.quantity: m for m in measure(result)}
    assert rows["final contact wrench h_e"].formatted() == "1.996"
    distance = next(m for q, m in rows.items() if q.startswith("final p_e − o_r"))
    tail = result.t >= result.t[-1] - 0.05 * (result.t[-1] - result.t[0])
    expected = 1e3 * (result.signals["p"][tail, 1].mean() + 0.2)
    assert distance.unit == "mm" and np.isclose(distance.value, expected) and distance.formatted() == "0.2"
    (scope,) = [s for s in scope_layout(result) if s.name == "p"]
    y = scope.panels[1]
    assert y.zoom is not None and y.zoom.ylim[0] < -0.2 < -0.1998 < y.zoom.ylim[1] < -0.19
    assert "+0.0002 from Σ_r" in y.note
    from armlab.viz.scopes import render_scope

    fig = render_scope(scope)
    (inset,) = fig.axes[1].child_axes
    levels = [line.get_ydata()[0] for line in inset.lines if len(set(line.get_ydata())) == 1]
    assert -0.2 in levels  # the rest plane drawn in the inset, beside the trace


def test_a_saturated_torque_panel_shows_the_band_not_the_commanded_peak():
    from dataclasses import replace

    t = np.linspace(0.0, 3.0, 3001)
    commanded = np.zeros((t.size, 3))
    commanded[:, 0] = 540.0 * np.exp(-20 * t) * np.cos(15 * t)  # the A7 ω_n = 60 kind of demand
    commanded[:, 2] = 30.0 * np.exp(-20 * t)                    # 1.5× its limit: drawn whole
    applied = np.clip(commanded, -20.0, 20.0)
    rest = np.zeros((t.size, 3))
    result = _result(t, rest, rest, tau=applied, meta={"torque_limit": 20.0})
    result = replace(result, signals={**result.signals, "tau_cmd": commanded},
                     labels={**result.labels, "tau_cmd": JOINTS}, units={**result.units, "tau_cmd": UNITS})
    (scope,) = [s for s in scope_layout(result) if s.name == "torques"]
    first, _, third = scope.panels
    assert first.ylim is not None and first.ylim[0] == -first.ylim[1]
    assert 20.0 < first.ylim[1] <= 1.35 * 20.0 + 1e-9
    assert "540" in first.note and "off-scale" in first.note
    assert third.ylim is None and {v for v, _ in third.hlines} == {20.0, -20.0}


def test_a_long_scope_title_is_wrapped_inside_the_figure_not_cut():
    from armlab.viz.layout import Panel, Scope
    from armlab.viz.scopes import render_scope

    t = np.linspace(0.0, 1.0, 50)
    panel = Panel("y [m]", curves=[("y", t, t, {})])
    title = ("p, its reference p_des and the compliant frame p_t, spring rest Σ_r, drawn for a scenario "
             "whose name is long enough to run past the figure's edge")
    fig = render_scope(Scope("p", title, [panel]), title_prefix="a13_admittance_regulation_variant")
    fig.canvas.draw()
    from matplotlib.text import Text

    (text,) = [a for a in fig.findobj(Text) if a.get_text().startswith("a13_admittance_regulation_variant")]
    box = text.get_window_extent(fig.canvas.get_renderer())
    assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1 and box.y1 <= fig.bbox.y1
    assert text.get_text().replace("\n", " ") == f"a13_admittance_regulation_variant: {title}"
    assert fig.axes[0].get_window_extent().y1 < box.y0  # the panel starts under the title


def test_a_note_taken_out_of_its_page_points_at_the_page_for_what_stood_above():
    from armlab.viz.notes import anchored

    page = "docs/A6-joint-pd.md"
    text = ("K_P2 = 0.5 does not meet it (see above); the output above gives two branches, "
            "with x_d above the surface and y_d above its rest plane, 2 mm above 0.1 m.")
    out = anchored(text, page)
    assert out.count(f"above in {page}") == 2
    assert "(see above in docs/A6-joint-pd.md)" in out
    assert "the output above in docs/A6-joint-pd.md gives" in out
    assert "x_d above the surface" in out and "above its rest plane" in out and "above 0.1 m" in out
    assert anchored(out, page) == out  # already anchored: unchanged


def test_a_wide_metrics_table_scrolls_in_its_article_and_keeps_a_wrench_s_columns_together():
    """A contact run's table: h_e gives fy (fx, fz are zero), the rest distance p_e, then the
    theory's f_e (fx, fy, fz); the force columns are fx, fy, fz side by side, and the table,
    wider than the article, sits in a box that scrolls sideways."""
    import re

    from armlab.theory import Prediction
    from armlab.viz import html
    from armlab.viz.experiments import Experiment
    from armlab.viz.report import _experiment_html, metric_table

    force = Prediction("equilibrium contact force f_e", ("fx", "fy", "fz"), np.array([0.0, 1.996, 0.0]),
                       ("N",) * 3, lambda r: np.array([0.0, 1.996, 0.0]))
    metrics = measure(_contact_run(), [force])
    headers, _ = metric_table(metrics)
    forces = [k for k, h in enumerate(headers) if h in ("fx", "fy", "fz")]
    assert [headers[k] for k in forces] == ["fx", "fy", "fz"]
    assert forces == list(range(forces[0], forces[0] + 3)) and headers.index("p_e") > forces[-1]

    exp = Experiment("wide", 11, "A11 — wide", "", [("plant", "prp")], metrics=metrics)
    page = _experiment_html(exp)
    tables = re.findall(r"<table[ >]", page)
    boxed = re.findall(r'<div class="table-scroll"><table[ >]', page)
    assert len(tables) == 2 and len(boxed) == 2
    rule = re.search(r"\.table-scroll\s*\{([^}]*)\}", html.STYLE).group(1)
    assert "overflow-x: auto" in rule and "max-width: 100%" in rule


def test_the_seeds_sweeps_are_run_into_the_report_and_paged(tmp_path):
    """A11 "softer gets closer" and A8 "no visible change unless F₂ is increased a lot" are
    sweeps: a full report of the PRP runs them (resuming a folder it wrote before) and shows
    their pages."""
    from armlab.sweep import read_results
    from armlab.viz.sweeps import SEED_SWEEPS, seed_sweep_pages

    pages = seed_sweep_pages(SEED_SWEEPS, tmp_path, 2)
    assert [Path(folder).name for folder, _ in pages] == ["a11_stiffness", "a8_quadratic_friction"]
    for k, (folder, page) in enumerate(pages):
        assert f'id="sweep{2 + k}"' in page and "<img" in page
    a11 = read_results(tmp_path / "sweeps" / "a11_stiffness").to_pandas()
    a11 = a11.sort_values("environment.stiffness[2]")
    ok = a11[a11["status"] == "ok"]
    assert len(ok) >= 20
    assert np.all(np.diff(ok["position_error"].to_numpy()) > 0)       # softer: closer to x_d
    a8 = read_results(tmp_path / "sweeps" / "a8_quadratic_friction").to_pandas()
    a8 = a8.sort_values("disturbance[0].coefficient")
    small = a8[a8["disturbance[0].coefficient"] <= 0.3]["rms_error"].to_numpy()
    large = a8[(a8["disturbance[0].coefficient"] >= 10) & (a8["status"] == "ok")]["rms_error"].to_numpy()
    assert small.max() < 1.05 * small.min() and large.size and large.min() > 3 * small.max()
    again = seed_sweep_pages(SEED_SWEEPS, tmp_path, 2)          # resumed: the same pages
    assert [page for _, page in again] == [page for _, page in pages]


def test_a_bundled_sweeps_page_names_it_and_says_what_it_shows(tmp_path):
    from armlab.sweep import load_sweep
    from armlab.viz.sweeps import seed_sweep_pages

    (folder, page), = seed_sweep_pages(("a11_stiffness",), tmp_path, 0)
    assert "bundled sweep a11_stiffness; bundled scenario a11_compliance" in page
    assert str(Path(load_sweep("a11_stiffness").source).parent) not in page     # no installation path
    assert "act in series between x_d" in page                                   # its description
