"""``SimulationResult``: time-major closed-loop data with named signals, saved to NPZ/CSV/Parquet.

Every array is time-major and never squeezed: ``t`` (N,), ``q``, ``qd``, ``qdd``, ``tau``
(N, n), the controller state ``z`` (N, k) (k may be 0) and ``signals[name]`` (N, w).  Row i
holds the values at ``t[i]``; ``tau`` is the torque applied at the joints after saturation and
``qdd`` the plant's acceleration under it (disturbances included).  Each group has one label
and one unit per column (``labels[group]``, ``units[group]``).

Flat tables (``to_dataframe``, CSV, Parquet) name a column ``"<group>.<label>"``, e.g.
``q.theta2``, ``tau.d1``, ``q_err.d3``; ``t`` is the first column.

A run that diverged is still a result: ``status == "diverged"`` and ``diagnosis`` says what
diverged and when; the arrays stop at the last finite step.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armlab.errors import ResultFileError

_CORE = ("q", "qd", "qdd", "tau", "z")
FORMATS = (".npz", ".csv", ".parquet")


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
    status : "ok" or "diverged";  diagnosis : "" or what diverged and when
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
        """Write to ``.npz``, ``.csv`` or ``.parquet`` (chosen by the suffix); returns the path."""
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
        header = json.dumps(self._header(), default=_plain)
        # Written beside the target and renamed at the end, so a failure leaves no partial file.
        partial = path.with_name(f".{path.name}.partial")
        try:
            if suffix == ".npz":
                arrays = {"t": self.t, **{f"g_{g}": a for g, a in self.groups().items()}}
                with open(partial, "wb") as handle:
                    np.savez_compressed(handle, header=np.array(header), **arrays)
            elif suffix == ".csv":
                names, table = self.to_table()
                with open(partial, "w", encoding="utf-8") as handle:
                    handle.write("# armlab " + header + "\n")
                    handle.write(",".join(names) + "\n")
                    np.savetxt(handle, table, delimiter=",", fmt="%.17g")
            else:
                names, table = self.to_table()
                arrow = pa.table({name: table[:, i] for i, name in enumerate(names)})
                arrow = arrow.replace_schema_metadata({"armlab": header})
                pq.write_table(arrow, partial)
            partial.replace(path)
        except OSError as error:
            partial.unlink(missing_ok=True)
            raise ResultFileError(f"{path}: cannot be written ({error.strerror})") from None
        return path

    @classmethod
    def load(cls, path: str | Path) -> SimulationResult:
        """Read a file written by :meth:`save` (any of the three formats)."""
        path = Path(path)
        suffix = path.suffix.lower()
        if not path.is_file():
            raise ResultFileError(f"{path}: no such file")
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                header = json.loads(str(data["header"]))
                t = data["t"]
                groups = {g: data[f"g_{g}"] for g, _, _ in header["layout"]}
        elif suffix in (".csv", ".parquet"):
            if suffix == ".csv":
                with open(path, encoding="utf-8") as handle:
                    first = handle.readline()
                    if not first.startswith("# armlab "):
                        raise ResultFileError(f"{path}: not an armlab result (no '# armlab' header)")
                    header = json.loads(first[len("# armlab "):])
                    handle.readline()
                    table = np.loadtxt(handle, delimiter=",", ndmin=2)
            else:
                import pyarrow.parquet as pq

                arrow = pq.read_table(path)
                metadata = arrow.schema.metadata or {}
                if b"armlab" not in metadata:
                    raise ResultFileError(f"{path}: not an armlab result (no armlab metadata)")
                header = json.loads(metadata[b"armlab"])
                table = np.column_stack([arrow.column(i).to_numpy() for i in range(arrow.num_columns)])
            t = table[:, 0].copy()
            groups, start = {}, 1
            for group, labels, _ in header["layout"]:
                groups[group] = np.ascontiguousarray(table[:, start:start + len(labels)])
                start += len(labels)
        else:
            raise ResultFileError(f"{path}: unknown format {suffix!r} (use {', '.join(FORMATS)})")
        labels = {g: tuple(lb) for g, lb, _ in header["layout"]}
        units = {g: tuple(u) for g, _, u in header["layout"]}
        core = {name: groups.pop(name) for name in _CORE}
        return cls(t=t, **core, signals=groups, labels=labels, units=units, meta=header["meta"],
                   status=header["status"], diagnosis=header["diagnosis"])
