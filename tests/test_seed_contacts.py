"""The seed's contact experiments (A11–A13): its spring surface pulls, the push variants press,
and the contact dynamics are the ones the gains give.

f_y is the force the end effector exerts on the environment along y_0 (the surface's normal
points to +y_0, into free space): pressing is f_y < 0.  The references are closed forms of the
contact's linear dynamics, M ë + D ė + (K_P + k) e = 0, from the scenario files' numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from armlab.scenarios import load_scenario
from armlab.simulation.environment import PlanarWall, Spring

SEED_AND_PUSH = (
    ("a11_compliance", "a11_compliance_push"),
    ("a11_compliance_diagonal", "a11_compliance_diagonal_push"),
    ("a12_impedance_regulation", "a12_impedance_regulation_push"),
    ("a12_impedance_tracking", "a12_impedance_tracking_push"),
    ("a13_admittance_regulation", "a13_admittance_regulation_push"),
    ("a13_admittance_tracking", "a13_admittance_tracking_push"),
)


def _force_y(name):
    run = load_scenario(name).run()
    return run, run.signals["h_e"][:, 1]


@pytest.mark.parametrize(("seed", "push"), SEED_AND_PUSH, ids=[p for _, p in SEED_AND_PUSH])
def test_the_seeds_spring_pulls_and_its_push_variant_presses(seed, push):
    """The seed's spring runs put x_d above the rest plane: the spring holds the end effector
    down (f_y > 0 on most samples), which no surface does.  Each push variant puts x_d inside
    a unilateral wall at the same plane and never pulls; its report text says so of the seed's."""
    seed_scenario, push_scenario = load_scenario(seed), load_scenario(push)
    assert isinstance(seed_scenario.environment, Spring)
    assert "pull" in seed_scenario.description
    wall = push_scenario.environment
    assert isinstance(wall, PlanarWall)
    np.testing.assert_allclose(wall.point[1], seed_scenario.environment.rest_position[1])
    depths = wall.normal @ (wall.point[:, None] - push_scenario.controller.reference.positions.T)
    assert depths.max() == pytest.approx(0.1)             # x_d reaches 0.1 m inside
    _, f_seed = _force_y(seed)
    _, f_push = _force_y(push)
    assert np.mean(f_seed > 1e-9) > 0.7 and f_seed.max() > 1.9
    assert f_push.max() <= 0.0 and f_push.min() < -0.05


def _extrema(t, d, start, stop):
    """Times and values of the local extrema of d on start < t < stop."""
    inside = np.flatnonzero((t > start) & (t < stop))
    k = inside[1:-1][(np.abs(d[inside[1:-1]]) >= np.abs(d[inside[:-2]]))
                     & (np.abs(d[inside[1:-1]]) >= np.abs(d[inside[2:]]))
                     & (np.sign(np.diff(d))[inside[1:-1] - 1] != np.sign(np.diff(d))[inside[1:-1]])]
    return t[k], d[k]


def test_the_seeds_impedance_in_contact_rings_as_its_gains_say():
    """M_d = 1 kg, K_D = 10 N·s/m, K_P + k = 10 020 N/m: ω_d = √(10 020 − 25) = 99.97 rad/s and
    the envelope decays as e^(−K_D t / 2M_d) = e^(−5t): ζ = 0.05, as the description says."""
    run, f = _force_y("a12_impedance_regulation_push")
    t_peak, d = _extrema(run.t, f - f[-1], 0.05, 0.8)
    omega_d = np.pi / np.mean(np.diff(t_peak))
    assert omega_d == pytest.approx(np.sqrt(10020.0 - 25.0), rel=0.01)
    decay = -np.polyfit(t_peak, np.log(np.abs(d)), 1)[0]
    assert decay == pytest.approx(5.0, rel=0.05)
    assert "ζ = 10/(2·100) = 0.05" in load_scenario("a12_impedance_regulation_push").description


def test_the_damped_impedance_settles_in_contact_without_ringing():
    """K_D = 140 N·s/m along the normal: ζ = 0.70 at ω_n = 100.1 rad/s; the force enters a
    2 % band of its final value within 4/(ζω_n) = 57 ms (plus the start from rest) and stays."""
    run, f = _force_y("a12_impedance_regulation_damped")
    outside = np.flatnonzero(np.abs(f - f[-1]) > 0.02 * abs(f[-1]))
    assert run.t[outside[-1]] < 0.1
    assert f[-1] == pytest.approx(-1.996008, abs=1e-5)
    _, f_seed = _force_y("a12_impedance_regulation_push")
    outside = np.flatnonzero(np.abs(f_seed - f_seed[-1]) > 0.02 * abs(f_seed[-1]))
    assert run.t[outside[-1]] > 0.5        # the seed's gains ring for more than half a second


def test_the_admittance_obeying_the_seeds_rule_stops_ringing_and_presses_harder():
    """The seed's admittance in contact: ω = √(10 020/1) = 100 rad/s above its 20 rad/s inner
    loop; the run rings (many crossings of its final force) and peaks at 50 N.  Tuned to
    ω = 4 rad/s, ζ = 1: no ringing, and the inner loop, which compensates the measured wrench,
    takes Σ_e onto Σ_t, which starts at x_d 0.1 m inside: up to k · 0.083 m = 834 N."""
    tuned = load_scenario("a13_admittance_regulation_tuned").controller
    mass, damping = np.asarray(tuned.mass_t)[2], np.asarray(tuned.kd_t)[2]   # z_d, the normal
    stiffness = 20.0 + 1e4
    assert np.sqrt(stiffness / mass) == pytest.approx(4.0)
    assert damping / (2.0 * np.sqrt(stiffness * mass)) == pytest.approx(1.0, rel=1e-3)
    assert np.sqrt(float(np.asarray(tuned.kp).flat[0])) / np.sqrt(stiffness / mass) == pytest.approx(5.0)

    def crossings(f):
        return int(np.sum(np.diff(np.sign(f - f[-1])) != 0))

    _, f_seed = _force_y("a13_admittance_regulation_push")
    _, f_tuned = _force_y("a13_admittance_regulation_tuned")
    assert crossings(f_seed) > 50 and crossings(f_tuned) <= 3
    assert 45.0 < -f_seed.min() < 55.0 and 800.0 < -f_tuned.min() < 870.0
    assert f_tuned.max() <= 0.0
