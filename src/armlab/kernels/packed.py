"""A robot's :class:`~armlab.model.robot.RobotArrays` packed into two flat arrays.

Calling a compiled function from Python costs about 0.2 µs per array argument to unbox; the
18 arrays of ``RobotArrays`` plus the 17 of a dynamics workspace would cost far more than the
dynamics itself.  The public functions therefore pass ``(joint_type, data)`` and rebuild the
named tuple of views inside compiled code with :func:`unpack_robot` (no copy, no allocation).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.model.robot import RobotArrays

# Float fields of RobotArrays in packing order (joint_type travels separately as int64).
FLOAT_FIELDS = RobotArrays._fields[1:]


def pack_robot(m: RobotArrays) -> tuple[np.ndarray, np.ndarray]:
    """(joint_type (n,) int64, data (k,) float64) holding every field of ``m``.

    The arrays stay writeable (but are never written) so that the kernels see the same array
    types as with ``robot.arrays`` and compile once.
    """
    data = np.concatenate([np.asarray(getattr(m, name), dtype=float).ravel() for name in FLOAT_FIELDS])
    joint_type = np.ascontiguousarray(m.joint_type, dtype=np.int64)
    return joint_type, data


@njit(cache=True)
def unpack_robot(joint_type, data):
    """The :class:`RobotArrays` whose float arrays are views into ``data`` (see pack_robot)."""
    n = joint_type.shape[0]
    o = 0
    tree_R = data[o:o + 9 * n].reshape((n, 3, 3))
    o += 9 * n
    tree_p = data[o:o + 3 * n].reshape((n, 3))
    o += 3 * n
    offset = data[o:o + n]
    o += n
    tool_R = data[o:o + 9].reshape((3, 3))
    o += 9
    tool_p = data[o:o + 3]
    o += 3
    base_R = data[o:o + 9].reshape((3, 3))
    o += 9
    base_p = data[o:o + 3]
    o += 3
    mass = data[o:o + n]
    o += n
    com = data[o:o + 3 * n].reshape((n, 3))
    o += 3 * n
    inertia = data[o:o + 9 * n].reshape((n, 3, 3))
    o += 9 * n
    gear_ratio = data[o:o + n]
    o += n
    rotor_inertia = data[o:o + n]
    o += n
    viscous = data[o:o + n]
    o += n
    coulomb = data[o:o + n]
    o += n
    q_min = data[o:o + n]
    o += n
    q_max = data[o:o + n]
    o += n
    gravity = data[o:o + 3]
    return RobotArrays(joint_type, tree_R, tree_p, offset, tool_R, tool_p, base_R, base_p, mass,
                       com, inertia, gear_ratio, rotor_inertia, viscous, coulomb, q_min, q_max,
                       gravity)
