"""The law ABI: how the simulation loop hands a controller's law its inputs and outputs.

A controller's law (``armlab.control.base``) reads q, q̇, z, h_e and writes τ, ż and its
signals.  The loop keeps all of them in its one scratch array ``work``; :func:`law_views`
gives the views, in the order of the law's arguments around ``params``, and
:func:`law_entry` marks a controller's own *entry*, the law compiled inlined into the
function the loop calls (``armlab.simulation.loop``)::

    @law_entry(pd_law)
    def pd_entry(cp, law, t, work, n, k, s):
        q, qd, z, h_e, tau_out, zdot_out, signals_out = law_views(borrowed(work), n, k, s)
        pd_law(t, q, qd, z, h_e, borrowed(cp[0]), tau_out, zdot_out, signals_out)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.kernels.boundary import buffer_view


@njit(cache=True, inline="always")
def law_views(work, n, k, s):
    """(q, qd, z, h_e, tau_out, zdot_out, signals_out): the scratch views a law reads and
    writes, in the order of its arguments around ``params``.

    They lie first in ``work``, in this order, whatever the rest of the scratch layout: a
    controller's own entry is compiled into its own module's cache, which numba does not
    invalidate when this file changes, so what the entries inline is kept fixed (the law
    ABI).  Changing it means changing the entries' modules too."""
    f = np.float64
    return (buffer_view(work, 0, n, f), buffer_view(work, n, n, f), buffer_view(work, 2 * n, k, f),
            buffer_view(work, 2 * n + k, 6, f), buffer_view(work, 2 * n + k + 6, n, f),
            buffer_view(work, 3 * n + k + 6, k, f), buffer_view(work, 3 * n + 2 * k + 6, s, f))


def law_entry(law):
    """Decorator of a controller's own entry (see the module docstring) for ``law``: compiled
    like the laws, and marked with the law it inlines (the simulator uses it only with that
    law)."""
    def wrap(function):
        entry = njit(cache=True)(function)
        entry.inlined_law = law
        return entry
    return wrap
