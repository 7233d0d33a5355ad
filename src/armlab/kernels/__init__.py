"""Numba-compiled kernels on plain arrays (:class:`armlab.model.RobotArrays`).

They allocate nothing in their inner loops and write into caller-provided outputs where a
result is an array, so that they can be called from other compiled code (the simulation
loop) as well as from the Python API.  Compiled code is cached on disk (``cache=True``).
"""
