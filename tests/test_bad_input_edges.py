"""Bad input found by trying armlab as a new user would, each an exit code 2 and one line (not
an internal error), and results that must not claim success: a Dask scheduler address that
cannot be used, a random range whose width overflows, a full disk under ``armlab run``, a run
that logs a value that is not finite."""

from __future__ import annotations

import errno

import numpy as np
import pytest

import armlab
from armlab.cli import BAD_INPUT, main
from armlab.control.function import FunctionController
from armlab.errors import SweepFileError
from armlab.simulation.results import SimulationResult
from armlab.sweep import load_sweep_file

SWEEP = """
scenario = "a7_id_high_gain"
{extra}
[set]
"simulation.t_final" = 0.01
[grid]
"controller.kp" = {{ values = [100, 200] }}
"""


@pytest.mark.parametrize("address", ["junk", "http://localhost:8786", "[::1", "tls://localhost:8786",
                                     "ucx://localhost:8786"])
def test_an_unusable_scheduler_address_is_bad_input_naming_the_option(tmp_path, capfd, address):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (the 'cluster' extra)")
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.format(extra=""), encoding="utf-8")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet",
                 "--scheduler", address]) == BAD_INPUT
    err = capfd.readouterr().err.strip()
    assert err.startswith("armlab sweep: error: --scheduler: cannot use the Dask scheduler "
                          f"{address!r}") and len(err.splitlines()) == 1, err


def test_a_scheduler_of_the_sweep_file_is_named_by_its_field(tmp_path):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (the 'cluster' extra)")
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.format(extra='[cluster]\nscheduler = "junk"'), encoding="utf-8")
    from armlab.sweep import sweep

    with pytest.raises(SweepFileError, match=r"s\.toml: cluster\.scheduler: cannot use the Dask scheduler"):
        sweep(load_sweep_file(path), tmp_path / "out", progress=False)


@pytest.mark.parametrize("draw, reason", [("uniform = [-1e308, 1e308]", "b − a overflows"),
                                          ("normal = [1e308, 1e307]", "beyond the range of a float")])
def test_random_ranges_whose_draws_overflow_are_refused(tmp_path, capfd, draw, reason):
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.format(extra=f"seed = 1\nruns = 2\n[random]\nx = {{ {draw} }}"), encoding="utf-8")
    with pytest.raises(SweepFileError, match=reason):
        load_sweep_file(path)
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == BAD_INPUT
    assert "internal error" not in capfd.readouterr().err


def test_a_linspace_whose_spacing_overflows_is_refused(tmp_path, capfd):
    """numpy's linspace of [-1e308, 1e308] gives [nan, inf, 1e308] (last - first overflows):
    refused naming the field, not three runs of which two are invalid and one diverged."""
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.replace("values = [100, 200]", "linspace = [-1e308, 1e308, 3]").format(extra=""),
                    encoding="utf-8")
    with pytest.raises(SweepFileError, match=r"grid\.controller\.kp\.linspace: last - first = .* overflows"):
        load_sweep_file(path)
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == BAD_INPUT
    assert len(capfd.readouterr().err.strip().splitlines()) == 1


def test_run_on_a_full_disk_says_nothing_of_success(tmp_path, capfd, monkeypatch):
    """The first write fails as on a full disk (ENOSPC): one error line, exit 2, and no "done"
    before it."""
    def full(self, path):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(SimulationResult, "save", full)
    assert main(["run", "a6_pd_online", "--t-final", "0.05", "--out", str(tmp_path)]) == BAD_INPUT
    out, err = capfd.readouterr()
    assert "done" not in out + err and "wrote" not in out, err
    assert err.strip().splitlines()[-1].endswith("No space left on device"), err


def test_run_says_done_after_writing(tmp_path, capfd):
    from armlab.cli import OK

    assert main(["run", "a6_pd_online", "--t-final", "0.05", "--out", str(tmp_path)]) == OK
    assert "done in" in capfd.readouterr().err and (tmp_path / "a6_pd_online.npz").is_file()


def _inf_after(t_switch):
    def law(t, q, qd):
        tau = np.zeros(q.shape[0])
        if t >= t_switch:
            tau[1] = np.inf
        return tau
    return law


def test_a_run_that_logs_a_non_finite_value_has_diverged():
    """An infinite command saturated by the torque limit leaves the state finite (the loop's
    own checks pass) but logs tau_cmd = inf: not an "ok" run."""
    robot = armlab.load_robot("planar2r")
    controller = FunctionController(model=robot, law=_inf_after(0.05))
    result = armlab.simulate(robot, controller, q0=np.zeros(2), t_final=0.1, dt=1e-3, torque_limit=1.0,
                             on_divergence="return")
    assert result.status == "diverged"
    assert "non-finite tau_cmd (theta2)" in result.diagnosis and "t = 0.05 s" in result.diagnosis
    assert len(result.t) == 50 and np.all(np.isfinite(result.signals["tau_cmd"]))
    with pytest.raises(armlab.SimulationDiverged, match="non-finite tau_cmd"):
        armlab.simulate(robot, controller, q0=np.zeros(2), t_final=0.1, dt=1e-3, torque_limit=1.0)
    finite = FunctionController(model=robot, law=_inf_after(1.0))
    ok = armlab.simulate(robot, finite, q0=np.zeros(2), t_final=0.1, dt=1e-3, torque_limit=1.0)
    assert ok.status == "ok"


@pytest.mark.parametrize("address, problem", [
    ("tcp://127.0.0.1:8786", None), ("localhost:8786", None), ("[::1]:8786", None),
    ("ws://scheduler.example.org:1", None), ("junk", "no port"), ("http://h:1", "unsupported scheme"),
    ("[::1", "closing bracket"), ("[::g]:1", "not an IPv6 address"), ("::1:8786", "in brackets"),
    ("h_x:1", "not a host name"), ("h:0", "not an integer in 1…65535"), ("h:65536", "1…65535"),
    ("h:１", "1…65535"), ("ucx://h:1", "unsupported scheme"), ("inproc://h:1", "unsupported scheme")])
def test_scheduler_addresses_are_checked_before_dask_sees_them(address, problem):
    """Dask's client on a malformed address can leave its event-loop thread behind (the next
    client of the process then waits for a loop that never starts), so the form is checked
    first; a well-formed address is left to Dask to connect to."""
    from armlab.sweep.address import address_problem

    found = address_problem(address)
    assert (found is None) if problem is None else (problem in found), found
