"""Python first, fast second: a control law in plain Python runs in ``simulate`` and gives the
trajectory of its ``numba.njit`` twin in the compiled loop; a law that breaks the protocol is
refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

import armlab
from armlab import FunctionController
from armlab.control.base import Signal
from armlab.errors import ProtocolError
from armlab.simulation.disturbances import SinusoidalTorque, StepTorque
from armlab.simulation.environment import Spring

ROBOT = armlab.load_robot("prp")
Q_DES = np.array([0.1, 1.0, 0.05])
KP, KD, KI = np.array([25.0, 5.0, 10.0]), np.array([10.0, 1.0, 3.0]), np.array([2.0, 1.0, 1.0])


def pd(t, q, qd):
    return KP * (Q_DES - q) - KD * qd


def pid(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """PID on the joint error with its integral as the state z; logs the error and |h_e|."""
    q_des, kp, kd, ki = params.q_des, params.kp, params.kd, params.ki
    for i in range(q.shape[0]):
        error = q_des[i] - q[i]
        tau_out[i] = kp[i] * error - kd[i] * qd[i] + ki[i] * z[i]
        zdot_out[i] = error
        signals_out[i] = error
    signals_out[q.shape[0]] = np.sqrt(h_e[0] ** 2 + h_e[1] ** 2 + h_e[2] ** 2)


from typing import NamedTuple  # noqa: E402


class PIDParams(NamedTuple):
    q_des: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    ki: np.ndarray


PARAMS = PIDParams(Q_DES, KP, KD, KI)
SIGNALS = (Signal.joint("q_err", ROBOT, "error"), Signal("contact", ("|f|",), ("N",)))


def pid_controller(law):
    return FunctionController(ROBOT, law, parameters=PARAMS, z0=np.zeros(3),
                              state_names=("i_d1", "i_theta2", "i_d3"), logged=SIGNALS)


def test_a_plain_python_pd_and_its_njit_twin_give_the_same_trajectory():
    runs = [armlab.simulate(ROBOT, FunctionController(ROBOT, law), q0=np.zeros(3), t_final=1.0, dt=1e-3)
            for law in (pd, njit(pd))]
    assert runs[0].meta["law"] == "python" and "law" not in runs[1].meta
    assert np.abs(runs[0].q[-1] - runs[0].q[0]).max() > 0.05  # it moved
    for name in ("q", "qd", "qdd", "tau"):
        np.testing.assert_allclose(getattr(runs[0], name), getattr(runs[1], name), atol=1e-12, rtol=0)


def test_the_full_form_with_state_signals_saturation_disturbance_and_contact_agrees():
    # Every branch of the loop: controller state, signals, τ limits, two disturbances, a
    # spring environment (h_e), in continuous and in sampled control.
    spring = Spring(stiffness=[0, 0, 200.0, 0, 0, 0], rest_position=[0.0, -0.15, 0.45])
    for period in (None, 4e-3):
        kwargs = dict(q0=[0.05, 0.5, 0.0], t_final=1.0, dt=1e-3, torque_limit=[2.0, 1.0, 3.0],
                      disturbance=[SinusoidalTorque([0.1, 0.2, 0.0], [3.0, 3.0, 3.0]),
                                   StepTorque(0.4, [0.0, 0.0, 0.5])],
                      environment=spring, control_period=period)
        slow = armlab.simulate(ROBOT, pid_controller(pid), **kwargs)
        fast = armlab.simulate(ROBOT, pid_controller(njit(pid)), **kwargs)
        assert slow.meta["law"] == "python"
        assert np.abs(slow.signals["h_e"]).max() > 0.1 and np.abs(slow.signals["tau_cmd"]).max() > 2.0
        for name in ("q", "qd", "qdd", "tau", "z"):
            np.testing.assert_allclose(getattr(slow, name), getattr(fast, name), atol=1e-12, rtol=0)
        for name in ("q_err", "contact", "tau_cmd", "tau_dist", "h_e"):
            np.testing.assert_allclose(slow.signals[name], fast.signals[name], atol=1e-12, rtol=0)
        assert slow.labels == fast.labels and slow.units == fast.units


def test_the_adaptive_integrator_runs_a_python_law_too():
    runs = [armlab.simulate(ROBOT, FunctionController(ROBOT, law), q0=np.zeros(3), t_final=0.5, dt=1e-2,
                            method="adaptive") for law in (pd, njit(pd))]
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-9, rtol=0)


def test_a_diverging_python_law_is_reported_like_a_compiled_one():
    def push(t, q, qd):
        return np.array([50.0, 0.0, 0.0])

    with pytest.raises(armlab.SimulationDiverged, match="joint limit exceeded on joint d1") as python:
        armlab.simulate(ROBOT, FunctionController(ROBOT, push), q0=np.zeros(3), t_final=5.0, dt=1e-3)
    with pytest.raises(armlab.SimulationDiverged) as compiled:
        armlab.simulate(ROBOT, FunctionController(ROBOT, njit(push)), q0=np.zeros(3), t_final=5.0, dt=1e-3)
    assert str(python.value) == str(compiled.value)


def one_line(error) -> str:
    text = str(error.value)
    assert "\n" not in text, text
    return text


def test_a_law_with_the_wrong_number_of_arguments_is_refused():
    with pytest.raises(ProtocolError) as error:
        FunctionController(ROBOT, lambda t, q: q)
    assert "takes 2 arguments; a law takes (t, q, qd) or (t, q, qd, z, h_e, params" in one_line(error)


def test_a_laws_arguments_are_counted_as_its_signature_says():
    import functools

    from armlab.control.function import arity

    def law(t, q, qd, extra=None):
        return q

    @functools.wraps(law)
    def decorated(*args, **kwargs):                      # inspect reads the wrapped signature
        return law(*args, **kwargs)

    class Callable:
        __hash__ = None                                  # not hashable: nothing may need that

        def __call__(self, t, q, qd):
            return q

        def method(self, t, q, qd):
            return q

    assert [arity(f) for f in (law, decorated, Callable(), Callable().method)] == [3] * 4
    law.__defaults__ = (None, None)                     # now (t, q) are all it needs
    with pytest.raises(ProtocolError, match="takes 2 arguments"):
        arity(law)


def test_a_list_where_a_tuple_is_expected_is_refused():
    with pytest.raises(ProtocolError) as error:
        FunctionController(ROBOT, njit(pid), parameters=[Q_DES, KP, KD, KI], z0=np.zeros(3), logged=SIGNALS)
    assert one_line(error).startswith("params: a list, but a law's params must be a tuple")


def test_a_short_law_returning_the_wrong_shape_is_refused():
    with pytest.raises(ProtocolError) as error:
        armlab.simulate(ROBOT, FunctionController(ROBOT, lambda t, q, qd: [0.0, 0.0]), q0=np.zeros(3),
                        t_final=0.01, dt=1e-3)
    assert one_line(error) == "law: returned shape (2,), expected (3,) joint torques"


def test_an_njit_law_that_does_not_compile_is_one_line():
    @njit
    def broken(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
        tau_out[0] = params.gain_that_is_not_there

    with pytest.raises(ProtocolError) as error:
        armlab.simulate(ROBOT, FunctionController(ROBOT, broken, parameters=PARAMS), q0=np.zeros(3),
                        t_final=0.01, dt=1e-3)
    text = one_line(error)
    assert text.startswith("FunctionController.law does not compile for its params:")
    assert "gain_that_is_not_there" in text


def test_simulate_batch_asks_for_a_compiled_law():
    with pytest.raises(ProtocolError) as error:
        armlab.simulate_batch(ROBOT, [FunctionController(ROBOT, pd)], q0=np.zeros(3), t_final=0.01, dt=1e-3)
    assert "simulate_batch needs it compiled (numba.njit)" in one_line(error)


def test_the_bridge_evaluates_a_python_law():
    pytest.importorskip("control", reason="python-control is not installed (extra 'control')")
    from armlab.control.bridge import LawEvaluator

    tau, zdot = LawEvaluator(FunctionController(ROBOT, pd))(0.0, np.zeros(3), np.zeros(3), np.zeros(0))
    np.testing.assert_allclose(tau, KP * Q_DES)
