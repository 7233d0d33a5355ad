"""Robot-specialised closed-form dynamics (armlab.specialise) against the numeric kernels, and
its use by the simulator and the computed-torque controller."""

import pickle
from dataclasses import replace

import numpy as np
import pytest

import armlab
from armlab.errors import ControllerSpecError
from armlab.scenarios import load_scenario
from armlab.simulation import SimulationError, simulate
from armlab.specialise import ClosedFormUnavailable, closed_form_module, closed_form_status, robot_key
from armlab.symbolic.energy import inertia_matrix
from armlab.symbolic.model import symbolic_robot

SMALL = ["prp", "prp_actuated", "planar2r", "link1"]


def robots():
    for name in SMALL:
        yield armlab.load_robot(name)
    yield armlab.load_robot("prp").with_link_mass("link4", 0.16)


@pytest.mark.parametrize("robot", list(robots()), ids=lambda r: f"{r.name}-{r.links[-1].inertial.mass:g}")
def test_closed_form_equals_the_numeric_kernels(robot):
    module = closed_form_module(robot)
    plant = (robot.packed, np.zeros(0))  # model, data: the generated code reads neither
    rng = np.random.default_rng(7)
    n = robot.n
    for _ in range(25):
        q = rng.uniform(-1.0, 1.0, n)
        qd, qdd, tau = rng.normal(scale=2.0, size=(3, n))
        h_e = rng.normal(size=6) * rng.integers(0, 2)        # half the states without a wrench
        tau_cf, qdd_cf = np.zeros(n), np.zeros(n)
        module.inverse_dynamics(*plant, q, qd, qdd, tau_cf)
        expected = armlab.inverse_dynamics(robot, q, qd, qdd)
        np.testing.assert_allclose(tau_cf, expected, rtol=1e-10, atol=1e-10 * np.abs(expected).max())
        assert module.forward_dynamics(*plant, q, qd, tau, h_e, qdd_cf) == 0
        expected = armlab.forward_dynamics(robot, q, qd, tau, h_e=h_e)
        np.testing.assert_allclose(qdd_cf, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_a_changed_robot_is_derived_from_its_numbers_not_its_file():
    # with_link_mass keeps the file's expressions out of the symbolic model: B follows the mass.
    light = armlab.load_robot("prp").with_link_mass("link4", 0.16)
    sr = symbolic_robot(light, numeric=True)
    q = np.array([0.1, 0.4, 0.3])
    B = np.array(inertia_matrix(sr).subs(dict(zip(sr.q, q, strict=True))), dtype=float)
    np.testing.assert_allclose(B, armlab.inertia_matrix(light, q), rtol=1e-12, atol=1e-14)


def test_simulations_through_the_closed_form_match_the_numeric_ones():
    scenario = load_scenario("a7_id_mismatch")
    runs = {}
    for dynamics in ("numeric", "closed_form"):
        controller = replace(scenario.controller, dynamics=dynamics)
        runs[dynamics] = simulate(scenario.plant, controller, q0=np.zeros(3), t_final=3.0, dt=1e-3,
                                  dynamics=dynamics)
        assert runs[dynamics].meta["dynamics"] == dynamics
    np.testing.assert_allclose(runs["closed_form"].q, runs["numeric"].q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(runs["closed_form"].tau, runs["numeric"].tau, rtol=1e-9, atol=1e-9)


def test_the_wrench_term_of_the_closed_form_in_a_contact_run():
    # The PRP pushing on a wall: h_e ≠ 0 goes through the generated Jᵀ h_e.
    scenario = load_scenario("a11_compliance")
    runs = [scenario.run(t_final=1.0, dynamics=dynamics) for dynamics in ("numeric", "closed_form")]
    assert [r.meta["dynamics"] for r in runs] == ["numeric", "closed_form"]
    assert np.abs(runs[0].signals["h_e"]).max() > 0.1
    np.testing.assert_allclose(runs[1].q, runs[0].q, rtol=0, atol=1e-9)


def test_auto_uses_the_generated_dynamics_for_small_and_large_robots():
    prp, puma = armlab.load_robot("prp"), armlab.load_robot("puma560")
    for robot in (prp, puma):
        closed_form_module(robot)           # "auto" uses a module made on request earlier
    pd = armlab.control.joint_space.JointPDGravity
    reference = armlab.references.Constant
    small = simulate(prp, pd(prp, reference(np.zeros(3)), 10.0, 2.0), q0=np.zeros(3), t_final=0.01,
                     dt=1e-3)
    large = simulate(puma, pd(puma, reference(np.zeros(6)), 10.0, 2.0), q0=np.zeros(6), t_final=0.01,
                     dt=1e-3)
    # One generator for both sizes: the traced kernels (armlab.specialise.traced).
    assert small.meta["dynamics"] == "closed_form" and large.meta["dynamics"] == "closed_form"
    assert "armlab.specialise.traced" in closed_form_module(prp).__doc__
    assert "armlab.specialise.traced" in closed_form_module(puma).__doc__


def test_auto_leaves_robots_without_a_module_on_disk_to_the_numeric_kernels(monkeypatch, tmp_path):
    from armlab import specialise

    puma = armlab.load_robot("puma560")
    specialise.closed_form_module(puma)
    module = specialise.closed_form.cache_dir() / "closed_form" / f"armlab_closed_form_{robot_key(puma)}.py"
    assert module.is_file()
    # Another cache folder, as a fresh machine has, and a process that has not met the Puma.
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(specialise.closed_form, "_OUTCOMES", {})
    assert specialise.plant_kernels(puma, "auto")[0] == "numeric"
    assert not (tmp_path / "closed_form").exists()                        # nothing was made
    # Back on this machine's cache: the module on disk is found (and checked) again.
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(module.parents[1]))
    assert specialise.plant_kernels(puma, "auto")[0] == "closed_form"


def test_bad_choices_and_unavailable_closed_forms_are_named(monkeypatch):
    from armlab import specialise

    scenario = load_scenario("a7_id_via_points")
    with pytest.raises(SimulationError, match="dynamics: 'fast'"):
        simulate(scenario.plant, scenario.controller, q0=np.zeros(3), t_final=0.01, dt=1e-3,
                 dynamics="fast")
    with pytest.raises(ControllerSpecError, match="dynamics"):
        replace(scenario.controller, dynamics="fast")
    robot = armlab.load_robot("prp")
    # A robot whose closed form disagrees with its kernels is refused, with the reason kept.
    broken = robot.replace(links=robot.links)
    monkeypatch.setitem(specialise.closed_form._OUTCOMES, robot_key(broken), "inverse dynamics differ (test)")
    with pytest.raises(ClosedFormUnavailable, match="differ"):
        closed_form_module(broken)
    assert closed_form_status(broken) == "inverse dynamics differ (test)"
    with pytest.raises(SimulationError, match="dynamics: inverse dynamics differ"):
        simulate(broken, scenario.controller, q0=np.zeros(3), t_final=0.01, dt=1e-3,
                 dynamics="closed_form")
    fallback = simulate(broken, scenario.controller, q0=np.zeros(3), t_final=0.01, dt=1e-3)
    assert fallback.meta["dynamics"] == "numeric"


def test_a_robot_with_a_closed_form_still_pickles():
    robot = armlab.load_robot("prp")
    closed_form_module(robot)
    copy = pickle.loads(pickle.dumps(robot))
    assert closed_form_module(copy) is closed_form_module(robot)


def test_a_pickled_robot_finds_its_closed_form_in_a_fresh_process(monkeypatch):
    import armlab.specialise.closed_form as cf

    robot = armlab.load_robot("prp")
    module = closed_form_module(robot)
    copy = pickle.loads(pickle.dumps(robot))
    monkeypatch.setattr(cf, "_OUTCOMES", {})          # what another process starts with
    assert closed_form_module(copy).__name__ == module.__name__


def test_generated_kernels_refuse_wrong_lengths():
    robot = armlab.load_robot("prp")
    module = closed_form_module(robot)
    plant = (robot.packed, np.zeros(0))  # model, data: the generated code reads neither
    out = np.zeros(3)
    assert module.forward_dynamics(*plant, np.zeros(2), np.zeros(3), np.zeros(3), np.zeros(6), out) == 1
    assert np.isnan(module.kinetic_energy(*plant, np.zeros(3), np.zeros(4)))
    assert module.mass_matrix(*plant, np.zeros(3), np.zeros((3, 2))) == 1
    assert module.checked_inverse_dynamics(*plant, np.zeros(3), np.zeros(3), np.zeros(4), out) == 1


@pytest.mark.parametrize("name", SMALL + ["puma560"])
def test_the_public_functions_through_the_generated_module_equal_the_kernels(name):
    robot = armlab.load_robot(name)
    rng = np.random.default_rng(11)
    n = robot.n
    for trial in range(10):
        q = rng.uniform(-1.0, 1.0, n)
        qd, qdd, tau = rng.normal(size=(3, n))
        h_e = rng.normal(size=6)
        expected = {"tau": armlab.inverse_dynamics(robot, q, qd, qdd), "B": armlab.inertia_matrix(robot, q),
                    "qdd": armlab.forward_dynamics(robot, q, qd, tau),
                    "qdd_h": armlab.forward_dynamics(robot, q, qd, tau, h_e=h_e)}
        for dynamics in ("closed_form", "auto"):
            # Lists take the converting path of the entries, arrays the direct one.
            args = (q.tolist(), qd.tolist()) if trial % 2 else (q, qd)
            got = {"tau": armlab.inverse_dynamics(robot, *args, qdd, dynamics=dynamics),
                   "B": armlab.inertia_matrix(robot, args[0], dynamics=dynamics),
                   "qdd": armlab.forward_dynamics(robot, *args, tau, dynamics=dynamics),
                   "qdd_h": armlab.forward_dynamics(robot, *args, tau, h_e=h_e, dynamics=dynamics)}
            for key, value in expected.items():
                scale = max(1.0, np.abs(value).max())
                np.testing.assert_allclose(got[key], value, rtol=1e-10, atol=1e-10 * scale,
                                           err_msg=f"{name} {dynamics} {key}")
    # Calls the module does not serve (a wrench, no gravity) run the kernels, bit for bit.
    h_e = rng.normal(size=6)
    for kwargs in ({"h_e": h_e}, {"gravity": False}):
        np.testing.assert_array_equal(armlab.inverse_dynamics(robot, q, qd, qdd, dynamics="closed_form",
                                                              **kwargs),
                                      armlab.inverse_dynamics(robot, q, qd, qdd, **kwargs))


def test_the_public_functions_name_bad_input_with_the_generated_module():
    robot = armlab.load_robot("prp")
    z = np.zeros(3)
    with pytest.raises(ValueError, match="qdd"):
        armlab.inverse_dynamics(robot, z, z, np.zeros(2), dynamics="closed_form")
    with pytest.raises(ValueError, match="q must"):
        armlab.inertia_matrix(robot, np.zeros(4), dynamics="closed_form")
    with pytest.raises(ValueError, match="tau"):
        armlab.forward_dynamics(robot, z, z, "abc", dynamics="closed_form")
    with pytest.raises(ValueError, match="h_e"):
        armlab.forward_dynamics(robot, z, z, z, h_e=np.zeros(5), dynamics="closed_form")
    with pytest.raises(ValueError, match="dynamics: 'fast' is not one of"):
        armlab.inertia_matrix(robot, z, dynamics="fast")
    for odd in (["auto"], np.array(["numeric"]), None):
        with pytest.raises(ValueError, match="dynamics: .* is not one of"):
            armlab.forward_dynamics(robot, z, z, z, dynamics=odd)
    # A str subclass names the same choice, on the first call and on later ones alike.
    fresh = armlab.load_robot(robot.name)
    for _ in range(2):
        np.testing.assert_array_equal(armlab.inertia_matrix(fresh, z, dynamics=np.str_("closed_form")),
                                      armlab.inertia_matrix(fresh, z, dynamics="closed_form"))
        np.testing.assert_array_equal(armlab.inverse_dynamics(fresh, list(z), z, z, dynamics=np.str_("auto")),
                                      armlab.inverse_dynamics(fresh, z, z, z, dynamics="auto"))
    # "numeric" by another string object than the default: the kernels, not an error.
    np.testing.assert_array_equal(armlab.inertia_matrix(robot, z, dynamics="".join("numeric")),
                                  armlab.inertia_matrix(robot, z))


def test_a_robot_keeps_its_generated_entries_out_of_pickles():
    robot = armlab.load_robot("prp")
    q = np.array([0.1, 0.7, 0.2])
    B = armlab.inertia_matrix(robot, q, dynamics="closed_form")
    # The entries are machine code, which cannot be pickled: the pickle leaves them out and
    # the copy finds them again on use.
    copy = pickle.loads(pickle.dumps(robot))
    np.testing.assert_array_equal(armlab.inertia_matrix(copy, q, dynamics="closed_form"), B)


def test_the_cache_folder_is_armlab_cache_dir_else_the_users(monkeypatch, tmp_path):
    """ARMLAB_CACHE_DIR wins over every platform default; without it (or empty) the folder is
    the user's cache folder of armlab, on Linux by the XDG base-directory rules."""
    import sys

    from armlab.specialise import cache_dir

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "mine"))
    assert cache_dir() == tmp_path / "mine"
    monkeypatch.setenv("ARMLAB_CACHE_DIR", "")
    default = cache_dir()
    assert "armlab" in default.parts and not default.is_relative_to(tmp_path / "mine")
    if sys.platform.startswith("linux"):
        assert default == tmp_path / "xdg" / "armlab"
        monkeypatch.delenv("XDG_CACHE_HOME")
        monkeypatch.delenv("ARMLAB_CACHE_DIR")
        assert cache_dir() == tmp_path / "home" / ".cache" / "armlab"


