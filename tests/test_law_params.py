"""Laws take named parameters: every bundled controller's and environment's ``params()`` is a
module-level NamedTuple whose fields are exactly what its law reads, by name."""

import inspect
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from numba import njit, typeof, types
from numba.core.datamodel import default_manager

import armlab
from armlab.control import entry
from armlab.control.adaptive import SlotineLi
from armlab.control.base import Controller, Signal
from armlab.errors import ProtocolError
from armlab.references.joint import Sinusoid
from armlab.scenarios import bundled_scenario_names, load_scenario
from armlab.simulation import loop, simulate, simulator
from armlab.simulation.environment import FreeSpace, PlanarWall, Spring

PRP = armlab.load_robot("prp")


def _bundled():
    """One instance of every controller and environment class the bundled scenarios use, plus
    the n-DoF Slotine–Li controller and the three environments."""
    objects = {}
    for name in bundled_scenario_names():
        scenario = load_scenario(name)
        for item in (scenario.controller, getattr(scenario, "environment", None)):
            if item is not None:
                objects.setdefault(type(item), item)
    objects[SlotineLi] = SlotineLi(PRP, Sinusoid([0, 0, 0], 0.1, 1.0), 1.0, 1.0, 1.0)
    objects[FreeSpace] = FreeSpace()
    objects[Spring] = Spring(np.ones(6), np.zeros(3))
    objects[PlanarWall] = PlanarWall([0, 0, 0], [0, 0, 1], 1000.0, 5.0)
    return list(objects.values())


BUNDLED = _bundled()


def test_the_bundled_scenarios_cover_every_law_family():
    names = {type(item).__name__ for item in BUNDLED}
    assert {"JointPDGravity", "JointInverseDynamics", "SlotineLi1DoF", "SlotineLi", "OperationalPD",
            "OperationalInverseDynamics", "ComplianceControl", "ImpedanceControl", "AdmittanceControl",
            "ForceControl", "ParallelForcePosition", "FreeSpace", "Spring", "PlanarWall"} <= names


@pytest.mark.parametrize("item", BUNDLED, ids=lambda item: type(item).__name__)
def test_params_are_a_module_level_named_tuple_of_exactly_what_the_law_reads(item):
    params = item.params()
    kind = type(params)
    assert isinstance(params, tuple) and kind is not tuple and hasattr(kind, "_fields")
    # Module level: numba's disk cache finds the class again by its importable name.
    assert kind.__qualname__ == kind.__name__
    assert getattr(sys.modules[kind.__module__], kind.__name__) is kind
    source = inspect.getsource(type(item).law.py_func)
    assert not re.search(r"=\s*params\s*$|params\s*\[", source, re.MULTILINE), "positional read"
    assert set(re.findall(r"\bparams\.(\w+)", source)) == set(kind._fields)


# A law reading a field its parameters do not have: numba refuses it when it compiles.
class ShortParams(NamedTuple):
    kp: np.ndarray                 # (n,) [N·m/rad]


@njit
def misspelt_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    kp, kd = params.kp, params.nope
    for i in range(q.shape[0]):
        tau_out[i] = -kp[i] * q[i] - kd[i] * qd[i]


@dataclass(frozen=True)
class Misspelt(Controller):
    model: armlab.Robot
    law = misspelt_law

    def params(self):
        return ShortParams(kp=np.ones(self.n))


def test_a_law_reading_a_missing_field_fails_to_compile_naming_it():
    # One line (not numba's forty) that names the attribute.
    with pytest.raises(ProtocolError, match="nope") as error:
        simulate(PRP, Misspelt(PRP), q0=[0, 0, 0], t_final=0.01, dt=1e-3)
    assert "\n" not in str(error.value)


# The worked example of ``armlab.control.base``, as written there.
class PDParams(NamedTuple):
    q_des: np.ndarray              # (n,) target joint positions [m | rad]
    kp: np.ndarray                 # (n,) K_P [N/m | N·m/rad]
    kd: np.ndarray                 # (n,) K_D [N·s/m | N·m·s/rad]


@njit(cache=True)
def pd_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    q_des, kp, kd = params.q_des, params.kp, params.kd
    for i in range(q.shape[0]):
        tau_out[i] = kp[i] * (q_des[i] - q[i]) - kd[i] * qd[i]
        signals_out[i] = q_des[i] - q[i]


@dataclass(frozen=True)
class PD(Controller):
    model: armlab.Robot
    q_des: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    law = pd_law

    def params(self):
        return PDParams(q_des=np.asarray(self.q_des, float), kp=np.asarray(self.kp, float),
                        kd=np.asarray(self.kd, float))

    def signals(self):
        return (Signal.joint("q_err", self.model, "error"),)


def test_the_protocol_example_runs_and_logs_its_error():
    q_des, kp, kd = np.array([0.1, 0.5, 0.05]), np.array([400.0, 50.0, 200.0]), np.array([40.0, 5.0, 20.0])
    result = simulate(PRP, PD(PRP, q_des, kp, kd), q0=[0, 0, 0], t_final=0.5, dt=1e-3)
    np.testing.assert_array_equal(result.signals["q_err"], q_des - result.q)
    # τ = K_P q̃ − K_D q̇ on every logged row (no torque limit, no disturbance).
    np.testing.assert_allclose(result.tau, kp * (q_des - result.q) - kd * result.qd, rtol=0, atol=1e-12)


