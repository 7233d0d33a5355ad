"""``SimulationResult``: time-major closed-loop data with named signals, saved to NPZ/CSV/Parquet.

Every array is time-major and never squeezed: ``t`` (N,), ``q``, ``qd``, ``qdd``, ``tau``
(N, n), the controller state ``z`` (N, k) (k may be 0) and ``signals[name]`` (N, w).  Row i
holds the values at ``t[i]``; ``tau`` is the torque applied at the joints after saturation and
``qdd`` the plant's acceleration under it (disturbances included).  Each group has one label
and one unit per column (``labels[group]``, ``units[group]``).

Flat tables (``to_dataframe``, CSV, Parquet) name a column ``"<group>.<label>"``, e.g.
``q.theta2``, ``tau.d1``, ``q_err.d3``; ``t`` is the first column.

A run that diverged is still a result: ``status == "diverged"`` and ``diagnosis`` says what
diverged and when; the arrays stop at the last finite step.  A run that logged a value that is
not finite (NaN, ±inf: a state the loop's own checks let through, an acceleration of a chain
whose mass matrix overflowed) has diverged, whatever its loop reported
(:meth:`SimulationResult.first_nonfinite`).  A run stopped by Ctrl-C
(``"interrupted"``) or by a step budget (``"stopped"``) keeps its data the same way.

Files: ``save`` writes atomically (``armlab.files``) with a CRC-32 of header and data in the
header; ``load`` checks the container, the layout, every shape and the checksum, and raises
one ``ResultFileError`` (``file: what is wrong``) for anything else.
"""

from __future__ import annotations

import json
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armlab.errors import ResultFileError
from armlab.files import replacing

_CORE = ("q", "qd", "qdd", "tau", "z")
FORMATS = (".npz", ".csv", ".parquet")
STATUSES = ("ok", "diverged", "interrupted", "stopped")
"""``status`` of a result: complete, diverged, interrupted (Ctrl-C), stopped by a budget."""