def test_auto_without_a_module_on_disk_calls_the_kernels(monkeypatch, tmp_path):
    from armlab import specialise

    puma = armlab.load_robot("puma560")
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(specialise.closed_form, "_OUTCOMES", {})
    q, qd, tau = np.full(6, 0.3), np.full(6, -0.2), np.ones(6)
    np.testing.assert_array_equal(armlab.forward_dynamics(puma, q, qd, tau, dynamics="auto"),
                                  armlab.forward_dynamics(puma, q, qd, tau))


# What "auto" does for an arm nobody asked a closed form for: a 3-joint arm with ordinary
# (random, non-round) numbers, whose symbolic derivation can take many minutes.
AUTO_PROGRAM = """
import json, pickle, sys
import numpy as np
from armlab.control.joint_space import JointInverseDynamics
from armlab.references.joint import Constant
from armlab.simulation import simulate
from armlab.specialise import inverse_dynamics_function, numeric_inverse_dynamics
with open(sys.argv[1], "rb") as stream:
    robot = pickle.load(stream)
controller = JointInverseDynamics(robot, Constant(np.zeros(3)), 25.0, 10.0)
result = simulate(robot, controller, q0=np.zeros(3), t_final=0.01, dt=1e-3)
print(json.dumps({"plant": result.meta["dynamics"],
                  "controller_numeric": inverse_dynamics_function(robot) is numeric_inverse_dynamics(),
                  "sympy": sorted(m for m in sys.modules if m.split(".")[0] == "sympy")[:3]}))
"""


