"""Every symbolic derivation step is bounded: a budget per assignment, past which the section
keeps what it derived and says in one line what it skipped.

Arms with non-round DH and inertial parameters (exact rationals with four digits, twists that
are no multiple of π/12) made SymPy's solver and expansions run for many minutes on 3 joints.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

pytest.importorskip("sympy")

from armlab.model.toml_io import robot_from_dict  # noqa: E402
from armlab.symbolic import derive  # noqa: E402
from armlab.symbolic.budget import Budget, BudgetExceeded  # noqa: E402

# Wall-clock slack over a budget: the watchdog wakes late on a loaded machine and Python
# raises the exception at its next check, after the C call it is in (a big-integer product).
SLACK = 8.0


def non_round_arm(n: int, rng: np.random.Generator) -> dict:
    """A robot-file table of ``n`` joints whose every number has four significant digits."""

    def odd(low, high):
        return float(f"{rng.uniform(low, high):.4g}")

    joints = []
    for i in range(n):
        inertia = np.diag([odd(0.010, 0.014) for _ in range(3)]) + odd(1e-4, 9e-4) * (1 - np.eye(3))
        joints.append({
            "name": f"q{i + 1}", "type": "prismatic" if i == 1 and n > 2 else "revolute",
            "dh": {"a": odd(0.05, 0.4), "alpha": odd(-1.5, 1.5), "d": odd(-0.2, 0.2), "theta": odd(-1, 1)},
            "limits": [-3.0, 3.0] if i != 1 or n <= 2 else [-0.4, 0.4],
            "link": {"mass": odd(0.5, 3.0), "com": [odd(-0.1, 0.1) for _ in range(3)],
                     "inertia": inertia.tolist()}})
    return {"name": f"odd{n}", "dh_convention": "standard", "joints": joints}


def test_a_budget_stops_busy_work_even_where_exceptions_are_swallowed():
    with Budget(0.3, "spin") as budget:
        while True:
            try:
                sum(range(1000))
            except Exception:  # what SymPy does in many places
                pass
    assert budget.exceeded and 0.3 <= budget.elapsed < 0.3 + SLACK


def test_a_budget_that_ended_in_time_never_fires_later_and_nests():
    with Budget(0.2, "quick") as quick:
        pass
    time.sleep(0.5)  # past its expiry: nothing may arrive now
    assert not quick.exceeded
    seen = []
    with Budget(0.2, "outer") as outer:
        try:
            with Budget(100.0, "inner") as inner:
                while True:
                    pass
        except BudgetExceeded as error:
            seen.append(str(error))
            raise
    assert outer.exceeded and not inner.exceeded
    assert seen == ["outer exceeded its budget of 0.2 s"]


def test_a_budget_works_in_any_thread():
    seen = []

    def work():
        with Budget(0.2, "thread") as budget:
            while True:
                pass
        seen.append(budget.exceeded)

    worker = threading.Thread(target=work)
    worker.start()
    worker.join(0.2 + SLACK)
    assert seen == [True]


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6, 7])
def test_random_non_round_arms_derive_within_their_budget(n):
    robot = robot_from_dict(non_round_arm(n, np.random.default_rng(n)), f"odd{n}.toml")
    budget = 0.5
    for key in ("A1", "A2", "A3", "A4", "A5"):
        started = time.perf_counter()
        (section,) = derive(robot, only=key, budget=budget)
        elapsed = time.perf_counter() - started
        assert elapsed < budget + SLACK, (key, elapsed)
        if not section.complete:
            assert f"{key} stopped after its budget of 0.5 s" in section.notes[-1]
            assert "\n" not in section.notes[-1]


def test_the_three_joint_arm_that_hung_says_what_it_skipped():
    """SymPy's polynomial solver (the closed-form IK of A1) ran for minutes on this arm; it has
    its own share of A1's budget, so the Jacobians after it are still tried, and the note says
    which step was skipped and why.  Called on its own: what ran before it in A1 depends on
    the machine's load, this does not."""
    from armlab.symbolic.model import symbolic_robot
    from armlab.symbolic.sections import IK_SHARE, Section, _inverse_kinematics

    robot = robot_from_dict(non_round_arm(3, np.random.default_rng(29)), "odd3.toml")
    section = Section("A1", "A1", budget=2.0)
    started = time.perf_counter()
    assert _inverse_kinematics(section, symbolic_robot(robot), "0") is None
    assert time.perf_counter() - started < IK_SHARE * 2.0 + SLACK
    (note,) = section.notes
    assert note.startswith("Closed-form inverse kinematics skipped: SymPy's polynomial solver did not "
                           "finish within 0.8 s")


def test_derive_refuses_a_budget_that_is_no_time():
    from armlab.robots import load_robot

    with pytest.raises(ValueError, match="budget must be a positive number"):
        derive(load_robot("prp"), only="A1", budget=0)


def test_derive_command_stays_within_budget_on_a_non_round_arm(tmp_path, capsys):
    import json

    from armlab.cli import main

    arm = non_round_arm(3, np.random.default_rng(29))
    lines = [f'name = "{arm["name"]}"', 'dh_convention = "standard"']
    for joint in arm["joints"]:  # JSON arrays and strings are TOML arrays and strings
        link = joint["link"]
        lines += ["[[joints]]", f'name = "{joint["name"]}"', f'type = "{joint["type"]}"',
                  "dh = {" + ", ".join(f"{k} = {v}" for k, v in joint["dh"].items()) + "}",
                  f"limits = {json.dumps(joint['limits'])}", "[joints.link]",
                  *(f"{k} = {json.dumps(v)}" for k, v in link.items())]
    path = tmp_path / "odd3.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    started = time.perf_counter()
    assert main(["derive", str(path), "--only", "A3", "--budget", "1"]) == 0
    assert time.perf_counter() - started < 1 + SLACK + 20  # + SymPy's import
    out, err = capsys.readouterr()
    assert "budget of 1 s spent" in err and "A3 stopped after its budget of 1 s" in out


def test_a_report_derivation_cut_short_is_shown_and_not_cached(tmp_path, monkeypatch):
    from armlab.progress import progress_bar
    from armlab.viz import report

    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
    robot = robot_from_dict(non_round_arm(3, np.random.default_rng(29)), "odd3.toml")
    derived = report._cached_symbolic_sections(robot, progress_bar(5, enabled=False), 0.5)
    assert "stopped after its budget of 0.5 s" in derived[3]
    assert not report._derivation_cache(robot).exists()
