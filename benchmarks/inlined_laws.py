"""The same small law declared twice at module level, called from its generated entry
(``numba.njit``) and compiled inside it (``numba.njit(inline="always")``), for
``bench_python_laws.py``: a PD about a via-point reference on the PRP, whose parameters are
either the four arrays it reads or those four among the fifteen of the A7 law's.

A law is called from its entry unless it is declared inlined (``armlab.control.entry``), and a
call passes each array of its parameters as seven machine words, read or not."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from armlab.control.base import Controller
from armlab.model.robot import Robot
from armlab.references.joint import reference_into

# Per joint [N/m, N·m/rad, N/m] and [N·s/m, N·m·s/rad, N·s/m]: stiff enough to hold the PRP near
# its reference under gravity, slow enough for RK4 at 1 ms on its light revolute joint.
KP = (200.0, 2.0, 200.0)
KD = (40.0, 0.3, 8.0)


class ReferenceGains(NamedTuple):
    reference: np.ndarray           # a JointReference's data (writeable copy)
    q_des: np.ndarray               # (n,) scratch
    qd_des: np.ndarray              # (n,) scratch
    qdd_des: np.ndarray             # (n,) scratch


# Two definitions of one body: a law gets its generated entry only when its module holds it
# under its own function's name, so the two decorations cannot share one ``def``.
@njit(cache=True)
def called_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """τ = K_P (q_des(t) − q) − K_D q̇ (diagonal gains) with q_des the reference at t."""
    reference_into(params.reference, t, params.q_des, params.qd_des, params.qdd_des)
    for i in range(q.shape[0]):
        tau_out[i] = KP[i] * (params.q_des[i] - q[i]) - KD[i] * qd[i]


@njit(cache=True, inline="always")
def inlined_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """:func:`called_law`, compiled inside its entry."""
    reference_into(params.reference, t, params.q_des, params.qd_des, params.qdd_des)
    for i in range(q.shape[0]):
        tau_out[i] = KP[i] * (params.q_des[i] - q[i]) - KD[i] * qd[i]


@dataclass(frozen=True, eq=False)
class CalledPD(Controller):
    """The law on ``reference``, called from its entry; its parameters those of the A7 law
    ``wide`` (a ``JointInverseDynamics``, which holds the same four arrays among its fifteen)
    when given, else the four arrays it reads."""

    model: Robot
    reference: object
    wide: Controller | None = None
    law = called_law

    def params(self):
        if self.wide is not None:
            return self.wide.params()
        n = self.model.n
        return ReferenceGains(np.array(self.reference.data), np.zeros(n), np.zeros(n), np.zeros(n))


@dataclass(frozen=True, eq=False)
class InlinedPD(CalledPD):
    """The same, compiled inside its entry."""

    law = inlined_law