def _named_tuples_in(numba_type):
    """The NamedTuple types inside a numba type (tuples, pointers), recursively."""
    if isinstance(numba_type, types.BaseNamedTuple):
        return [numba_type]
    if isinstance(numba_type, types.BaseTuple):
        return [found for member in numba_type for found in _named_tuples_in(member)]
    if isinstance(numba_type, types.CPointer):
        return _named_tuples_in(numba_type.dtype)
    return []


def test_the_shared_loop_functions_never_see_a_named_tuple(monkeypatch):
    # numba's cache index of a shared function holds every signature it was compiled for; a
    # signature naming this test module's PDParams would break loading it in any process that
    # cannot import this module.
    q_des = np.array([0.1, 0.5, 0.05])
    simulate(PRP, PD(PRP, q_des, 100.0 * np.ones(3), 20.0 * np.ones(3)), q0=[0, 0, 0], t_final=0.05,
             dt=1e-3, method="adaptive")
    scenario = load_scenario("a11_compliance")
    scenario.run(t_final=0.01)
    # A law without an entry (one that cannot be imported by name) goes through law_trampoline.
    monkeypatch.setattr(simulator, "generated_entry", lambda law: None)
    scenario.run(t_final=0.01)
    shared = (loop.rk4_run, loop.park_params, loop.rhs, loop.log_rows, entry.law_trampoline,
              loop.env_trampoline)
    signatures = [(function.py_func.__name__, signature) for function in shared
                  for signature in function.signatures]
    assert {name for name, _ in signatures} == {function.py_func.__name__ for function in shared}
    named = [(name, found) for name, signature in signatures for argument in signature
             for found in _named_tuples_in(argument)]
    assert named == []
    # The adaptive integrator's right-hand side takes the parameters parked (their addresses):
    # one compiled version for every law and environment, nothing of theirs typed per call.
    scenario.run(t_final=0.01, method="adaptive")
    assert len(loop.rhs.signatures) == 1
    assert not any(isinstance(argument, types.BaseTuple) for argument in loop.rhs.signatures[0])


@pytest.mark.parametrize("item", BUNDLED, ids=lambda item: type(item).__name__)
def test_a_named_tuple_and_its_plain_tuple_share_numba_layout(item):
    # The loop stores the plain tuple and the law reads it as its NamedTuple (integrators).
    params = item.params()
    named, plain = default_manager.lookup(typeof(params)), default_manager.lookup(
        typeof(entry.plain_params(params)))
    assert typeof(entry.plain_params(params)) != typeof(params)
    assert named.get_value_type() == plain.get_value_type()
    assert named.get_data_type() == plain.get_data_type()
    assert named.get_argument_type() == plain.get_argument_type()


GAIN = 31.0625      # a value no other number of the run takes


def _holds_gain(value, depth=0) -> bool:
    """Whether ``value`` is, or holds within three levels of lists, tuples and dicts, a number
    or a float array equal to GAIN (the gain in every form it takes: number, list, matrix)."""
    if isinstance(value, np.ndarray):
        return value.dtype.kind == "f" and value.size < 100 and bool(np.any(value == GAIN))
    if isinstance(value, (float, int)) and not isinstance(value, bool):
        return value == GAIN
    if depth >= 3:
        return False
    if isinstance(value, dict):
        value = list(value.values())
    if isinstance(value, (list, tuple)):
        return any(_holds_gain(item, depth + 1) for item in value[:50])
    return False


def test_a_scenario_gain_reaches_its_law_through_five_files(tmp_path):
    """The files of the functions that receive a scenario file's gain as an argument, in any
    form, on its way to the compiled law: the file reader, the gain's matrix, the law ABI and
    the loop (the controller's class, whose dataclass __init__ and compiled law the trace does
    not see, is the fifth); the step check reads the gains beside that walk.  The trace sees
    the arguments of the calls in this thread (a run this short stays in it), not an object's
    fields read inside a function."""
    text = load_scenario("a6_pd_desired").source
    path = tmp_path / "gain.toml"
    path.write_text(Path(text).read_text().replace("kp = [25, 0.5, 10]", f"kp = [{GAIN}, 0.5, 10]"))
    files = set()

    def trace(frame, event, arg):
        name = frame.f_code.co_filename
        if event == "call" and "armlab" in name and "tests" not in name:
            if any(_holds_gain(value) for value in list(frame.f_locals.values())):
                files.add(Path(name).parts[-2] + "/" + Path(name).name)
        return None

    from armlab.scenarios import load_scenario_file

    previous = sys.gettrace()
    sys.settrace(trace)
    try:
        load_scenario_file(path).run(t_final=0.01)
    finally:
        sys.settrace(previous)
    assert {"scenarios/tables.py", "control/entry.py", "simulation/loop.py"} <= files     # seen at all
    assert files <= {"scenarios/tables.py", "control/gains.py", "control/entry.py", "simulation/loop.py",
                     "simulation/step_check.py"}, sorted(files)