def _plain(value):
    """JSON form of metadata values that are not JSON types (arrays, numbers, objects)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return repr(value)


@dataclass(frozen=True)
class SimulationResult:
    """Closed-loop data of one run (see the module docstring).

    Attributes
    ----------
    t : (N,) [s]
    q, qd, qdd : (N, n) joint positions [m | rad], velocities, accelerations
    tau : (N, n) applied joint torques/forces [N | N·m], after saturation
    z : (N, k) controller state
    signals : dict name → (N, w) array, the controller's (and the simulator's) logged signals
    labels, units : dict group → tuple of per-column labels / units, for q, qd, qdd, tau, z
        and every signal
    meta : JSON-able dict — scenario, plant and controller descriptions, integrator settings
    status : one of ``STATUSES``: "ok", "diverged", "interrupted" (Ctrl-C) or "stopped" (a step
        budget);  diagnosis : "" or what happened and when
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    z: np.ndarray
    signals: dict = field(default_factory=dict)
    labels: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    status: str = "ok"
    diagnosis: str = ""

    def __repr__(self) -> str:
        span = f", t = {self.t[0]:.6g} … {self.t[-1]:.6g} s" if len(self) else ""
        return (f"SimulationResult({len(self)} samples{span}, {self.n} joints, status={self.status!r}, "
                f"signals={list(self.signals)})")

    def _repr_html_(self) -> str:
        """The result in a notebook: a summary and its first scope as an inline PNG."""
        from armlab.viz.notebook import result_html

        return result_html(self)

    @property
    def n(self) -> int:
        return self.q.shape[1]

    def __len__(self) -> int:
        return self.t.shape[0]

    def groups(self) -> dict[str, np.ndarray]:
        """Every (N, w) array by group name, core arrays first, then signals."""
        out = {name: getattr(self, name) for name in _CORE}
        out.update(self.signals)
        return out

    def column(self, group: str, label: str) -> np.ndarray:
        """The (N,) column ``label`` of ``group``, e.g. ``result.column("q", "theta2")``."""
        data = self.groups()[group]
        return data[:, list(self.labels[group]).index(label)]

    def first_nonfinite(self) -> tuple[int, str, str] | None:
        """(row, group, label) of the first logged value that is NaN or ±inf (time first, then
        the groups in :meth:`groups` order), or None when every value is finite."""
        best = None
        if not np.all(np.isfinite(self.t)):
            best = (int(np.argmin(np.isfinite(self.t))), "t", "t")
        for name, data in self.groups().items():
            bad = ~np.isfinite(data)
            if not bad.any():
                continue
            rows = bad.any(axis=1)
            row = int(np.argmax(rows))
            if best is None or row < best[0]:
                column = int(np.argmax(bad[row]))
                labels = self.labels.get(name, ())
                best = (row, name, str(labels[column]) if column < len(labels) else str(column))
        return best

    def head(self, rows: int, **changes) -> SimulationResult:
        """The result of the first ``rows`` rows (views, no copies), with ``changes`` to its
        other fields (``status``, ``diagnosis``)."""
        fields = {**vars(self), **changes}
        for name in ("t", *_CORE):
            fields[name] = fields[name][:rows]
        fields["signals"] = {name: data[:rows] for name, data in self.signals.items()}
        return SimulationResult(**fields)

    def _layout(self) -> list:
        return [[g, list(self.labels[g]), list(self.units[g])] for g in self.groups()]

    def _header(self) -> dict:
        return {"layout": self._layout(), "meta": self.meta, "status": self.status,
                "diagnosis": self.diagnosis}

    def to_table(self) -> tuple[list[str], np.ndarray]:
        """Column names and the (N, 1 + Σ w) matrix of ``to_dataframe``."""
        names = ["t"]
        blocks = [self.t[:, None]]
        for group, data in self.groups().items():
            names += [f"{group}.{label}" for label in self.labels[group]]
            blocks.append(data)
        return names, np.hstack(blocks)

    def to_dataframe(self):
        """A pandas DataFrame, one row per sample, columns ``t`` and ``"<group>.<label>"``;
        units and metadata in ``df.attrs``."""
        import pandas as pd

        names, table = self.to_table()
        df = pd.DataFrame(table, columns=names)
        df.attrs.update(self._header())
        return df

    def save(self, path: str | Path) -> Path:
        """Write to ``.npz``, ``.csv`` or ``.parquet`` (chosen by the suffix); returns the path.

        The file appears complete or not at all (``armlab.files``: a temporary file renamed
        into place; concurrent saves to one path leave the last complete one).  Its header
        carries a CRC-32 of the header and the data (:func:`_checksum`), checked by
        :meth:`load`."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in FORMATS:
            raise ResultFileError(f"{path}: unknown format {suffix!r} (use {', '.join(FORMATS)})")
        if suffix == ".parquet":
            try:
                import pyarrow as pa
                import pyarrow.parquet as pq
            except ImportError:
                raise ResultFileError(f"{path}: Parquet needs pyarrow (pip install 'armlab[data]')") from None
        names, table = self.to_table()
        header = json.loads(json.dumps(self._header(), default=_plain))   # as load will see it
        header["crc32"] = _checksum(header, table)
        text = json.dumps(header)
        try:
            with replacing(path) as temporary:
                if suffix == ".npz":
                    arrays = {"t": self.t, **{f"g_{g}": a for g, a in self.groups().items()}}
                    with open(temporary, "wb") as handle:
                        np.savez_compressed(handle, header=np.array(text), **arrays)
                elif suffix == ".csv":
                    with open(temporary, "w", encoding="utf-8", newline="\n") as handle:
                        handle.write("# armlab " + text + "\n")
                        handle.write(",".join(names) + "\n")
                        np.savetxt(handle, table, delimiter=",", fmt="%.17g")
                else:
                    arrow = pa.table({name: table[:, i] for i, name in enumerate(names)})
                    pq.write_table(arrow.replace_schema_metadata({"armlab": text}), temporary)
        except OSError as error:
            raise ResultFileError(f"{path}: cannot be written ({error.strerror or error})") from None
        return path

    @classmethod
    def load(cls, path: str | Path) -> SimulationResult:
        """Read a file written by :meth:`save` (any of the three formats).

        Anything that is not such a file, intact, raises one :class:`ResultFileError` naming
        the file and what is wrong: unreadable or damaged containers, a header that does not
        describe the data (groups, labels, units, shapes), or data and header that do not match
        their checksum (a truncated or edited file)."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in FORMATS:
            raise ResultFileError(f"{path}: unknown format {suffix!r} (use {', '.join(FORMATS)})")
        if not path.is_file():
            raise ResultFileError(f"{path}: no such file")
        try:
            header, t, groups = _READERS[suffix](path)
        except ResultFileError:
            raise
        except MemoryError:
            raise ResultFileError(f"{path}: too large to load") from None
        except Exception as error:  # noqa: BLE001 — every reader fault of a damaged file
            # zipfile, zlib, numpy, json, pyarrow and the codecs each raise their own kinds;
            # whichever it is, the file is damaged and the user needs one line saying so.
            reason = (str(error).strip().splitlines() or [""])[0][:200]
            raise ResultFileError(f"{path}: damaged or not an armlab result "
                                  f"({type(error).__name__}: {reason})") from None
        return _checked(path, header, t, groups)


