"""References (R1)–(R5): derivatives by finite differences, via-points, periodicity, bad input."""

import numpy as np
import pytest

from armlab.references.joint import (
    Constant,
    Ramp,
    ReferenceSpecError,
    Sinusoid,
    SquareWaveAcceleration,
    ViaPoints,
)

REFERENCES = [
    Sinusoid([0.1, 1.0], [0.2, 0.3], [1.0, 2.0], [0.0, 0.5]),
    ViaPoints([1, 2, 5, 6], [[0, 0], [0.1, np.pi / 3], [0.1, np.pi / 3], [0.15, np.pi / 6]]),
    SquareWaveAcceleration([0.0, 0.5], [2.0, 1.0], [4.0, 3.0]),
    Ramp([0.0, 0.1], [1.0, -0.5], [1.5, -0.4], t_start=0.5),
]


@pytest.mark.parametrize("ref", REFERENCES, ids=lambda r: type(r).__name__)
def test_velocity_and_acceleration_are_derivatives_of_position(ref):
    t = np.linspace(0.05, 9.7, 397)
    h = 1e-5
    q_plus, qd_plus, _ = ref.evaluate(t + h)
    q_minus, qd_minus, _ = ref.evaluate(t - h)
    _, qd, qdd = ref.evaluate(t)
    # Skip samples next to the ramp's corners and the square wave's switches.
    smooth = np.all(np.abs(qd_plus - qd_minus) < 1e-3 + 4 * h * (np.abs(qdd) + 1), axis=1)
    np.testing.assert_allclose(((q_plus - q_minus) / (2 * h))[smooth], qd[smooth], atol=1e-6)
    jump = np.abs(qdd - ref.evaluate(t + 3 * h)[2]) > 1e-3
    keep = smooth & ~np.any(jump, axis=1)
    np.testing.assert_allclose(((qd_plus - qd_minus) / (2 * h))[keep], qdd[keep], atol=1e-5)


def test_via_points_reach_each_point_at_rest():
    values = np.array([[0, 0, 0], [0.1, np.pi / 3, 0.05], [0.1, np.pi / 3, 0.05], [0.15, np.pi / 6, 0.1]])
    ref = ViaPoints([1, 2, 5, 6], values)
    q, qd, qdd = ref.evaluate(np.array([0.0, 1, 2, 5, 6, 9]))
    np.testing.assert_allclose(q, values[[0, 0, 1, 2, 3, 3]], atol=1e-15)
    np.testing.assert_allclose(qd, 0, atol=1e-15)
    np.testing.assert_allclose(qdd, 0, atol=1e-12)
    # Quintic midpoint: half way, peak speed 15/8 Δ/T.
    q_mid, qd_mid, _ = ref.evaluate(1.5)
    np.testing.assert_allclose(q_mid, 0.5 * values[1])
    np.testing.assert_allclose(qd_mid, 15 / 8 * values[1])


def test_square_wave_acceleration_is_periodic_with_amplitude_a_p2_over_32():
    A, P, c = 2.0, 4.0, 0.3
    ref = SquareWaveAcceleration([c], [A], [P])
    t = np.linspace(0, 3 * P, 6001)
    q, qd, qdd = ref.evaluate(t)
    assert set(np.unique(qdd)) == {-A, A}
    np.testing.assert_allclose(q.max() - c, A * P**2 / 32, rtol=1e-6)
    np.testing.assert_allclose(c - q.min(), A * P**2 / 32, rtol=1e-6)
    np.testing.assert_allclose(ref.evaluate(t + P)[0], q, atol=1e-12)
    assert abs(np.mean(qd)) < 1e-3


def test_ramp_holds_then_moves_then_stops():
    ref = Ramp([0.0], [1.0], [1.5])
    q, qd, _ = ref.evaluate(np.array([-1.0, 0.7, 1.5, 3.0]))
    np.testing.assert_allclose(q[:, 0], [0.0, 0.7, 1.5, 1.5])
    np.testing.assert_allclose(qd[:, 0], [0.0, 1.0, 0.0, 0.0])
    q, qd, qdd = Constant([0.2, -1.0]).evaluate(4.0)
    np.testing.assert_array_equal(q, [0.2, -1.0])
    assert not qd.any() and not qdd.any()


@pytest.mark.parametrize("make, field", [
    (lambda: ViaPoints([0, 0], [[0], [1]]).data, "times"),
    (lambda: ViaPoints([0, 1], [[0, 1]]).data, "values"),
    (lambda: Ramp([0], [-1], [1]).data, "slope"),
    (lambda: SquareWaveAcceleration([0], [1], [0]).data, "period"),
    (lambda: Sinusoid([0, 0], [1, 2, 3], 1.0).data, "amplitude"),
])
def test_bad_reference_names_the_field(make, field):
    with pytest.raises(ReferenceSpecError, match=field):
        make()
