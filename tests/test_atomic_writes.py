"""Atomic writes (armlab.files): concurrent writers of one output never corrupt it, a killed
writer leaves nothing partial, a failed write names the file and leaves nothing behind."""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from armlab.errors import ResultFileError
from armlab.files import PREFIX, replacing, sweep, write_text
from armlab.simulation.results import FORMATS, SimulationResult
from synthetic_results import assert_same, synthetic_result

SRC = Path(__file__).resolve().parents[1] / "src"
TESTS = Path(__file__).resolve().parent


def _env(tmp_path):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), str(TESTS), env.get("PYTHONPATH", "")])
    env.setdefault("ARMLAB_CACHE_DIR", str(tmp_path / "cache"))
    return env


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(PREFIX))


def test_a_failed_write_removes_its_temporary_file_and_raises_the_original_error(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="writer failed"), replacing(target) as temporary:
        temporary.write_text("half")
        raise RuntimeError("writer failed")
    assert target.read_text() == "old" and _leftovers(tmp_path) == []


def test_an_unwritable_folder_is_reported_with_the_target_name(tmp_path):
    target = tmp_path / "missing" / "out.txt"
    with pytest.raises(OSError) as caught:
        write_text(target, "x")
    assert caught.value.filename == str(target)
    with pytest.raises(ResultFileError, match=re.escape(str(tmp_path / "missing" / "r.csv"))):
        synthetic_result(1).save(tmp_path / "missing" / "r.csv")


def test_sweep_removes_temporary_files_of_dead_writers_only(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    (tmp_path / f"{PREFIX}{dead.stdout.strip()}.abc.run.csv").write_text("partial")
    live = tmp_path / f"{PREFIX}{os.getpid()}.def.run.csv"
    live.write_text("being written")
    (tmp_path / "run.csv").write_text("kept")
    sweep(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, "run.csv"])


CONCURRENT_SAVER = """
import sys
from pathlib import Path
from synthetic_results import synthetic_result
seed, folder = int(sys.argv[1]), Path(sys.argv[2])
result = synthetic_result(seed, rows=2000)
for _ in range(8):
    for suffix in (".npz", ".csv", ".parquet"):
        result.save(folder / f"run{suffix}")
"""


def test_concurrent_saves_into_one_folder_leave_one_writers_complete_file(tmp_path):
    # 3 processes × 8 saves of each format of their own result into the same three paths.
    out = tmp_path / "out"
    out.mkdir()
    env = _env(tmp_path)
    writers = [subprocess.Popen([sys.executable, "-c", CONCURRENT_SAVER, str(seed), str(out)], env=env,
                                stderr=subprocess.PIPE, text=True) for seed in range(3)]
    for writer in writers:
        _, errors = writer.communicate(timeout=240)
        assert writer.returncode == 0, errors
    candidates = [synthetic_result(seed, rows=2000) for seed in range(3)]
    for suffix in FORMATS:
        loaded = SimulationResult.load(out / f"run{suffix}")
        seed = loaded.meta["seed"]
        assert_same(loaded, candidates[seed])
    assert sorted(p.name for p in out.iterdir()) == ["run.csv", "run.npz", "run.parquet"]


KILLED_WRITER = """
import sys
from armlab.files import write_text
target, size = sys.argv[1], 4_000_000
for i in range(10_000):
    write_text(target, chr(ord("a") + i % 26) * size)
"""


def test_a_writer_killed_at_random_moments_leaves_the_old_file_or_the_new_one(tmp_path):
    # What the report, URDF export, figures and generated modules rely on (armlab.files).
    target = tmp_path / "report.html"
    rng = random.Random(19)
    env = _env(tmp_path)
    for _ in range(6):
        writer = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(target)], env=env)
        time.sleep(rng.uniform(0.3, 1.2))
        writer.send_signal(signal.SIGKILL)
        writer.wait(timeout=30)
        if target.exists():
            text = target.read_text()
            assert len(text) == 4_000_000 and text == text[0] * len(text)
    write_text(target, "final")         # the next write clears what killed writers left
    assert target.read_text() == "final" and _leftovers(tmp_path) == []


def _cli(args, env):
    return subprocess.Popen([sys.executable, "-m", "armlab.cli", *args], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_kill_9_during_armlab_run_and_urdf_export_leaves_no_partial_file(tmp_path):
    env = _env(tmp_path)
    out = tmp_path / "runs"
    urdf = tmp_path / "prp.urdf"
    # A complete run first: it also fills the compile caches, so that the killed runs below
    # reach the writing stage within the random delays.
    run = ["run", "a7_id_mismatch", "--out", str(out), "--format", "npz,csv,parquet", "--t-final", "2"]
    first = _cli(run, env)
    assert first.wait(timeout=600) == 0, first.stderr.read()
    rng = random.Random(20)
    for _ in range(3):
        for args in (run, ["robots", "prp", "--urdf", str(urdf)]):
            process = _cli(args, env)
            time.sleep(rng.uniform(0.5, 3.5))
            process.send_signal(signal.SIGKILL)
            process.wait(timeout=60)
        for path in out.iterdir():
            if not path.name.startswith(PREFIX):
                SimulationResult.load(path)       # raises ResultFileError if partial
        if urdf.exists():
            assert urdf.read_text().rstrip().endswith("</robot>")
    last = _cli(run, env)
    assert last.wait(timeout=600) == 0, last.stderr.read()
    assert _leftovers(out) == []
    assert sorted(p.name for p in out.iterdir()) == ["a7_id_mismatch.csv", "a7_id_mismatch.npz",
                                                     "a7_id_mismatch.parquet"]


def test_every_writer_goes_through_armlab_files():
    # Files are written only by armlab.files; elsewhere a direct write would be non-atomic.
    direct = re.compile(r"\.write_(text|bytes)\(|open\([^)]*['\"][wa]b?['\"]|savefig\((?!buffer|temporary)")
    offenders = []
    for path in sorted((SRC / "armlab").rglob("*.py")):
        if path.name == "files.py":
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#")[0]
            if direct.search(code) and "temporary" not in code:
                offenders.append(f"{path.relative_to(SRC)}:{number}: {line.strip()}")
    assert offenders == []


def test_results_round_trip_with_every_status(tmp_path):
    for status in ("ok", "diverged", "interrupted", "stopped"):
        result = synthetic_result(7, status=status)
        for suffix in FORMATS:
            assert_same(SimulationResult.load(result.save(tmp_path / f"r{suffix}")), result)


def test_kill_9_during_armlab_report_keeps_the_previous_report_or_a_complete_new_one(tmp_path):
    """The issue's case: a good report in place, a report killed while it is written must not
    replace it by a partial or empty file."""
    env = _env(tmp_path)
    out = tmp_path / "report"
    out.mkdir()
    previous = "<!DOCTYPE html><html><body>the previous report</body></html>\n"
    (out / "report.html").write_text(previous, encoding="utf-8")
    rng = random.Random(7)
    for _ in range(2):
        process = _cli(["report", "--quick", "--quiet", "--no-animation", "--out", str(out)], env)
        time.sleep(rng.uniform(2.0, 25.0))
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=60)
        text = (out / "report.html").read_text(encoding="utf-8")
        assert text == previous or text.rstrip().endswith("</html>")
        for path in out.rglob("*"):
            if path.is_file() and not path.name.startswith(PREFIX):
                assert path.stat().st_size > 0, path
