"""A sweep's output folder: a Parquet dataset written one task at a time, resumable.

Layout of ``DIR``::

    manifest.json                    what the sweep is (its fingerprint, runs, chunks, columns)
    runs/part-000000.parquet         the rows of chunk 0 (runs 0 … chunk_size − 1), one row per run
    runs/part-000001-000004.parquet  the rows of chunks 1 to 4, written together (one task)
    …

A file holds the consecutive chunks of one task (its name: the first and, for more than one,
the last chunk).  It is written under a temporary name and renamed (``os.replace``, atomic on
one file system), so a file that exists is complete; a sweep interrupted at any moment
(Ctrl-C, kill -9, a lost machine) leaves only whole files and maybe a temporary file, which
the next start deletes.  Resuming runs exactly the chunks no file holds, so every run is in
exactly one file.  The manifest's fingerprint (``SweepSpec.fingerprint``) must match: the
folder of another sweep, or of the same file since edited, is refused rather than mixed.

The dataset is read back with :meth:`SweepStore.read` (a ``pyarrow.Table`` sorted by run) or
any Parquet reader (``pandas.read_parquet(DIR / "runs")``).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from armlab.errors import SweepStoreError
from armlab.sweep.metrics import METRICS

FORMAT = 1
_PART = re.compile(r"^part-(\d{6,})(?:-(\d{6,}))?\.parquet$")


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        raise SweepStoreError("a sweep writes Parquet: install pyarrow "
                              "(pip install 'armlab[sweep]')") from None
    return pyarrow, pyarrow.parquet


def schema(spec):
    """The table's columns: run, the parameters, status, diagnosis, the metrics."""
    pa, _ = _pyarrow()
    fields = [pa.field("run", pa.int64())]
    axes = {a.key: a for a in spec.grid + spec.zipped + spec.random}
    for name in spec.parameter_names:
        axis = axes.get(name)
        text = axis is not None and any(isinstance(v, str) for v in axis.values)
        fields.append(pa.field(name, pa.string() if text else pa.float64()))
    fields += [pa.field("status", pa.string()), pa.field("diagnosis", pa.string())]
    fields += [pa.field(name, pa.float64()) for name, _ in METRICS]
    return pa.schema(fields)


