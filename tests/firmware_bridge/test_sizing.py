import numpy as np
import pytest

import handarm
from handarm.firmware_bridge import sizing as S
from handarm.kinematics import forward, joint_frames
from handarm.transmission import coupling_matrix


@pytest.fixture(scope="module")
def design():
    return handarm.ArmDesign()


@pytest.fixture(scope="module")
def configs(design):
    return S.default_configurations(design, n=20)


def motor_torques(design, q, links, payload, g):
    """Independent statics: joint torque = sum over bodies of z_j . (r x F), then K^-T."""
    frames = joint_frames(design, q)
    tool = forward(design, q)[0]
    tau = np.zeros(6)
    for j in range(6):
        o, z = frames[j, :3, 3], frames[j, :3, 2]
        for i in range(j, 6):
            com = frames[i, :3, :3] @ links.coms[i] + frames[i, :3, 3]
            tau[j] += z @ np.cross(com - o, links.masses[i] * g)
        tau[j] += z @ np.cross(tool - o, payload * g)
    return np.linalg.solve(coupling_matrix(design).T, tau)


def test_max_payload_is_tight_over_every_gravity_direction(design, configs, rng):
    links = S.design_link_masses(design)
    payload, info = S.max_payload(design, configs, links)
    assert payload > 0
    dirs = rng.normal(size=(400, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    limit = 0.5 * 6.0  # MX-64T stall torque at 12 V (e-manual)
    worst = max(
        np.abs(motor_torques(design, q, links, payload, S.GRAVITY * g)).max()
        for q in configs
        for g in dirs[:40]
    )
    assert worst <= limit * (1 + 1e-6)
    # the binding case: worst direction is along the binding motor's torque row
    q = np.array(info["binding_configuration"])
    k = info["binding_motor"] - 1
    best = max(abs(motor_torques(design, q, links, payload * 1.02, S.GRAVITY * g)[k]) for g in dirs)
    assert best > limit * 0.99


def test_any_direction_is_stricter_than_a_finite_set(design, configs):
    cone, _ = S.max_payload(design, configs)
    cube, _ = S.max_payload(design, configs, directions=S.gravity_directions())
    assert cone <= cube + 1e-9


def test_pulley_sizing(design, configs):
    sized = S.size_pulleys(design, configs, radius_range=(0.004, 0.02), min_speed=np.radians(180))
    assert np.all(sized.radii >= 0.004 - 1e-9) and np.all(sized.radii <= 0.02 + 1e-9)
    # each joint alone reaches the speed floor with the motors at no-load speed
    d2 = design.replace(joint_pulley_radii=tuple(sized.radii))
    from handarm.transmission import joint_velocity_limits

    assert np.all(joint_velocity_limits(d2) >= np.radians(180) * (1 - 1e-6))
    # the sizing agrees with the payload the sized arm really has, gravity in any direction
    check, _ = S.max_payload(d2, configs)
    assert check == pytest.approx(sized.payload, abs=2e-4)
    # and is no worse than the design's own pulleys, which satisfy the same constraints
    mine, _ = S.max_payload(design, configs)
    assert sized.payload >= mine - 2e-4
    # a finite set of directions is looser: its payload is at least the any-direction one
    cube = S.size_pulleys(
        design,
        configs,
        radius_range=(0.004, 0.02),
        min_speed=np.radians(180),
        directions=S.gravity_directions(),
    )
    assert cube.payload >= sized.payload - 2e-4


def test_sizing_errors(design):
    with pytest.raises(ValueError, match="safety"):
        S.max_payload(design, safety=0.0)
    with pytest.raises(ValueError, match="radius_range"):
        S.size_pulleys(design, radius_range=(0.02, 0.01))
    with pytest.raises(ValueError, match="min_speed: joint 1 cannot reach"):
        S.size_pulleys(design, radius_range=(0.01, 0.02), min_speed=10.0)
