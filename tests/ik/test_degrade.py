import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.ik.conftest import HOSTILE_D3, random_design, valid_configurations

import handarm
from handarm import ik


def angle(a, b):
    return 2 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def solvable(design, p, dirs):
    return ik.solve_batch(design, np.broadcast_to(p, dirs.shape).copy(), dirs).counts > 0


def check_pose(design, r):
    p2, e2 = handarm.forward(design, r.solutions)
    np.testing.assert_allclose(p2, np.broadcast_to(r.achieved_position, p2.shape), atol=1e-9)
    np.testing.assert_allclose(e2, np.broadcast_to(r.achieved_direction, e2.shape), atol=1e-9)
    assert handarm.is_valid(design, r.solutions).all()


def pitch_yaw_grid(p, e, design, step_deg=1.0):
    """Smallest direction change found by a brute-force grid over pitch (yaw kept) and yaw.

    The grid is offset by half a step so that it never lands on straight up/down, where a
    vertical direction would let L take any azimuth (keeping neither pitch nor yaw).
    """
    pitch, yaw = math.asin(e[2]), math.atan2(e[1], e[0])
    t = np.radians(np.arange(-180, 180, step_deg) + 0.5 * step_deg)
    along_pitch = np.stack([np.cos(t) * math.cos(yaw), np.cos(t) * math.sin(yaw), np.sin(t)], 1)
    along_yaw = np.stack(
        [
            math.cos(pitch) * np.cos(t),
            math.cos(pitch) * np.sin(t),
            np.full_like(t, math.sin(pitch)),
        ],
        1,
    )
    dirs = np.concatenate([along_pitch, along_yaw])
    ok = solvable(design, p, dirs)
    return float(angle(dirs[ok], e).min()) if ok.any() else math.inf


