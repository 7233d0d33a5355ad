"""A robot's :class:`~armlab.model.robot.RobotArrays` rebuilt from its packed array.

Calling a compiled function from Python costs about 0.1–0.2 µs per array argument to unbox;
the 18 arrays of ``RobotArrays`` plus the 17 of a dynamics workspace would cost far more than
the dynamics itself.  The public functions therefore pass flat arrays and rebuild the named
tuple of views inside compiled code with :func:`unpack_robot` (no copy, no allocation); the
layout is that of :func:`armlab.model.robot.pack_arrays`.

The views are made by :func:`~armlab.kernels.boundary.buffer_view`, which writes the shape
and strides of a C-contiguous view directly: ``data[o:o + k].reshape(shape)`` would call
numba's general reshape helper, about 30 ns each, i.e. ~1 µs for the ~30 views of a robot
and a workspace — more than a 3-joint inverse dynamics.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.kernels.boundary import buffer_view
from armlab.model.robot import RobotArrays


@njit(cache=True, inline="always")
def unpack_robot(joint_type, data):
    """The :class:`RobotArrays` whose float arrays are views into ``data`` (the float fields of
    :func:`~armlab.model.robot.pack_arrays`).

    Inlined into its caller so that the views are reference-counted as the caller is (see
    ``workspace_from_buffer`` in :mod:`armlab.kernels.dynamics`)."""
    n = joint_type.shape[0]
    f = np.float64
    o = 0
    tree_R = buffer_view(data, o, (n, 3, 3), f)
    o += 9 * n
    tree_p = buffer_view(data, o, (n, 3), f)
    o += 3 * n
    offset = buffer_view(data, o, n, f)
    o += n
    tool_R = buffer_view(data, o, (3, 3), f)
    o += 9
    tool_p = buffer_view(data, o, 3, f)
    o += 3
    base_R = buffer_view(data, o, (3, 3), f)
    o += 9
    base_p = buffer_view(data, o, 3, f)
    o += 3
    mass = buffer_view(data, o, n, f)
    o += n
    com = buffer_view(data, o, (n, 3), f)
    o += 3 * n
    inertia = buffer_view(data, o, (n, 3, 3), f)
    o += 9 * n
    gear_ratio = buffer_view(data, o, n, f)
    o += n
    rotor_inertia = buffer_view(data, o, n, f)
    o += n
    viscous = buffer_view(data, o, n, f)
    o += n
    coulomb = buffer_view(data, o, n, f)
    o += n
    q_min = buffer_view(data, o, n, f)
    o += n
    q_max = buffer_view(data, o, n, f)
    o += n
    gravity = buffer_view(data, o, 3, f)
    return RobotArrays(joint_type, tree_R, tree_p, offset, tool_R, tool_p, base_R, base_p, mass,
                       com, inertia, gear_ratio, rotor_inertia, viscous, coulomb, q_min, q_max,
                       gravity)