class SweepStore:
    """The output folder of one sweep (see the module docstring)."""

    def __init__(self, folder, spec):
        self.folder = Path(folder)
        self.runs = self.folder / "runs"
        self.spec = spec
        self.schema = schema(spec)

    def manifest(self) -> dict:
        spec = self.spec
        return {"format": FORMAT, "fingerprint": spec.fingerprint(), "name": spec.name, "title": spec.title,
                "source": spec.source, "scenario": spec.scenario_file, "seed": spec.seed,
                "n_runs": spec.n_runs, "chunk_size": spec.chunk_size, "n_chunks": spec.n_chunks,
                "parameters": list(spec.parameter_names), "metrics": [list(m) for m in METRICS]}

    def open(self, *, overwrite: bool = False) -> set[int]:
        """Make or reopen the folder; returns the chunks already complete (none if
        ``overwrite``, which deletes the chunk files of an earlier sweep first)."""
        try:
            self.runs.mkdir(parents=True, exist_ok=True)
            manifest_path = self.folder / "manifest.json"
            if manifest_path.exists() and not overwrite:
                try:
                    old = json.loads(manifest_path.read_text(encoding="utf-8"))
                except (ValueError, UnicodeDecodeError):
                    raise SweepStoreError(f"{manifest_path}: is not a sweep manifest") from None
                if not isinstance(old, dict) or old.get("fingerprint") != self.spec.fingerprint():
                    raise SweepStoreError(
                        f"{self.folder}: holds the results of another sweep (or of this file before an "
                        "edit); choose another output folder or overwrite it")
            else:
                for folder in (self.runs, self.folder / "signals"):
                    for path in folder.glob("part-*.parquet"):
                        path.unlink()
            for folder in (self.runs, self.folder / "signals"):
                for path in folder.glob(".*.tmp"):
                    path.unlink()  # a chunk whose writer was interrupted: it runs again
            self._write_atomic(manifest_path, json.dumps(self.manifest(), indent=1).encode())
            return self.completed()
        except OSError as error:
            raise SweepStoreError(f"{self.folder}: cannot be used ({error.strerror or error})") from None

    def completed(self) -> set[int]:
        """The chunks whose rows a file holds."""
        done = set()
        for path in self.runs.iterdir():
            chunks = chunks_of(path.name)
            if chunks and chunks.stop <= self.spec.n_chunks:
                done.update(chunks)
        return done

    def write(self, chunks: range, columns: dict[str, list], signals: dict | None = None) -> None:
        """Write the rows (``{column: values}``) of the consecutive ``chunks`` as one Parquet
        file, atomically; their decimated ``signals`` (``{column: array}``) first, into
        ``signals/``: the rows' file is what marks the chunks complete."""
        pa, _ = _pyarrow()
        name = part_name(chunks)
        if signals is not None:
            self._write_parquet(pa.table(signals), self.folder / "signals" / name)
        self._write_parquet(pa.Table.from_pydict(columns, schema=self.schema), self.runs / name)

    def _write_parquet(self, table, target: Path) -> None:
        _, pq = _pyarrow()
        temporary = target.with_name(f".{target.name}.{os.getpid()}.tmp")
        try:
            target.parent.mkdir(exist_ok=True)
            pq.write_table(table, temporary)
            os.replace(temporary, target)
        except OSError as error:
            raise SweepStoreError(f"{target}: cannot be written ({error.strerror or error})") from None

    def _write_atomic(self, path: Path, data: bytes) -> None:
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        temporary.write_bytes(data)
        os.replace(temporary, path)

    def read(self):
        """Every written row as one ``pyarrow.Table``, sorted by run."""
        return read_results(self.folder)


def part_name(chunks: range) -> str:
    """The file name of the consecutive ``chunks``: ``part-000005.parquet`` for one,
    ``part-000005-000009.parquet`` for chunks 5 to 9."""
    last = f"-{chunks[-1]:06d}" if len(chunks) > 1 else ""
    return f"part-{chunks[0]:06d}{last}.parquet"


def chunks_of(name: str) -> range | None:
    """The chunks the file ``name`` holds (the inverse of :func:`part_name`), or None."""
    match = _PART.match(name)
    if match is None:
        return None
    first = int(match.group(1))
    last = int(match.group(2)) if match.group(2) else first
    return range(first, last + 1) if last >= first else None


def read_signals(folder, runs=None):
    """The decimated signals a sweep kept (its ``[signals]`` table): a ``pyarrow.Table`` of
    rows (run, t, <signal>.<label> …) sorted by run and time; ``runs`` selects some runs."""
    pa, pq = _pyarrow()
    parts = sorted((Path(folder) / "signals").glob("part-*.parquet"))
    if not parts:
        raise SweepStoreError(f"{folder}: holds no signals (the sweep file has no [signals] table)")
    filters = None if runs is None else [("run", "in", list(runs))]
    try:
        table = pa.concat_tables([pq.read_table(p, filters=filters) for p in parts],
                                 promote_options="default")
    except (OSError, pa.ArrowInvalid) as error:
        raise SweepStoreError(f"{folder}: cannot be read ({error})") from None
    return table.sort_by([("run", "ascending"), ("t", "ascending")])


def read_results(folder):
    """The table of a sweep's output folder (``pyarrow.Table`` sorted by run)."""
    pa, pq = _pyarrow()
    runs = Path(folder) / "runs"
    parts = sorted(p for p in runs.glob("part-*.parquet") if _PART.match(p.name)) if runs.is_dir() else []
    if not parts:
        raise SweepStoreError(f"{folder}: holds no sweep results")
    try:
        table = pa.concat_tables([pq.read_table(p) for p in parts])
    except (OSError, pa.ArrowInvalid) as error:
        raise SweepStoreError(f"{folder}: cannot be read ({error})") from None
    return table.sort_by("run")