@pytest.fixture(scope="module")
def four_dof_targets():
    d = handarm.ArmDesign()
    rng = np.random.default_rng(11)
    q = valid_configurations(d, rng, 400)
    p = handarm.forward(d, q)[0]
    e = rng.normal(size=(400, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    b = ik.solve_batch(d, p, e)
    keep = np.flatnonzero(b.counts == 0)[:25]
    return d, p[keep], e[keep]


def test_four_dof_no_worse_than_grid(four_dof_targets):
    d, P, E = four_dof_targets
    assert len(P) >= 10
    levels = []
    for p, e in zip(P, E, strict=True):
        r = ik.solve(d, p, e)
        levels.append(r.reached_dof)
        assert r.count > 0
        check_pose(d, r)
        np.testing.assert_allclose(r.achieved_position, p, atol=1e-12)
        assert r.position_error == 0.0
        if r.reached_dof == 4:
            assert r.direction_error <= pitch_yaw_grid(p, e, d) + 1e-9
            # only pitch or only yaw changed
            pitch, yaw = math.asin(e[2]), math.atan2(e[1], e[0])
            a = r.achieved_direction
            same_yaw = (
                abs(math.sin(math.atan2(a[1], a[0]) - yaw)) < 1e-9 or math.hypot(*a[:2]) < 1e-9
            )
            same_pitch = abs(a[2] - e[2]) < 1e-9
            assert same_yaw or same_pitch
            assert not np.isnan(pitch)
    assert 4 in levels


def _fibonacci(n):
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = math.pi * (1 + 5**0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


@pytest.mark.slow  # about a minute; level 3 is also checked by test_degrade_levels
def test_three_dof_no_worse_than_sphere_grid():
    d = handarm.ArmDesign()
    rng = np.random.default_rng(0)
    # tool points pushed towards the edge of the workspace, random directions: 3 DoF is rare
    q = valid_configurations(d, rng, 2000)
    p = handarm.forward(d, q)[0] * 1.06
    e = rng.normal(size=p.shape)
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    b = ik.solve_batch(d, p, e)
    found = 0
    for i in np.flatnonzero(b.counts == 0)[:200]:
        r = ik.solve(d, p[i], e[i])
        if r.reached_dof != 3:
            continue
        found += 1
        check_pose(d, r)
        np.testing.assert_allclose(r.achieved_position, p[i], atol=1e-12)
        assert pitch_yaw_grid(p[i], e[i], d) == math.inf  # 4 DoF really was impossible
        sphere = _fibonacci(1000)
        ok = solvable(d, p[i], sphere)
        assert r.direction_error <= angle(sphere[ok], e[i]).min() + 1e-6
    assert found >= 2


def test_two_dof_nearest_position_and_pointing():
    d = handarm.ArmDesign()
    rng = np.random.default_rng(12)
    q = valid_configurations(d, rng, 200000)
    cloud = handarm.forward(d, q)[0]
    for p in ([0.5, 0.1, 0.2], [0.0, 0.0, 0.3], [-0.2, -0.2, 0.2], [0.1, 0.0, -0.28]):
        p = np.asarray(p)
        r = ik.solve(d, p, [1.0, 0.0, 0.0])
        assert r.reached_dof == 2
        check_pose(d, r)
        brute = np.linalg.norm(cloud - p, axis=1).min()
        assert r.position_error <= brute + 1e-9
        assert r.position_error == pytest.approx(np.linalg.norm(r.achieved_position - p), abs=1e-12)
        aim = (p - r.achieved_position) / np.linalg.norm(p - r.achieved_position)
        # pointing at the target whenever the arm can, else its stretched direction
        if angle(r.achieved_direction, aim) > 1e-9:
            assert ik.solve(d, r.achieved_position, aim, degrade=False).count == 0


def _disk_bound(design, p):
    """(bound, q): no tool point comes nearer p than bound, and q is the configuration that
    would meet it.

    Every tool point lies within a4 + a5 + a6 of the base-plane disk of radius a2 + a3 about
    joint 2, at a1 (cos q1, sin q1): the bound is the least over q1 within its limits (here
    over a dense grid, its ends and p's azimuth) of p's distance from that disk, less a4 +
    a5 + a6; q is the arm stretched towards p from joint 2 at that q1.
    """
    a = design.lengths
    r2, rt = a[2] + a[3], a[4:7].sum()
    azimuth = math.atan2(p[1], p[0])
    q1s = np.concatenate([np.linspace(design.lower[0], design.upper[0], 20001),
                          azimuth + 2 * np.pi * np.arange(-1, 2)])  # fmt: skip
    q1s = q1s[(q1s >= design.lower[0]) & (q1s <= design.upper[0])]
    vx, vy = p[0] - a[1] * np.cos(q1s), p[1] - a[1] * np.sin(q1s)
    dist = np.hypot(np.maximum(np.hypot(vx, vy) - r2, 0.0), p[2]) - rt
    k = np.argmin(dist)
    r = math.hypot(vx[k], vy[k])
    q = np.array(
        [q1s[k], math.atan2(vy[k], vx[k]) - q1s[k], 0.0, math.atan2(p[2], r - r2), 0.0, 0.0]
    )
    q[1] = math.remainder(q[1], 2 * math.pi)
    return float(dist[k]), q, r > r2


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_two_dof_beyond_reach_meets_the_bound_where_the_stretched_arm_can(seed):
    """Beyond the reach the arm stretched towards p from joint 2, with joint 1 as near p's
    azimuth as its limits allow, is the nearest point of all whenever it is within the
    limits and valid (above or below the base's reach, the arm with joint 4 under p and the
    tip chain vertical): level 2 answers with exactly the bound's distance, no farther than
    a polish of the seeds and no farther than a brute-force cloud of valid configurations;
    elsewhere never nearer than the bound."""
    from handarm.ik import degrade

    rng = np.random.default_rng(seed)
    d = handarm.ArmDesign() if seed == 0 else random_design(rng)
    cloud = handarm.forward(d, valid_configurations(d, rng, 100000))[0]
    reach = float(d.lengths[1:].sum())
    p_all = rng.normal(size=(40, 3))
    p_all *= reach * rng.uniform(1.01, 1.6, (40, 1)) / np.linalg.norm(p_all, axis=1, keepdims=True)
    # and points within the stretched arm's length that the bound still puts out of reach
    # (behind the base, beyond joint 1's limits)
    near = rng.normal(size=(4000, 3))
    near *= reach * rng.uniform(0.6, 1.0, (4000, 1)) / np.linalg.norm(near, axis=1, keepdims=True)
    near = [p for p in near if _disk_bound(d, p)[0] > 1e-6][:15]
    assert seed == 0 or len(near) >= 5
    met = behind = above = 0
    for p in [*p_all, *near]:
        e = rng.normal(size=3)
        r = ik.solve(d, p, e / np.linalg.norm(e))
        assert r.reached_dof == 2
        check_pose(d, r)
        bound, q, outside = _disk_bound(d, p)
        assert r.position_error >= bound - 1e-12
        assert r.position_error <= np.linalg.norm(cloud - p, axis=1).min() + 1e-12
        polished = degrade._two_dof(d, p, e, None, degrade._polished(d, p, None))
        assert r.position_error <= polished.position_error + 1e-12
        if outside and handarm.is_valid(d, q):
            met += 1
            behind += abs(q[1]) > 1e-9  # joint 1 at a limit, the arm stretched from joint 2
            assert r.position_error == pytest.approx(bound, abs=1e-12)
            np.testing.assert_allclose(r.achieved_position, handarm.forward(d, q)[0], atol=1e-12)
        elif not outside and seed == 0:
            # above or below the base's reach: joint 4 under p, the tip chain vertical
            above += 1
            assert r.position_error == pytest.approx(bound, abs=1e-12)
            np.testing.assert_allclose(r.achieved_position[:2], p[:2], atol=1e-12)
    assert met >= 10 and (seed != 0 or (behind >= 3 and above >= 3))


def _above_family(design, p, n_psi=3600, psi=None):
    """Valid configurations with joint 4 under (or over) p and the tip chain vertical, on a
    grid of tip-plane azimuths psi (n_psi over the turn, unless given) and both elbows:
    above or below the base's reach every one of them is a nearest point of all
    (``forward`` confirms each reaches (p_x, p_y, +-(a4 + a5 + a6)))."""
    a = design.lengths
    if psi is None:
        psi = np.linspace(-np.pi, np.pi, n_psi, endpoint=False)
    n_psi = len(psi)
    # joint 3 one link back from joint 4 along the tip plane; joints 1 and 2 reach it
    j3 = np.stack([p[0] - a[3] * np.cos(psi), p[1] - a[3] * np.sin(psi)], 1)
    rows = []
    for elbow in (1, -1):
        with np.errstate(invalid="ignore"):  # NaN where joint 3 is out of their reach
            q2 = elbow * np.arccos(((j3**2).sum(1) - a[1] ** 2 - a[2] ** 2) / (2 * a[1] * a[2]))
        q1 = np.arctan2(j3[:, 1], j3[:, 0]) - np.arctan2(
            a[2] * np.sin(q2), a[1] + a[2] * np.cos(q2)
        )
        q = np.zeros((n_psi, 6))
        q[:, 0], q[:, 1] = np.angle(np.exp(1j * q1)), q2
        q[:, 2] = np.angle(np.exp(1j * (psi - q1 - q2)))
        q[:, 3] = math.copysign(np.pi / 2, p[2])
        rows.append(q[np.isfinite(q2)])
    q = np.concatenate(rows)
    q = q[np.all((q >= design.lower) & (q <= design.upper), axis=1)]
    tip = handarm.forward(design, q)[0]
    rt = a[4:7].sum()
    at = np.all(np.abs(tip - [p[0], p[1], math.copysign(rt, p[2])]) < 1e-9, axis=1)
    assert at.all()
    return q[handarm.is_valid(design, q)]


@pytest.mark.parametrize(
    ("height", "radius", "e"),
    [
        (0.02, 0.5, [0.3, -0.2, 0.9]),
        (-0.02, 0.8, [0.3, -0.2, 0.9]),
        # bench_tracking's 13th circle: joint 1 at its limit, valid azimuths a sliver
        (0.011947956557823937, 0.48318628787506973, [0.946, -0.270, 0.179]),
    ],
)
def test_level_two_over_the_base_follows_the_nearest_of_the_nearest_points(height, radius, e):
    """A target circling above (below) the base's reach: every answer meets the bound (the
    tip chain vertical under the target) and moves current no farther than the nearest
    valid configuration that meets it (a dense grid of them, less its spacing). The first
    version took the nearest of 72 azimuths: along a contact its steps jumped 19 degrees
    where one of 1 degree met the bound."""
    d = handarm.ArmDesign()
    a = d.lengths
    rt, rho = a[4:7].sum(), radius * (a[1] + a[2] + a[3])
    e = np.array(e) / np.linalg.norm(e)
    n = int(2 * math.pi * rho / 0.004)
    current, checked = np.zeros(6), 0
    for t in np.linspace(0, 2 * math.pi, n):
        p = np.array([rho * math.cos(t), rho * math.sin(t), math.copysign(rt, height) + height])
        r = ik.solve(d, p, e, current=current)
        family = _above_family(d, p)
        if r.reached_dof == 2 and len(family):
            checked += 1
            assert r.position_error == pytest.approx(abs(height), abs=1e-12)
            nearest = np.linalg.norm(family - current, axis=1).min()
            assert np.linalg.norm(r.follow - current) <= nearest + math.radians(0.3)
        current = r.follow
    assert checked >= 0.8 * n


@pytest.mark.parametrize("beyond", [1e-13, 5e-13, 2e-12, 1e-11, 1e-10, 2e-9])
def test_just_beyond_the_reach_is_reached_only_to_rounding(beyond):
    """A target a hair beyond the stretched arm: reached (error 0) only within 1e-12 m,
    the kinematics' rounding; beyond that level 2, with the true distance as its error."""
    d = handarm.ArmDesign()
    a = d.lengths
    q = np.array([0.3, 0.0, 0.0, 0.4, 0.0, 0.0])  # stretched from joint 2
    tip = handarm.forward(d, q)[0]
    joint2 = a[1] * np.array([math.cos(0.3), math.sin(0.3), 0.0])
    p = tip + beyond * (tip - joint2) / np.linalg.norm(tip - joint2)
    r = ik.solve(d, p, [0.0, 0.0, 1.0])
    true = np.linalg.norm(handarm.forward(d, r.solutions)[0] - p, axis=-1).max()
    if r.reached_dof >= 3:
        assert r.position_error == 0.0 and true <= 1e-12
    else:
        assert r.reached_dof == 2 and beyond > 1e-12
        assert r.position_error == pytest.approx(true, rel=1e-9)
        assert true == pytest.approx(beyond, rel=0.05)


def test_level_two_over_the_base_with_e_along_the_aim_keeps_the_nearest_member():
    """e straight down, p under the base's reach: the nearest member already points at p,
    so the exact pose it re-aims at (a vertical L, its ranges at one azimuth) may not move
    current farther. Found by a hostile check on a random design: 163 degrees where the
    nearest member was 127 away (and flagged family_ended, so the loop took it)."""
    d = handarm.ArmDesign(
        link_lengths=(0.03569672805495898, 0.037909468604847396, 0.06885354443565682,
                      0.025514956528105814, 0.056006031557939234, 0.06371363160870767,
                      0.031274064401996204),
        joint_limits=((-0.8328803313642594, 1.3700086144900505),
                      (-2.3045436017226044, 2.0720058928974563),
                      (-1.0648029816719216, 1.75524814510478),
                      (-2.333533515673782, 1.7311895413722387),
                      (-2.2452930563411333, 3.062023675043226),
                      (-2.367173922337149, 1.6550516885724846)),
    )  # fmt: skip
    p = np.array([0.07398295034784397, -0.013903005853003953, -0.15333087565881418])
    current = np.array([1.3650635879672062, -1.776882317739578, -1.0566858897463558,
                        -1.5707963344230342, -1.4901161e-08, 2.2529307e-08])  # fmt: skip
    r = ik.solve(d, p, [0.0, 0.0, -1.0], current=current)
    assert r.reached_dof == 2
    family = _above_family(d, p, 36000)
    nearest = np.linalg.norm(family - current, axis=1).min()
    assert np.linalg.norm(r.follow - current) <= nearest + math.radians(0.1)


def test_level_two_under_the_base_with_the_elbow_straight_tries_both_elbows():
    """Joint 2 nearly straight (q2 = -3e-4): the members of the other elbow are as near
    current as its own; the nearest was missed by 0.3 degrees (a hostile check)."""
    d = handarm.ArmDesign()
    p = np.array([-0.03462321570379469, 0.10136563324812528, -0.17740387078178174])
    current = np.array([1.4112607339506127, -0.00031494958643631636, 1.6404534860614586,
                        -math.pi / 2, 0.0, 0.0])  # fmt: skip
    r = ik.solve(d, p, [0.0, 0.0, -1.0], current=current)
    assert r.reached_dof == 2
    family = _above_family(d, p, 36000)
    nearest = np.linalg.norm(family - current, axis=1).min()
    assert np.linalg.norm(r.follow - current) <= nearest + math.radians(0.05)


@pytest.mark.parametrize(
    ("p", "current"),
    [
        # the case that found it: current's own nearest point in collision (19 deg steps)
        ([0.07402876969784347, -0.01203084606433205, 0.17],
         [0.374848176239227, -0.111933806146062, -2.270043007886643]),
        # valid azimuths 5.4 deg from current's, between two of 72 samples (208 deg)
        ([-0.060472290048612154, -0.03995190088171706, 0.16194795655782396],
         [2.210734691397633, 1.553588465514745, 1.1272681511775602]),
        # joint 1 at its limit: valid azimuths a sliver 1.3 deg away (147 deg)
        ([-0.016968619113992403, 0.07046359494909604, 0.16194795655782396],
         [2.3561795435626234, -0.15656711027835687, -2.297449005136921]),
    ],
)  # fmt: skip
def test_level_two_over_the_base_from_beside_a_contact_or_a_limit(p, current):
    """Cases a circling target met on the paper's arm: the answer moves current no farther
    than the nearest valid configuration meeting the bound (a dense grid, less its spacing)."""
    d = handarm.ArmDesign()
    p, current = np.array(p), np.array([*current, math.pi / 2, 0.0, 0.0])
    assert handarm.is_valid(d, current)
    r = ik.solve(d, p, [0.3, -0.2, 0.9], current=current)
    assert r.reached_dof == 2
    family = _above_family(d, p, 36000)
    nearest = np.linalg.norm(family - current, axis=1).min()
    assert nearest < math.radians(10)
    assert np.linalg.norm(r.follow - current) <= nearest + math.radians(0.1)


@pytest.mark.parametrize(
    ("design", "p", "e", "current", "psi_oracle"),
    [
        # joint 3 at its limit: the other elbow's valid azimuths a sliver 0.0048 deg wide
        (HOSTILE_D3, [0.031166361759102482, 0.09112157202024365, -0.132103141544535], [0, 0, -1],
         [1.7534192802779085, 0.03630717344946224, -1.9607554259226478, -math.pi / 2, 0, 0],
         -0.1556),
        # the same on the paper's arm, 0.0033 deg wide
        ({}, [0.016482966394983107, 0.07212987040087697, -0.15756523649754814], [0, 0, -1],
         [1.8041349302685017, 0.0422913725718821, -2.356167862991318, -math.pi / 2, 0, 0],
         -0.5019),
        # joint 4 1e-9 m inside the rim of the base's reach: the family 0.019 deg wide
        ({}, [-0.05762643691900767, 0.13848896514783998, 0.15500000000000003], [1, 0, 0],
         [0.7019558966675836, -2.0798056978900274, 2.356194490192345, 0.19867388276560138,
          -1.1179326651850483, -2.1896842675454837], 1.9653),
    ],
)  # fmt: skip
def test_level_two_over_the_base_finds_slivers_of_the_family(design, p, e, current, psi_oracle):
    """Cases a hostile check found (2026-11-27) where the valid members of the family are a
    sliver narrower than any grid: at a joint limit (found now by bisecting where each joint
    crosses its limit between samples) and next to the rim of the base's reach (where the
    samples now spread over the arc the family exists on). The oracle: a window of 40,001
    azimuths 1e-6 rad apart about the member the check found (psi_oracle, rad)."""
    d = handarm.ArmDesign(**design)
    p, current = np.array(p), np.array(current, dtype=float)
    r = ik.solve(d, p, e, current=current)
    bound = abs(p[2]) - d.lengths[4:7].sum()
    assert r.reached_dof == 2
    assert r.position_error == pytest.approx(bound, abs=1e-12)
    assert handarm.is_valid(d, r.follow)
    family = _above_family(d, p, psi=psi_oracle + np.linspace(-0.02, 0.02, 40001))
    assert len(family)
    nearest = np.linalg.norm(family - current, axis=1).min()
    assert np.linalg.norm(r.follow - current) <= nearest + 1e-5


def test_on_the_edge_of_the_reach_the_closed_form_keeps_the_nearest_member():
    """A target 1e-13 m beyond the edge (within rounding of it): only the family meeting the
    bound reaches it; a polish found another member, and follow jumped 233 degrees where
    the nearest moved 150 (a hostile check on a random design)."""
    d = handarm.ArmDesign(
        link_lengths=(0.07658336633434205, 0.050679653168861694, 0.07857462234246225,
                      0.024850161433736133, 0.056441349919701775, 0.04258919506263635,
                      0.06811407241914844),
        joint_limits=((-1.1245836047217372, 2.8279384583514724),
                      (-2.0272312741703575, 2.9026590191039263),
                      (-1.8640377047859684, 1.7500325457518795),
                      (-2.625892198950768, 3.102871127702595),
                      (-1.6015422383840354, 3.0656813328487247),
                      (-2.9681714034159903, 1.1323165957077874)),
    )  # fmt: skip
    p = np.array([-0.06987611641986068, 0.03920183274212714, -0.16714461740158656])
    current = np.array([0.8254084941786128, 0.0, 1.5302918234320786, -0.6989184755305362,
                        -1.4737517678495626, 1.0683944151701734])  # fmt: skip
    r = ik.solve(d, p, [0, 0, 1], current=current)
    assert r.reached_dof in (2, 3)
    assert np.linalg.norm(handarm.forward(d, r.follow)[0] - p) < 2e-13
    family = _above_family(d, p, 36000)
    nearest = np.linalg.norm(family - current, axis=1).min()
    assert np.linalg.norm(r.follow - current) <= nearest + math.radians(0.02)


_DIP_D1 = dict(
    link_lengths=(0.03879529311654294, 0.043283391717706204, 0.032197016963953315,
                  0.05414200351434156, 0.06684253245031956, 0.07271488793526705,
                  0.06289267534923523),
    joint_limits=((-3.132860600278521, 2.260887492059366),
                  (-1.721725248979758, 2.064849453125947),
                  (-2.8027309708581813, -1.7702700671280538),
                  (-0.8772097352289965, 2.7234741349983858),
                  (-1.0698176993032968, 2.4710596210901548),
                  (-1.821379629599072, 2.7739323069522577)),
)  # fmt: skip
_DIP_D3 = dict(
    link_lengths=(0.04332162511670202, 0.02859920813088308, 0.024635179394790232,
                  0.0670758176079379, 0.06814810239707461, 0.032242230531537006,
                  0.051529326034298745),
    joint_limits=((-1.0392258272209194, 1.6217076456277855),
                  (-2.6891976157717496, 1.836775706356911),
                  (-1.9150056744706418, 0.8616750484805993),
                  (-2.4796092668748115, 2.980848016888677),
                  (-2.1847187313898098, 1.7353852168399022),
                  (-1.3441280494844687, 1.7951860106905766)),
)  # fmt: skip


@pytest.mark.parametrize(
    ("design", "p", "current", "sphere", "psi_oracle"),
    [
        # joint 3 dips within its limit between two samples, both outside: 0.03 deg missed
        (_DIP_D1, [0.10052985294504783, 0.0, 0.2083234499246174],
         [4.014320875711519e-09, 1.1863776808153181, -1.9098964895272064,
          1.5625509452172395, -0.03688246587887433, 0.013297678548300287], None, -0.583892),
        # joint 1 dips within its limit: a sliver 1e-5 rad wide
        (_DIP_D3, [-0.004753387985200159, -0.11432083549760862, 0.15512931133657287],
         [-1.0392258270440116, -0.7430414471819297, 0.13962643922249443,
          1.5222448376228028, -0.048894534735384715, 0.08056643383848888], None, -1.782262),
        # a contact next to the end of an arc, where the joints move 300 times as far as psi
        ({}, [0.0981686272042729, -0.041970199734264045, -0.1500180549514037],
         [-0.7805118544645988, 1.7300780681785777, -1.8978277398979215, -1.1320322436848618,
          -0.2061070369497703, -0.0034688512125114453],
         ([0.04228093087295383, -0.02593426802124407, -0.0024464850224880023],
          0.01294572550758518), -1.600988),
    ],
)  # fmt: skip
def test_level_two_over_the_base_dips_and_arc_ends(design, p, current, sphere, psi_oracle):
    """A second hostile check (2026-11-28): slivers where a joint dips within its limit with
    no sign change between samples (now a golden-section search for its least excess), and
    a contact next to an arc's end, where three rounds of narrowing psi left follow 3.5e-5
    rad past the nearest (now more rounds while neighbouring members lie over 1e-6 rad
    apart). The oracle: 40,001 azimuths 1e-8 rad apart about the check's member."""
    from handarm.scene import Scene, scene_free

    d = handarm.ArmDesign(**design)
    p, current = np.array(p), np.array(current)
    kw = {}
    if sphere is not None:
        kw = {"scene": Scene.empty().with_sphere(sphere[0], sphere[1], name="s"),
              "clearance": 0.001}  # fmt: skip
    r = ik.solve(d, p, [0, 0, math.copysign(1.0, p[2])], current=current, **kw)
    assert r.reached_dof == 2
    assert r.position_error == pytest.approx(abs(p[2]) - d.lengths[4:7].sum(), abs=1e-12)
    family = _above_family(d, p, psi=psi_oracle + np.linspace(-2e-4, 2e-4, 40001))
    if sphere is not None:
        family = family[scene_free(d, family, kw["scene"], 0.001)]
        assert scene_free(d, r.follow[None], kw["scene"], 0.001).all()
    assert len(family) and handarm.is_valid(d, r.follow)
    nearest = np.linalg.norm(family - current, axis=1).min()
    assert np.linalg.norm(r.follow - current) <= nearest + 2e-6


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.floats(-0.2, 0.2),
    st.floats(-0.2, 0.2),
)
def test_the_family_over_the_base_exists_on_its_reach_arcs(seed, x, y):
    """Dense sampling of the tip-plane azimuth: joints 1 and 2 reach joint 3 (|cos q2| <= 1)
    exactly on ``_reach_arcs``, for random designs."""
    from handarm.ik.degrade import _reach_arcs

    rng = np.random.default_rng(seed)
    d = handarm.ArmDesign(link_lengths=rng.uniform(0.02, 0.08, 7))
    a = d.lengths
    psi = np.linspace(-np.pi, np.pi, 20001)
    j3 = np.stack([x - a[3] * np.cos(psi), y - a[3] * np.sin(psi)], 1)
    c2 = ((j3**2).sum(1) - a[1] ** 2 - a[2] ** 2) / (2 * a[1] * a[2])
    exists = np.abs(c2) <= 1.0
    on = np.zeros_like(exists)
    for lo, hi in _reach_arcs(d, np.array([x, y, 0.3])):
        turn = np.remainder(psi - lo, 2 * np.pi)
        on |= turn <= hi - lo
    margin = np.abs(np.abs(c2) - 1.0) > 1e-9  # away from the arcs' ends (rounding)
    assert np.array_equal(exists[margin], on[margin])


@pytest.mark.parametrize(
    ("q0_deg", "step", "steps"),
    [
        ([10, 30, -40, 30, 20, 10], [0.0015, 0, 0.0015], 30),  # 2 DoF from the 6th step on
        pytest.param([20, 40, -30, 10, 40, 30], [0, 0, 0.002], 90, marks=pytest.mark.slow),
    ],
)
def test_outputs_move_continuously_out_of_reach(q0_deg, step, steps):
    """A handheld user follows the answer: 2-3 mm target steps, small joint steps."""
    d = handarm.ArmDesign()
    q0 = np.radians(q0_deg)
    p0, e0 = handarm.forward(d, q0)
    current, levels, jumps = q0, [], []
    for k in range(steps):
        r = ik.solve(d, p0 + np.asarray(step) * k, e0, current=current)
        assert r.follow is not None
        jumps.append(np.abs(r.follow - current).max())
        current = r.follow
        levels.append(r.reached_dof)
    assert levels[0] == 5 and levels[-1] == 2 and 4 in levels
    assert max(jumps) < math.radians(20)


def test_no_degrade_gives_an_empty_result():
    """An empty answer says it reached nothing (0), never 5: a loop testing for 5 must not
    take it for an exact one."""
    d = handarm.ArmDesign()
    r = ik.solve(d, [0.5, 0.0, 0.0], [1, 0, 0], degrade=False)
    assert r.count == 0 and r.reached_dof == 0
    out = r.to_dict()
    assert out["reached_dof"] == 0
    # no pose reached: the file says nothing about one (it said the target, errors 0)
    for key in ("position_error_m", "direction_error_deg", "achieved_position_m",
                "achieved_direction"):  # fmt: skip
        assert out[key] is None, key
    json.dumps(out, allow_nan=False)


def test_nearest_point_seeds_are_valid_and_nearest_first(monkeypatch):
    """The seed cloud holds configurations within the limits only (validity is tested on
    the few nearest a point): every polished configuration is valid, its distance is its
    tool point's, and the cloud's seeds are its nearest valid configurations, in order."""
    from handarm.ik import degrade

    d = handarm.ArmDesign()
    cloud_q, cloud_p = degrade._position_cloud(d)
    valid = handarm.is_valid(d, cloud_q)
    assert not valid.all()  # the cloud is not filtered up front
    np.testing.assert_allclose(cloud_p, handarm.forward(d, cloud_q)[0], atol=1e-15)
    rng = np.random.default_rng(3)
    for p in rng.uniform(-0.3, 0.3, (12, 3)):
        qs, errs, _ = degrade._polished(d, p, None)
        n_start = len(degrade._start_seeds(d, p, None))
        assert len(qs) == n_start + degrade._SEEDS
        ok = np.isfinite(errs)
        assert handarm.is_valid(d, qs[ok]).all()
        np.testing.assert_allclose(
            errs[ok], np.linalg.norm(handarm.forward(d, qs[ok])[0] - p, axis=1), atol=1e-12
        )
    # the validity the polish remembers of the cloud points it tested is is_valid's
    known = degrade._cloud_validity(d)
    tested = np.flatnonzero(known >= 0)
    assert len(tested) >= degrade._SEEDS
    np.testing.assert_array_equal(known[tested] == 1, valid[tested])
    # with no polish steps the cloud rows are the seeds themselves; among the points, some
    # where fewer than _SEEDS of the first NEAR_FIRST * _SEEDS nearest are valid (the seeds
    # then come from farther)
    monkeypatch.setattr(degrade, "_POLISH_STEPS", 0)
    first = degrade.NEAR_FIRST * degrade._SEEDS
    sparse = [
        p
        for p in cloud_p[~valid][:400]
        if valid[np.argsort(np.linalg.norm(cloud_p - p, axis=1))[:first]].sum() < degrade._SEEDS
    ]
    assert len(sparse) >= 4
    for p in [*rng.uniform(-0.3, 0.3, (12, 3)), *sparse[:4]]:
        qs, _, _ = degrade._polished(d, p, None)
        n_start = len(degrade._start_seeds(d, p, None))
        order = np.argsort(np.linalg.norm(cloud_p[valid] - p, axis=1), kind="stable")
        np.testing.assert_array_equal(qs[n_start:], cloud_q[valid][order[: degrade._SEEDS]])
