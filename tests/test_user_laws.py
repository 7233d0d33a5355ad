"""A user's control law, declared in this file alone, runs in the compiled loop unchanged and is
named from a scenario file (through the ``armlab.scenario_types`` entry point of a package):
a joint PID with back-calculation anti-windup and its own inverse-dynamics feed-forward, which
calls the model's dynamics by name, against a plain-Python twin written with the public API."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from numba import njit

import armlab
from armlab import registry
from armlab.control.base import Controller, Signal
from armlab.control.entry import generated_entry
from armlab.control.function import FunctionController
from armlab.kernels.dynamics import DynamicsWorkspace, make_workspace, rnea_into
from armlab.model.robot import Robot, RobotArrays
from armlab.references.joint import JointReference, reference_into
from armlab.registry import scenario_type
from armlab.scenarios import ScenarioFileError, load_scenario_file
from armlab.simulation.results import SimulationResult

PRP = armlab.load_robot("prp")
HERE = Path(__file__).resolve().parent


class JointPIDParams(NamedTuple):
    model: RobotArrays              # the controller's model (its RNEA gives the feed-forward)
    workspace: DynamicsWorkspace    # scratch of rnea_into
    reference: np.ndarray           # a writeable copy of JointReference.data
    kp: np.ndarray                  # (n,) [N/m | N·m/rad]
    ki: np.ndarray                  # (n,) [N/(m·s) | N·m/(rad·s)]
    kd: np.ndarray                  # (n,) [N·s/m | N·m·s/rad]
    tau_max: np.ndarray             # (n,) the law's own torque limit [N | N·m]
    k_aw: float                     # back-calculation gain [m/N | rad/(N·m)]
    no_wrench: np.ndarray           # (6,) zeros: h_e of the feed-forward
    q_des: np.ndarray               # (n,) scratch: q_des(t)
    qd_des: np.ndarray              # (n,) scratch
    qdd_des: np.ndarray             # (n,) scratch
    feedforward: np.ndarray         # (n,) scratch: τ_ff


@njit(cache=True)
def joint_pid_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """τ_u = τ_ff + K_P e + K_I z + K_D ė,  τ = clip(τ_u, ±τ_max),  ż = e − k_aw (τ_u − τ),
    e = q_des − q,  τ_ff = B(q_des) q̈_des + n(q_des, q̇_des) (the model's RNEA, by name)."""
    m, ws, ref = params.model, params.workspace, params.reference
    kp, ki, kd, tau_max, k_aw = params.kp, params.ki, params.kd, params.tau_max, params.k_aw
    q_des, qd_des, qdd_des, ff = params.q_des, params.qd_des, params.qdd_des, params.feedforward
    n = q.shape[0]
    reference_into(ref, t, q_des, qd_des, qdd_des)
    rnea_into(m, ws, q_des, qd_des, qdd_des, 1.0, params.no_wrench, ff)
    for i in range(n):
        error = q_des[i] - q[i]
        unsaturated = ff[i] + kp[i] * error + ki[i] * z[i] + kd[i] * (qd_des[i] - qd[i])
        tau = min(max(unsaturated, -tau_max[i]), tau_max[i])
        tau_out[i] = tau
        zdot_out[i] = error - k_aw * (unsaturated - tau)
        signals_out[i] = error
        signals_out[n + i] = unsaturated - tau


@scenario_type("joint_pid_antiwindup")
@dataclass(frozen=True, eq=False)
class JointPID(Controller):
    """Joint PID with anti-windup and inverse-dynamics feed-forward (see ``joint_pid_law``)."""

    model: Robot
    reference: JointReference
    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray
    tau_max: np.ndarray
    k_aw: float = 0.01
    law = joint_pid_law

    def params(self):
        n = self.n
        vector = lambda value: np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()  # noqa: E731
        return JointPIDParams(
            model=self.model.arrays, workspace=make_workspace(n), reference=np.array(self.reference.data),
            kp=vector(self.kp), ki=vector(self.ki), kd=vector(self.kd), tau_max=vector(self.tau_max),
            k_aw=float(self.k_aw), no_wrench=np.zeros(6), q_des=np.zeros(n), qd_des=np.zeros(n),
            qdd_des=np.zeros(n), feedforward=np.zeros(n))

    def initial_state(self):
        return np.zeros(self.n)

    def state_labels(self):
        return tuple(f"integral_{name}" for name in self.model.joint_names)

    def signals(self):
        return (Signal.joint("q_err", self.model, "error"), Signal.joint("windup", self.model, "effort"))


SCENARIO = """\
title = "A user's joint PID with anti-windup"
plant = "prp"

[simulation]
t_final = 2.0
dt = 0.001
q0 = [0, 0, 0]

[controller]
type = "joint_pid_antiwindup"
kp = [400, 60, 400]
ki = [800, 120, 800]
kd = [40, 8, 40]
tau_max = [12, 3, 12]
k_aw = 0.05

[controller.reference]
type = "sinusoid"
center = [0.1, 0.6, 0.12]
amplitude = [0.02, 0.2, 0.02]
omega = [2, 3, 2]
"""
CENTER, AMPLITUDE, OMEGA = np.array([0.1, 0.6, 0.12]), np.array([0.02, 0.2, 0.02]), np.array([2.0, 3.0, 2.0])
KP, KI, KD = np.array([400.0, 60, 400]), np.array([800.0, 120, 800]), np.array([40.0, 8, 40])
TAU_MAX, K_AW = np.array([12.0, 3, 12]), 0.05


def python_twin(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """The same law in NumPy: the reference written out, the feed-forward by the public
    ``armlab.inverse_dynamics``."""
    q_des = CENTER + AMPLITUDE * np.sin(OMEGA * t)
    qd_des = AMPLITUDE * OMEGA * np.cos(OMEGA * t)
    qdd_des = -AMPLITUDE * OMEGA**2 * np.sin(OMEGA * t)
    feedforward = armlab.inverse_dynamics(PRP, q_des, qd_des, qdd_des)
    error = q_des - q
    unsaturated = feedforward + KP * error + KI * z + KD * (qd_des - qd)
    tau = np.clip(unsaturated, -TAU_MAX, TAU_MAX)
    tau_out[:] = tau
    zdot_out[:] = error - K_AW * (unsaturated - tau)
    signals_out[:3] = error
    signals_out[3:] = unsaturated - tau


@pytest.fixture
def scenario_file(tmp_path):
    path = tmp_path / "user_pid.toml"
    path.write_text(SCENARIO)
    return path


def test_a_users_law_from_a_scenario_file_runs_compiled_and_matches_its_python_twin(scenario_file):
    scenario = load_scenario_file(scenario_file)
    assert type(scenario.controller) is JointPID
    assert generated_entry(joint_pid_law) is not None      # the compiled loop inlines it
    compiled = scenario.run()
    twin = FunctionController(PRP, python_twin, parameters=(), z0=np.zeros(3),
                              logged=tuple(JointPID.signals(scenario.controller)))
    plain = armlab.simulate(PRP, twin, q0=np.zeros(3), t_final=2.0, dt=1e-3)
    assert compiled.status == plain.status == "ok"
    windup = compiled.signals["windup"]
    assert np.abs(windup).max() > 1.0                      # the law's saturation was active
    assert np.abs(compiled.signals["q_err"][-200:]).max() < 5e-3     # and it tracks again (0.6 rad at t = 0)
    for name in ("q", "qd", "tau", "z"):
        np.testing.assert_allclose(getattr(compiled, name), getattr(plain, name), rtol=0, atol=1e-12,
                                   err_msg=name)
    np.testing.assert_allclose(windup, plain.signals["windup"], rtol=0, atol=1e-12)


def _package(folder: Path, value: str) -> Path:
    """An installed package's metadata declaring ``value`` in the armlab.scenario_types group."""
    info = folder / "armlab_user_laws-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: armlab-user-laws\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[armlab.scenario_types]\nuser_laws = {value}\n")
    return folder


def _armlab_run(scenario: Path, out: Path, *paths: Path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(p) for p in paths] + [str(HERE.parent / "src")])}
    return subprocess.run([sys.executable, "-m", "armlab.cli", "run", str(scenario), "--out", str(out),
                           "--format", "npz", "--quiet"], env=env, capture_output=True, text=True,
                          timeout=600)


