"""How the benchmarks decide that two sides agree, in one place.

Each benchmark checks its sides against each other before it times them; the same check
functions run in the test suite on small sizes (``tests/test_benchmark_agreement.py``), so a
benchmark whose sides drift apart fails there and not on somebody's machine months later.

Two tolerances, relative to the largest entry of the expected result (entries near zero come
out of cancellations between terms of that size, so their error is bounded by it, not by
their own size):

* :data:`SAME_ALGORITHM`, 1e-12: one algorithm compiled twice (inlined into a loop or called;
  with or without fused multiply-adds).  Every operation is the same up to its rounding, at
  most 1 ulp (1.1e-16) each; a few hundred dependent operations of an RNEA or CRBA stay below
  1e-13.  Bit identity is not promised: LLVM may contract ``a * b + c`` into one FMA in one
  variant and not in the other.  A wrong term would differ by far more than 1e-12.
* :data:`OTHER_ALGORITHM`, 1e-9: two different computations of one quantity (armlab and
  Pinocchio, recursive and closed-form dynamics, a hand-written formula), whose round-off
  follows different paths.
"""

from __future__ import annotations

import numpy as np

SAME_ALGORITHM = 1e-12
OTHER_ALGORITHM = 1e-9


def assert_close(actual, expected, rtol: float, what: str) -> float:
    """Raise ``AssertionError`` naming ``what`` unless max |actual − expected| ≤ rtol · max(1,
    max |expected|); return that largest difference."""
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    if actual.shape != expected.shape:
        raise AssertionError(f"{what}: shapes {actual.shape} and {expected.shape} differ")
    difference = float(np.abs(actual - expected).max()) if actual.size else 0.0
    scale = max(1.0, float(np.abs(expected).max())) if expected.size else 1.0
    if not difference <= rtol * scale:
        raise AssertionError(f"{what}: max difference {difference:.3g} exceeds {rtol:g} × {scale:.3g}")
    return difference