# --------------------------------------------------------------------------- file layouts

def _canonical(table: np.ndarray) -> bytes:
    """The table's bytes as every format gives them back: float64 little-endian, C order, one
    NaN (CSV writes every NaN as ``nan``)."""
    table = np.ascontiguousarray(table, dtype="<f8")
    if np.isnan(table).any():
        table = np.where(np.isnan(table), np.nan, table)
    return table.tobytes()


def _checksum(header: dict, table: np.ndarray) -> int:
    """CRC-32 of the header (without its ``crc32`` entry, as JSON) and of the data table."""
    text = json.dumps({k: v for k, v in header.items() if k != "crc32"})
    return zlib.crc32(_canonical(table), zlib.crc32(text.encode("utf-8")))


def _header_of(text, path) -> dict:
    header = json.loads(text)
    if not isinstance(header, dict):
        raise ResultFileError(f"{path}: header: not a JSON object")
    return header


def _read_npz(path):
    with np.load(path, allow_pickle=False) as data:
        if "header" not in data.files or "t" not in data.files:
            raise ResultFileError(f"{path}: not an armlab result (no header or time array)")
        header = _header_of(str(data["header"]), path)
        layout = _layout_of(header, path)
        names = {f"g_{group}" for group, _, _ in layout}
        extra = sorted(set(data.files) - names - {"header", "t"})
        if extra:
            raise ResultFileError(f"{path}: arrays not in the header's layout: {', '.join(extra)}")
        missing = sorted(names - set(data.files))
        if missing:
            raise ResultFileError(f"{path}: arrays of the layout missing: {', '.join(missing)}")
        return header, data["t"], {group: data[f"g_{group}"] for group, _, _ in layout}


def _read_csv(path):
    with open(path, "rb") as handle:
        first = handle.readline()
        if not first.startswith(b"# armlab "):
            raise ResultFileError(f"{path}: not an armlab result (no '# armlab' header)")
        header = _header_of(first[len(b"# armlab "):].decode("utf-8"), path)
        names = handle.readline().decode("utf-8").rstrip("\n").split(",")
        body = handle.read()
    if body and not body.endswith(b"\n"):
        raise ResultFileError(f"{path}: truncated (the last row is incomplete)")
    expected = _column_names(_layout_of(header, path))
    if names != expected:
        raise ResultFileError(f"{path}: columns {_differ(names, expected)}")
    rows = body.decode("utf-8").splitlines()
    table = np.loadtxt(rows, delimiter=",", ndmin=2, dtype=float) if rows else np.zeros((0, len(names)))
    return header, *_split(table, _layout_of(header, path), path)


def _read_parquet(path):
    import pyarrow.parquet as pq

    arrow = pq.read_table(path)
    metadata = arrow.schema.metadata or {}
    if b"armlab" not in metadata:
        raise ResultFileError(f"{path}: not an armlab result (no armlab metadata)")
    header = _header_of(metadata[b"armlab"].decode("utf-8"), path)
    layout = _layout_of(header, path)
    expected = _column_names(layout)
    if arrow.column_names != expected:
        raise ResultFileError(f"{path}: columns {_differ(arrow.column_names, expected)}")
    kinds = [str(field.type) for field in arrow.schema]
    if any(kind != "double" for kind in kinds):
        bad = next(i for i, kind in enumerate(kinds) if kind != "double")
        raise ResultFileError(f"{path}: column {expected[bad]!r} holds {kinds[bad]}, not float64")
    columns = [arrow.column(i).to_numpy() for i in range(arrow.num_columns)]
    table = np.column_stack(columns) if arrow.num_rows else np.zeros((0, len(expected)))
    return header, *_split(table, layout, path)


