"""Symbolic modelling at scale: time and operation counts of B, C, g.

* PUMA 560 (six joints, Armstrong–Khatib–Burdick parameters, lengths a2, a3, d3, d4 and gear
  ratios as symbols): B, C, g by Newton–Euler over a polynomial ring (``compact_dynamics``),
  target ≤ 60 s; operation counts of the expanded forms and with shared subexpressions;
  checked against the numeric kernels at random states.
* The naive route for comparison: Christoffel symbols of the B obtained from partial
  Jacobians without simplification, for the same six joints (slow: counting its operations
  alone takes a minute).
* The PRP's whole A1–A5 chain as ``armlab derive prp`` prints it.

Each closed form is checked against the numeric kernels at random states before its figures
are printed (``check_compact``; the test suite runs it on the PRP).  The compiled closed forms
of ``armlab.specialise`` are measured by ``bench_dynamics.py`` and ``bench_simulation.py``.
Run: ``python benchmarks/bench_symbolic.py`` (or through the bench runner, which calls
:func:`main`).  Timings on a shared machine are noisy; ratios are measured side by side.
"""

from __future__ import annotations

import time

import numpy as np
import sympy as sp

from agreement import OTHER_ALGORITHM, assert_close


def _seconds(f, *args, repeat=1):
    start = time.perf_counter()
    for _ in range(repeat):
        value = f(*args)
    return (time.perf_counter() - start) / repeat, value


def check_compact(robot, sr, result, states=5):
    """B, C, g of ``compact_dynamics`` (symbols of ``sr``, its values substituted) against
    ``armlab.inertia_matrix`` / ``coriolis_matrix`` / ``gravity_torque`` at random states;
    returns the largest difference."""
    import armlab

    values = sr.numeric_substitution()
    B = sp.lambdify([list(sr.q)], result.B.xreplace(values))
    C = sp.lambdify([list(sr.q), list(sr.qd)], result.C.xreplace(values))
    g = sp.lambdify([list(sr.q)], result.g.xreplace(values))
    rng = np.random.default_rng(0)
    error = 0.0
    for _ in range(states):
        q, qd = rng.uniform(-np.pi, np.pi, size=(2, robot.n))
        error = max(error,
                    assert_close(B(q), armlab.inertia_matrix(robot, q), OTHER_ALGORITHM, f"{robot.name} B"),
                    assert_close(C(q, qd), armlab.coriolis_matrix(robot, q, qd), OTHER_ALGORITHM,
                                 f"{robot.name} C"),
                    assert_close(np.ravel(g(q)), armlab.gravity_torque(robot, q), OTHER_ALGORITHM,
                                 f"{robot.name} g"))
    return error


def puma_compact():
    import armlab
    from armlab.symbolic import compact_dynamics
    from armlab.symbolic.model import symbolic_robot

    robot = armlab.load_robot("puma560")
    sr = symbolic_robot(robot)
    seconds, result = _seconds(compact_dynamics, sr)
    error = check_compact(robot, sr, result)
    return {"puma560 B, C, g [s]": seconds, "puma560 ops B": result.ops["B"],
            "puma560 ops C": result.ops["C"], "puma560 ops g": result.ops["g"],
            "puma560 ops with CSE": result.ops_cse,
            "puma560 max |closed form − kernels|": error}, (robot, result)


def naive_christoffel(joints: int = 6):
    """B from partial Jacobians without simplification and its Christoffel C, for the PUMA's
    first ``joints`` joints: the route that does not scale (about 2.4 million operations in C
    for six joints when measured; counting them alone takes a minute)."""
    import armlab
    from armlab.model.robot import Robot
    from armlab.symbolic.model import symbolic_robot
    from armlab.symbolic.simplify import count_ops

    puma = armlab.load_robot("puma560")
    if joints == puma.n:
        sr = symbolic_robot(puma)  # the same symbols as the recursive route
    else:
        sr = symbolic_robot(Robot(name="puma_arm", joints=puma.joints[:joints],
                                  links=puma.links[:joints], gravity=puma.gravity))
    n = sr.n
    start = time.perf_counter()
    T = sp.eye(4)
    B = sp.zeros(n, n)
    axes = []
    for joint, link in zip(sr.joints, sr.links, strict=True):
        axes.append((T * joint.before)[:3, 2])
        T = T * joint.transform()
        p_c = (T * link.com.col_join(sp.Matrix([1])))[:3, 0]
        J_P = p_c.jacobian(sr.q)
        J_O = sp.Matrix.hstack(*[axes[k] if k < len(axes) else sp.zeros(3, 1) for k in range(n)])
        R = T[:3, :3]
        B += link.mass * J_P.T * J_P + J_O.T * R * link.inertia * R.T * J_O
    q, qd = list(sr.q), list(sr.qd)
    C = sp.Matrix(n, n, lambda i, j: sum((sp.diff(B[i, j], q[k]) + sp.diff(B[i, k], q[j])
                                          - sp.diff(B[j, k], q[i])) * qd[k] / 2 for k in range(n)))
    seconds = time.perf_counter() - start
    return {f"naive {n}-joint B, C (unsimplified) [s]": seconds,
            f"naive {n}-joint ops B": count_ops(B), f"naive {n}-joint ops C": count_ops(C)}


def prp_chain():
    import armlab
    from armlab.symbolic import derive
    from armlab.symbolic.simplify import count_ops

    robot = armlab.load_robot("prp")
    seconds, sections = _seconds(derive, robot)
    a3 = {s.key: s for s in sections}["A3"]
    items = dict(a3.pairs())
    B = {s.key: s for s in sections}["A2"]
    return {"prp derive A1–A5 [s]": seconds,
            "prp ops B": count_ops(dict(B.pairs())["B(q)"]),
            "prp ops C": count_ops(items["C(q, q̇)"]), "prp ops g": count_ops(items["g(q)"])}


def main() -> dict:
    results = {}
    results.update(prp_chain())
    puma, _ = puma_compact()
    results.update(puma)
    results.update(naive_christoffel(6))
    width = max(map(len, results))
    for key, value in results.items():
        shown = f"{value:.3g}" if isinstance(value, float) else str(value)
        print(f"{key:<{width}}  {shown}")
    return results


if __name__ == "__main__":
    main()
