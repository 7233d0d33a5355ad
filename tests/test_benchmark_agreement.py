"""The benchmarks' agreement checks, on a few states: a benchmark cannot rot unnoticed.

Each benchmark checks that its sides compute the same thing before it times them; those
checks are functions of the benchmark module, called here with small sizes (the timings are
left to ``make bench``).  Tolerances and their reasons: ``benchmarks/agreement.py``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import agreement  # noqa: E402
import bench_dynamics  # noqa: E402
import bench_python_laws  # noqa: E402
import bench_report  # noqa: E402
import bench_simulation  # noqa: E402
import bench_startup  # noqa: E402
import bench_symbolic  # noqa: E402

pytest.importorskip("pinocchio")


def test_assert_close_fails_beyond_its_tolerance():
    expected = np.array([1.0, -2.0, 4.0])
    assert agreement.assert_close(expected + 1e-13, expected, agreement.SAME_ALGORITHM, "near") < 1e-12
    with pytest.raises(AssertionError, match="far"):
        agreement.assert_close(expected + np.array([0.0, 0.0, 1e-10]), expected, agreement.SAME_ALGORITHM,
                               "far")
    with pytest.raises(AssertionError, match="shapes"):
        agreement.assert_close(expected[:2], expected, 1.0, "shapes")


@pytest.mark.parametrize("name", bench_dynamics.ROBOTS)
def test_dynamics_per_call_agrees_with_pinocchio(name):
    # The generated closed form of the six-joint arm takes a symbolic derivation: the PRP's
    # stands for it here; the benchmark checks both.
    bench_dynamics.check_per_call(name, closed_form=name == "prp")


@pytest.mark.parametrize("name", bench_dynamics.ROBOTS)
def test_dynamics_batched_loops_agree_with_pinocchio(name):
    bench_dynamics.check_batched(name, 5)


def test_every_compiled_prp_route_agrees_with_the_public_inverse_dynamics():
    bench_dynamics.check_prp_routes(50)


def test_simulated_prp_sides_agree_with_armlab():
    differences = bench_simulation.check_prp(t_final=0.2)
    assert set(differences) == {bench_simulation.ARMLAB, bench_simulation.NUMERIC, bench_simulation.PINOCCHIO,
                                bench_simulation.HAND}


def test_the_adaptive_a7_sides_agree():
    assert bench_simulation.check_adaptive(t_final=0.5) <= 1e-6


def test_a_small_law_runs_the_same_called_or_inlined():
    bench_python_laws.check_inlined(t_final=0.05)


def test_simulated_puma_sides_agree_with_armlab():
    assert bench_simulation.check_puma(t_final=0.05) is not None


def test_a_threaded_gain_sweep_returns_the_one_thread_results():
    bench_simulation.check_sweep(runs=4, t_final=0.05)


def test_the_compact_closed_form_agrees_with_the_kernels():
    import armlab
    from armlab.symbolic import compact_dynamics
    from armlab.symbolic.model import symbolic_robot

    robot = armlab.load_robot("prp")
    sr = symbolic_robot(robot)
    assert bench_symbolic.check_compact(robot, sr, compact_dynamics(sr), states=3) < 1e-9


def test_mujoco_runs_the_same_a7_trajectory():
    pytest.importorskip("mujoco")
    assert bench_startup.check_mujoco(t_final=2.0) < agreement.OTHER_ALGORITHM


def test_the_random_arms_of_the_startup_benchmark_simulate(capsys):
    for n in (3, 7):
        bench_startup.first_simulate(n, t_final=0.01, dynamics="numeric")
    finals = capsys.readouterr().out.split("\n")
    assert [len(json.loads(line)["q_final"]) for line in finals if line] == [3, 7]


def test_the_report_benchmark_takes_a_quick_page_for_a_preview_only_if_it_is_one(tmp_path):
    def page(name, sections, figures):
        path = tmp_path / f"{name}.html"
        path.write_text("".join(f'<section data-assignment="{s}">' for s in sections)
                        + "".join(f'<figure data-figure="{f}">' for f in figures), encoding="utf-8")
        return path

    full = page("full", ["animation", "A1", "A6", "metrics"], ["fig-a6-positions", "fig-a6-torques"])
    quick = page("quick", ["A1", "A6", "metrics"], ["fig-a6-positions"])
    assert bench_report.check_preview(full, quick) == (2, 1)
    with pytest.raises(RuntimeError, match="lacks the sections"):
        bench_report.check_preview(full, page("short", ["A1", "metrics"], ["fig-a6-positions"]))
    with pytest.raises(RuntimeError, match="does not"):
        bench_report.check_preview(full, page("other", ["A1", "A6", "metrics"], ["fig-a6-q_err"]))