def ordinary_arm(seed: int = 3):
    """A revolute–prismatic–revolute arm with random DH numbers, motors and friction."""
    import strategies
    from armlab.model.robot import Link, Robot

    rng = np.random.default_rng(seed)
    joints = tuple(strategies._joint(rng, f"j{i + 1}", kind, "standard", True, True)
                   for i, kind in enumerate(("revolute", "prismatic", "revolute")))
    links = tuple(Link(f"l{i + 1}", strategies.random_inertial(rng)) for i in range(3))
    return Robot("ordinary3", joints, links)


def test_auto_never_starts_a_derivation_and_a_module_appears_only_on_request(monkeypatch, tmp_path):
    import json
    import os
    import subprocess
    import sys

    from armlab.control.joint_space import JointInverseDynamics
    from armlab.references.joint import Constant
    from armlab.specialise import closed_form

    robot = ordinary_arm()
    pickled = tmp_path / "robot.pickle"
    pickled.write_bytes(pickle.dumps(robot))
    cache = tmp_path / "cache"
    env = dict(os.environ, ARMLAB_CACHE_DIR=str(cache))
    done = subprocess.run([sys.executable, "-c", AUTO_PROGRAM, str(pickled)], capture_output=True,
                          text=True, env=env, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report == {"plant": "numeric", "controller_numeric": True, "sympy": []}
    assert not list(cache.glob("closed_form/**/*.py"))       # no closed form generated
    # Asked for by name, a module is made (by the traced generator: its cost is bounded), and
    # from then on "auto" takes it.
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(cache))
    run = {}
    for dynamics in ("closed_form", "auto"):
        monkeypatch.setattr(closed_form, "_OUTCOMES", {})     # each as a fresh process would
        controller = JointInverseDynamics(robot, Constant(np.zeros(3)), 25.0, 10.0, dynamics=dynamics)
        run[dynamics] = simulate(robot, controller, q0=np.zeros(3), t_final=0.01, dt=1e-3, dynamics=dynamics)
        assert run[dynamics].meta["dynamics"] == "closed_form"
        assert len(list((cache / "closed_form").glob("armlab_closed_form_*.py"))) == 1
    np.testing.assert_array_equal(run["auto"].q, run["closed_form"].q)


def test_a_module_that_disagrees_on_disk_is_refused_by_auto_and_removed(monkeypatch, tmp_path):
    from armlab.specialise import closed_form

    robot = armlab.load_robot("prp")
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(closed_form, "_OUTCOMES", {})
    module = closed_form_module(robot)                        # made in this cache folder
    path = tmp_path / "closed_form" / f"{module.__name__}.py"
    # The same module with a wrong inverse dynamics and a digest that matches it, as a faulty
    # generator would write it (a file damaged after writing fails its digest and is generated
    # again: tests/test_cache_damage.py).
    body = path.read_text().rpartition("# armlab-source-sha256: ")[0]
    body = body.replace("tau_out[0] = ", "tau_out[0] = 1.0 + ", 1)
    path.write_text(body + closed_form._digest_line(body))
    monkeypatch.setattr(closed_form, "_OUTCOMES", {})
    assert closed_form.plant_kernels(robot, "auto")[0] == "numeric"
    assert "inverse dynamics differ" in closed_form_status(robot)
    assert not path.exists()
