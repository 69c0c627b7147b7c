import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import handarm
from handarm.transmission import (
    coupling_matrix,
    joint_from_motor,
    joint_torque_from_motor,
    motor_from_joint,
    motor_from_ticks,
    motor_ranges,
    motor_torque_from_joint,
    ticks_from_motor,
)

angles = arrays(np.float64, 6, elements=st.floats(-3, 3))


def routed(rng):
    signs = [[int(rng.choice([-1, 1])) if j <= k else 0 for j in range(6)] for k in range(6)]
    return handarm.ArmDesign(
        routing_signs=signs,
        joint_pulley_radii=rng.uniform(0.005, 0.015, 6),
        motor_pulley_radius=0.01,
    )


def test_coupling_matrix_is_the_routing(rng):
    d = routed(rng)
    k = coupling_matrix(d)
    assert np.allclose(np.triu(k, 1), 0)
    for row in range(6):
        for j in range(row + 1):
            assert k[row, j] == pytest.approx(
                d.routing_signs[row][j] * d.joint_pulley_radii[j] / d.motor_pulley_radius
            )


@settings(max_examples=100, deadline=None)
@given(q=angles, tau=angles, seed=st.integers(0, 1000))
def test_round_trips_and_virtual_work(q, tau, seed):
    d = routed(np.random.default_rng(seed))
    phi = motor_from_joint(d, q)
    np.testing.assert_allclose(joint_from_motor(d, phi), q, atol=1e-12)
    tj = joint_torque_from_motor(d, tau)
    np.testing.assert_allclose(motor_torque_from_joint(d, tj), tau, atol=1e-9)
    # virtual work: motor power equals joint power for any velocity
    assert np.dot(tau, phi) == pytest.approx(np.dot(tj, q), abs=1e-9)


def test_ticks_round_trip(design, rng):
    offsets = rng.integers(0, 4096, 6)
    phi = rng.uniform(-10, 10, 6)
    ticks = ticks_from_motor(design, phi, offsets)
    back = motor_from_ticks(design, ticks, offsets)
    np.testing.assert_allclose(back, phi, atol=2 * math.pi / 4096)


def test_motor_ranges_bound_the_limit_box(rng):
    d = routed(rng)
    ranges = motor_ranges(d)
    q = rng.uniform(d.lower, d.upper, (20000, 6))
    phi = motor_from_joint(d, q)
    lo = np.array([r.lo for r in ranges])
    hi = np.array([r.hi for r in ranges])
    assert np.all(phi >= lo - 1e-12) and np.all(phi <= hi + 1e-12)
    # and they are tight: a corner of the box reaches each bound
    k = coupling_matrix(d)
    corner = np.where(k[5] > 0, d.upper, d.lower)
    assert motor_from_joint(d, corner)[5] == pytest.approx(hi[5])


def test_modes_of_the_paper_arm():
    ranges = motor_ranges(handarm.ArmDesign())
    assert [r.mode for r in ranges] == ["joint"] + ["multi-turn"] * 5
    assert ranges[0].travel_ticks == pytest.approx(270 / 360 * 4096)


def test_too_much_travel_is_a_clear_error():
    d = handarm.ArmDesign(joint_pulley_radii=(0.05,) * 6)  # 6x the motor turns
    with pytest.raises(ValueError, match=r"joint_limits: motor \d would turn .* multi-turn"):
        motor_ranges(d)