def test_armlab_run_names_a_law_that_an_installed_package_declares(scenario_file, tmp_path):
    # A fresh process knows the type only through the package's entry point, which imports
    # this file; without the package the file names an unknown type, in one line.
    missing = _armlab_run(scenario_file, tmp_path / "none", HERE)
    assert missing.returncode != 0
    assert "controller.type: unknown type 'joint_pid_antiwindup'" in missing.stderr
    assert "Traceback" not in missing.stderr
    site = _package(tmp_path / "site", Path(__file__).stem)
    done = _armlab_run(scenario_file, tmp_path / "runs", HERE, site)
    assert done.returncode == 0, done.stderr[-2000:]
    saved = list((tmp_path / "runs").rglob("*.npz"))
    assert len(saved) == 1
    expected = load_scenario_file(scenario_file).run()
    np.testing.assert_allclose(SimulationResult.load(saved[0]).q, expected.q, rtol=0, atol=1e-12)


def test_a_declared_module_that_cannot_be_imported_is_named_in_one_line(scenario_file, tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(_package(tmp_path / "site", "armlab_no_such_module_for_this_test")))
    monkeypatch.setattr(registry, "_LOADED", threading.Event())
    monkeypatch.setattr(registry, "_LOAD_PROBLEMS", [])
    scenario_file.write_text(SCENARIO.replace("joint_pid_antiwindup", "joint_pid_nowhere"))
    with pytest.raises(ScenarioFileError) as raised:
        load_scenario_file(scenario_file)
    message = str(raised.value)
    assert "\n" not in message
    assert "controller.type: unknown type 'joint_pid_nowhere'" in message
    assert ("entry point user_laws = 'armlab_no_such_module_for_this_test' (armlab.scenario_types) "
            "cannot be imported: ModuleNotFoundError") in message
    # Loaded once per process: a second unknown type does not import again.
    assert registry.load_declared_modules() == registry._LOAD_PROBLEMS
    json.dumps(registry._LOAD_PROBLEMS)
