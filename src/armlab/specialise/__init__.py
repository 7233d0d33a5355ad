"""Robot specialisation: dynamics generated for one robot's numbers, below the public API.

A robot's generated module (the numeric kernels partially evaluated for its numbers by
:mod:`armlab.specialise.traced`) is
made on request, cached on disk, and checked against the compiled kernels of
``armlab.kernels`` before use (:mod:`armlab.specialise.closed_form`).  The simulator and the
controllers ask :func:`plant_kernels` and :func:`inverse_dynamics_function` for the kernels a
``dynamics=`` choice selects; the public functions of ``armlab.dynamics`` ask
:func:`chosen_module`.
"""

from armlab.specialise.closed_form import (
    DYNAMICS_CHOICES,
    ClosedFormUnavailable,
    cache_dir,
    cached_module,
    choice_problem,
    chosen_module,
    closed_form_module,
    closed_form_status,
    generated_module,
    inverse_dynamics_function,
    numeric_inverse_dynamics,
    plant_kernels,
    robot_key,
)

__all__ = ["DYNAMICS_CHOICES", "ClosedFormUnavailable", "cache_dir", "cached_module",
           "choice_problem", "chosen_module", "closed_form_module", "closed_form_status", "generated_module",
           "inverse_dynamics_function", "numeric_inverse_dynamics", "plant_kernels", "robot_key"]
