"""Every symbolic derivation step is bounded: a budget per assignment, past which the section
keeps what it derived and says in one line what it skipped.

Arms with non-round DH and inertial parameters (exact rationals with four digits, twists that
are no multiple of π/12) made SymPy's solver and expansions run for many minutes on 3 joints.
"""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest

pytest.importorskip("sympy")

from armlab.model.toml_io import robot_from_dict  # noqa: E402
from armlab.symbolic import derive  # noqa: E402
from armlab.symbolic.budget import bounded_parts, call_within  # noqa: E402

# Wall-clock slack over a budget: on a loaded machine the parent wakes late to kill its worker.
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


def _spin():
    while True:
        try:
            sum(range(1000))
        except BaseException:  # what SymPy does in places: nothing raised inside can stop it
            pass


def _deadlock():
    lock = threading.Lock()
    lock.acquire()
    lock.acquire()  # waits for ever, in C: no exception raised into the thread would land


def _big_integer():
    return 7 ** (7 ** 12)  # one C call of many seconds


@pytest.mark.parametrize("work", [_spin, _deadlock, _big_integer])
def test_a_budget_stops_work_that_swallows_exceptions_waits_on_a_lock_or_sits_in_c(work):
    started = time.perf_counter()
    assert call_within(0.3, work) == (False, None)
    assert 0.3 <= time.perf_counter() - started < 0.3 + SLACK


def _sleep_then(seconds, value):
    time.sleep(seconds)
    return value


def test_work_done_in_time_returns_its_value_and_its_exception():
    assert call_within(30.0, _sleep_then, 0.0, {"q": [1, 2]}) == (True, {"q": [1, 2]})
    assert call_within(None, _sleep_then, 0.0, 5) == (True, 5)
    with pytest.raises(ZeroDivisionError):
        call_within(30.0, lambda: 1 / 0)
    with pytest.raises(ValueError, match="positive number of seconds"):
        call_within(0, _sleep_then, 0.0, 5)


def _nested(pid_file):
    """A budgeted call inside budgeted work (the IK inside A1): writes its pid, then sleeps."""

    def inner():
        pid_file.write_text(str(os.getpid()))
        time.sleep(120)

    return call_within(100.0, inner)


def test_stopping_work_also_stops_the_work_it_started(tmp_path):
    pid_file = tmp_path / "inner.pid"
    assert call_within(1.0, _nested, pid_file) == (False, None)
    inner = int(pid_file.read_text())
    for _ in range(50):
        try:
            os.kill(inner, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    os.kill(inner, 9)
    raise AssertionError("the inner call outlived the work that started it")


def test_parts_after_one_that_ran_out_are_still_done_and_results_before_it_are_kept():
    def work(part, emit):
        emit(f"{part} began")
        if part == "slow":
            time.sleep(120)
        emit(f"{part} ended")

    events = list(bounded_parts(["a", "slow", "b"], work, 1.0))
    assert events == [("a", "item", "a began"), ("a", "item", "a ended"), ("a", "done", None),
                      ("slow", "item", "slow began"), ("slow", "exceeded", None),
                      ("b", "item", "b began"), ("b", "item", "b ended"), ("b", "done", None)]


def test_a_budget_works_from_any_thread():
    seen = []
    worker = threading.Thread(target=lambda: seen.append(call_within(0.3, _spin)), daemon=True)
    worker.start()
    worker.join(0.3 + SLACK)
    assert seen == [(False, None)]


def test_derivations_in_the_budgets_worker_are_those_derived_in_process():
    """Results come back pickled; SymPy's unevaluated forms (−(…) kept whole) stay as built."""
    import sympy as sp

    from armlab.robots import load_robot

    robot = load_robot("prp")
    here, bounded = derive(robot, budget=None), derive(robot, budget=120.0)
    for a, b in zip(here, bounded, strict=True):
        assert (a.key, a.notes, a.complete) == (b.key, b.notes, b.complete)
        assert [(i.label, i.tex, sp.srepr(i.expr)) for i in a.items] == \
               [(i.label, i.tex, sp.srepr(i.expr)) for i in b.items]


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
            last = section.items[-1].label if section.items else None
            assert (f"after {last} ({len(section.items)} results)" if last
                    else "before its first result (0 results)") in section.notes[-1]
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