_READERS = {".npz": _read_npz, ".csv": _read_csv, ".parquet": _read_parquet}


def _differ(got: list, expected: list) -> str:
    missing = [n for n in expected if n not in got]
    extra = [n for n in got if n not in expected]
    if missing:
        return f"missing: {', '.join(missing[:5])}"
    if extra:
        return f"not in the header's layout: {', '.join(extra[:5])}"
    return "out of the header's order"


def _column_names(layout) -> list[str]:
    return ["t"] + [f"{group}.{label}" for group, labels, _ in layout for label in labels]


def _split(table, layout, path):
    """(t, groups) of a flat table whose columns follow ``layout``."""
    width = 1 + sum(len(labels) for _, labels, _ in layout)
    if table.ndim != 2 or table.shape[1] != width:
        raise ResultFileError(f"{path}: {table.shape[-1]} columns, the header describes {width}")
    groups, start = {}, 1
    for group, labels, _ in layout:
        groups[group] = np.ascontiguousarray(table[:, start:start + len(labels)])
        start += len(labels)
    return table[:, 0].copy(), groups


def _layout_of(header: dict, path) -> list:
    """The header's layout, checked: [[group, labels, units], …], unique group names, the core
    groups first, as many units as labels, all strings."""
    layout = header.get("layout")
    if not isinstance(layout, list):
        raise ResultFileError(f"{path}: header: no layout")
    seen = []
    for entry in layout:
        if not (isinstance(entry, list) and len(entry) == 3 and isinstance(entry[0], str)
                and all(isinstance(part, list) and all(isinstance(x, str) for x in part)
                        for part in entry[1:])):
            raise ResultFileError(f"{path}: header: layout entry {str(entry)[:80]} is not "
                                  "[group, [labels], [units]]")
        if len(entry[1]) != len(entry[2]):
            raise ResultFileError(f"{path}: header: group {entry[0]!r} has {len(entry[1])} labels "
                                  f"and {len(entry[2])} units")
        if entry[0] in seen:
            raise ResultFileError(f"{path}: header: group {entry[0]!r} appears twice")
        seen.append(entry[0])
    if tuple(seen[:len(_CORE)]) != _CORE:
        raise ResultFileError(f"{path}: header: the layout does not start with {', '.join(_CORE)}")
    return layout


def _checked(path, header, t, groups) -> SimulationResult:
    """The result of a file's parts once they agree with each other (see ``load``)."""
    layout = _layout_of(header, path)
    for key, kind in (("meta", dict), ("status", str), ("diagnosis", str), ("crc32", int)):
        if not isinstance(header.get(key), kind) or isinstance(header.get(key), bool):
            raise ResultFileError(f"{path}: header: {key}: missing or not a {kind.__name__}")
    if header["status"] not in STATUSES:
        raise ResultFileError(f"{path}: header: status {header['status']!r} is not one of "
                              f"{', '.join(STATUSES)}")
    t = np.asarray(t)
    if t.ndim != 1 or t.dtype.kind != "f":
        raise ResultFileError(f"{path}: t: expected a vector of times, got shape {t.shape} of {t.dtype}")
    if not (np.isfinite(t).all() and np.all(np.diff(t) > 0)):
        raise ResultFileError(f"{path}: t: times are not finite and increasing")
    for group, labels, _ in layout:
        data = np.asarray(groups[group])
        if data.dtype.kind != "f" or data.shape != (t.shape[0], len(labels)):
            raise ResultFileError(f"{path}: {group}: shape {data.shape} of {data.dtype}, expected "
                                  f"({t.shape[0]}, {len(labels)}) floats (one row per time)")
    table = np.hstack([t[:, None]] + [np.asarray(groups[g], dtype=float) for g, _, _ in layout])
    if _checksum(header, table) != header["crc32"]:
        raise ResultFileError(f"{path}: checksum mismatch: the file was damaged or edited")
    labels = {g: tuple(lb) for g, lb, _ in layout}
    units = {g: tuple(u) for g, _, u in layout}
    groups = {g: np.ascontiguousarray(groups[g], dtype=float) for g, _, _ in layout}
    core = {name: groups.pop(name) for name in _CORE}
    return SimulationResult(t=np.ascontiguousarray(t, dtype=float), **core, signals=groups,
                            labels=labels, units=units, meta=header["meta"],
                            status=header["status"], diagnosis=header["diagnosis"])
