"""Damaged caches are detected, discarded and rebuilt (armlab.caches, armlab.specialise):
a truncated numba cache file, a truncated generated module; concurrent cold-cache runs give
identical results."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import armlab
from armlab.errors import CacheWarning
from armlab.scenarios import scenario_path
from armlab.simulation.results import SimulationResult
from armlab.specialise import closed_form

SRC = Path(__file__).resolve().parents[1] / "src"


PROBE = '''
from numba import njit

@njit(cache=True)
def twice(x):
    return 2.0 * x
'''

CALL = '''
import sys, warnings
sys.path.insert(0, sys.argv[1])
from armlab.caches import repaired
import probe_module
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    print(repaired(probe_module.twice, 21.0))
print(" | ".join(f"{w.category.__name__}: {w.message}" for w in seen))
'''


def test_a_truncated_numba_cache_file_is_discarded_and_rebuilt_with_one_warning(tmp_path):
    # A kernel of its own (not one the rest of the suite is loading meanwhile), cached under
    # NUMBA_CACHE_DIR in a folder whose path names armlab, as armlab's kernels are.
    folder = tmp_path / "armlab_probe"
    folder.mkdir()
    (folder / "probe_module.py").write_text(PROBE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}

    def call():
        done = subprocess.run([sys.executable, "-c", CALL, str(folder)], env=env, capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return done.stdout.splitlines()

    assert call() == ["42.0", ""]                          # compiled and cached
    cached = sorted((tmp_path / "numba").rglob("*.nbc"))
    assert cached
    for path in cached:
        path.write_bytes(path.read_bytes()[:200])
    value, seen = call()
    assert value == "42.0" and seen.startswith("CacheWarning: damaged compile cache (") and " | " not in seen
    rebuilt = sorted((tmp_path / "numba").rglob("*.nbc"))
    assert rebuilt and all(p.stat().st_size > 200 for p in rebuilt)   # written anew, whole
    assert call() == ["42.0", ""]                          # the rebuilt cache loads silently


def test_a_truncated_generated_module_is_generated_again_with_identical_results(tmp_path, monkeypatch):
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(closed_form, "_OUTCOMES", {})      # as a new process would start
    link1 = armlab.load_robot("link1")
    q, qd, qdd = np.array([0.3]), np.array([-0.5]), np.array([1.5])
    first = armlab.inverse_dynamics(link1, q, qd, qdd, dynamics="closed_form")
    (module,) = (tmp_path / "cache" / "closed_form").glob("*.py")
    text = module.read_text()
    for damaged in (text[: len(text) // 2], text.replace("tau_out[0] = ", "tau_out[0] = 1.0 + ", 1),
                    text + "x = 1\n"):
        module.write_text(damaged)
        monkeypatch.setattr(closed_form, "_OUTCOMES", {})
        fresh = armlab.load_robot("link1")                  # its own per-robot entries
        with pytest.warns(CacheWarning, match="generated module damaged or incomplete"):
            again = armlab.inverse_dynamics(fresh, q, qd, qdd, dynamics="closed_form")
        np.testing.assert_array_equal(again, first)
        assert module.read_text() == text
    np.testing.assert_allclose(first, armlab.inverse_dynamics(link1, q, qd, qdd), rtol=1e-12)


@pytest.mark.slow
def test_concurrent_cold_cache_runs_give_identical_results(tmp_path):
    # Three processes that all generate, write and compile the same closed form at once.
    text = scenario_path("a8_case1_sine").read_text(encoding="utf-8")
    text = text.replace("t_final = 50.0", 't_final = 2.0\ndynamics = "closed_form"')
    scenario = tmp_path / "cold.toml"
    scenario.write_text(text, encoding="utf-8")
    env = {**os.environ, "ARMLAB_CACHE_DIR": str(tmp_path / "empty-cache"),
           "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    runs = [subprocess.Popen([sys.executable, "-m", "armlab.cli", "run", str(scenario), "--out",
                              str(tmp_path / f"out{i}"), "--format", "npz", "--quiet"], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) for i in range(3)]
    for run in runs:
        _, errors = run.communicate(timeout=600)
        assert run.returncode == 0, errors
    results = [SimulationResult.load(tmp_path / f"out{i}" / "cold.npz") for i in range(3)]
    assert {r.meta["dynamics"] for r in results} == {"closed_form"}
    for other in results[1:]:
        for name, array in results[0].groups().items():
            np.testing.assert_array_equal(other.groups()[name], array, err_msg=name)
    assert [p.name for p in (tmp_path / "empty-cache" / "closed_form").iterdir()
            if p.name.startswith(".armlab-tmp")] == []


def test_the_cli_leaves_the_warnings_module_as_it_found_it(capsys):
    from armlab.cli import main

    before = warnings.showwarning
    assert main(["scenarios"]) == 0
    assert warnings.showwarning is before


def test_an_unwritable_cache_folder_falls_back_to_a_private_one_with_a_warning(tmp_path, monkeypatch):
    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(blocked))
    with pytest.warns(CacheWarning, match="cache folder cannot be written"):
        folder = closed_form._writable_folder()
    assert folder == closed_form._private_folder() and folder.is_dir()
    assert blocked.read_text() == "not a folder"


FULL_DISK = '''
import resource, signal, sys, warnings
# Writes beyond 2 kB fail (EFBIG) as on a full disk, where numba's cache check (creating an
# empty file) still passes and only the save of a compiled kernel fails.
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (2000, resource.RLIM_INFINITY))
sys.path.insert(0, sys.argv[1])
from armlab.caches import repaired
import probe_module
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    print(repaired(probe_module.quad, 1.5), repaired(probe_module.quad, 2.5))
print(" | ".join(f"{w.category.__name__}: {w.message}" for w in seen))
'''


@pytest.mark.skipif(sys.platform == "win32", reason="resource limits are POSIX")
def test_a_cache_that_cannot_be_written_degrades_to_compiling_in_memory_with_a_warning(tmp_path):
    folder = tmp_path / "armlab_probe"
    folder.mkdir()
    (folder / "probe_module.py").write_text(PROBE + "\n\n@njit(cache=True)\ndef quad(x):\n"
                                            "    return twice(twice(x))\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONDONTWRITEBYTECODE": "1",
           "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", FULL_DISK, str(folder)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    values, seen = done.stdout.splitlines()
    assert values == "6.0 10.0"
    assert seen.startswith("CacheWarning: the compile cache cannot be written") and " | " not in seen
    assert "compiling in memory" in seen
