"""armlab: modelling and control of robot manipulators.

Conventions (frames, twist and wrench ordering, Euler angles, units): ``docs/notation.md``.

The public names below are loaded on first use (PEP 562 module ``__getattr__``): ``import
armlab`` itself imports neither numba nor SciPy, so the command line answers ``--help`` at
once and a script pays only for what it touches (``armlab.load_robot`` reads a robot file
without loading the compiled kernels).
"""

from __future__ import annotations

import importlib
import sys
import types
import warnings

__version__ = "0.1.0"

# numba warns, at every typing of a compiled function's value, that first-class functions are
# experimental: armlab's use (the computed-torque law's params hold one, the law calls it) is
# what the suite runs on every numba of the supported range, so the warning would tell a user
# nothing to act on.  Set here, when armlab is first imported: a filter set by a module imported
# later inside a ``warnings.catch_warnings()`` block is dropped when the block ends (seen in
# Dask workers, which then printed the warning at every chunk).  The message alone is matched,
# so that ``import armlab`` does not import numba.
warnings.filterwarnings("ignore", "First-class function type feature is experimental")

_HOMES = {
    "armlab.control.interaction": ("AdmittanceControl", "ComplianceControl", "ForceControl",
                                   "ImpedanceControl", "ParallelForcePosition"),
    "armlab.control.function": ("FunctionController",),
    "armlab.control.task_space": ("OperationalInverseDynamics", "OperationalPD"),
    "armlab.dynamics": ("DynamicsData", "coriolis_matrix", "forward_dynamics", "gravity_torque",
                        "inertia_matrix", "inverse_dynamics", "kinetic_energy", "potential_energy"),
    "armlab.simulation.environment": ("FreeSpace", "PlanarWall", "Spring"),
    "armlab.inverse_kinematics": ("UnreachableTargetError", "inverse_kinematics"),
    "armlab.kinematics": ("analytic_jacobian", "forward_kinematics", "geometric_jacobian",
                          "jacobian_dot_qd", "link_frames", "pose_vector"),
    "armlab.model": ("Robot", "RobotFileError"),
    "armlab.model.urdf_io": ("load_urdf", "save_urdf", "to_urdf"),
    "armlab.operational_space": ("operational_space_dynamics",),
    "armlab.simulation.results": ("SimulationResult",),
    "armlab.robots": ("bundled_robot_names", "load_robot"),
    "armlab.simulation": ("SimulationDiverged", "SimulationInterrupted", "simulate", "simulate_batch"),
    "armlab.spatial": ("RepresentationSingularityError",),
    "armlab.references.task": ("ForceReference", "PoseReference"),
    "armlab.sweep": ("load_sweep", "read_results", "sweep"),
    "armlab.sweep.rollout": ("rollout",),
}
"""Where each public name is defined: module → names."""

_MODULE_OF = {name: module for module, names in _HOMES.items() for name in names}

__all__ = sorted(_MODULE_OF)


def __getattr__(name: str):
    """Import the module defining a public name on its first use, then keep the name here (so
    later lookups are plain attribute reads)."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'armlab' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _PublicNamesFirst(types.ModuleType):
    """The ``armlab`` module, whose public names win over submodules of the same name.

    Importing a submodule sets it as an attribute of its package: ``armlab.inverse_kinematics``
    would become the module :mod:`armlab.inverse_kinematics` instead of the function it
    defines.  That attribute is refused; the name then resolves through :func:`__getattr__`.
    """

    def __setattr__(self, name, value):
        if name in _MODULE_OF and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _PublicNamesFirst
