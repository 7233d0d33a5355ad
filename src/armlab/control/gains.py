"""Gain matrices of the control laws, from what a user writes (a number, a diagonal, a matrix).

One function serves every law: joint-space gains are (n, n); task-space gains act on the
``components`` of a task (a selection of the 6 pose coordinates [x, y, z, φ1, φ2, φ3]) and may
be written for all of them, then sliced to the task.  Every gain is symmetric positive
semi-definite (positive definite where the law needs an inverse or a strictly positive
energy, ``positive_definite=True``): a PD law with a negative or skew gain has no stable
equilibrium to speak of.
"""

from __future__ import annotations

import numpy as np

from armlab.errors import ControllerSpecError


def gain_matrix(value, size: int, field: str, *, components=None,
                positive_definite: bool = False) -> np.ndarray:
    """A (k, k) gain from a number (times I), a diagonal or a matrix.

    ``size`` is the dimension the gain is written for: n joints, or 6 pose coordinates.
    Without ``components``, k = size.  With ``components`` (k distinct indices below ``size``),
    the gain acts on those coordinates: a (k,) diagonal or a (k, k) matrix is taken as it is, a
    (size,) diagonal or a (size, size) matrix is sliced to them.  Raises
    :class:`~armlab.errors.ControllerSpecError` naming ``field`` if the shape does not fit, a
    value is not finite, or the gain is not symmetric positive semi-definite (definite with
    ``positive_definite``).
    """
    rows = list(range(size)) if components is None else [int(i) for i in components]
    k = len(rows)
    array = np.asarray(value, dtype=float)
    diagonal = array.ndim == 0 or array.shape in ((1,), (k,), (size,))
    if array.ndim == 0 or array.shape == (1,):
        array = np.eye(k) * float(array.reshape(-1)[0])
    elif array.shape in ((k,), (size,)):
        array = np.diag(array if array.shape == (k,) else array[rows])
    elif array.shape == (size, size) and k != size:
        array = array[np.ix_(rows, rows)]
    if array.shape != (k, k):
        what = f"{k} numbers or a {k}×{k} matrix" if k == size else (
            f"{k} (task) or {size} diagonal entries, or a {k}×{k} or {size}×{size} matrix")
        raise ControllerSpecError(f"{field}: expected a number, {what}, got shape {np.shape(value)}")
    if not np.all(np.isfinite(array)):
        raise ControllerSpecError(f"{field}: must be finite")
    if diagonal:
        # Written as a number or a diagonal: symmetric, its eigenvalues its entries (a gain
        # sweep builds thousands of these; the general checks cost ~25 µs each).
        smallest = array.diagonal().min() if k else 0.0
    else:
        if not np.allclose(array, array.T):
            raise ControllerSpecError(f"{field}: a gain must be symmetric")
        smallest = np.linalg.eigvalsh(0.5 * array + 0.5 * array.T).min()  # no overflow at 1e308
    if smallest < 0 or (positive_definite and smallest <= 0):
        kind = "positive definite" if positive_definite else "positive semi-definite"
        raise ControllerSpecError(f"{field}: a gain must be {kind} (smallest eigenvalue {smallest:g})")
    return np.ascontiguousarray(array)
