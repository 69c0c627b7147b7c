"""Issue 15: degradation levels keep what they say, match brute force, inputs are checked."""

import math

import numpy as np
import pytest
from tests.ik.conftest import valid_configurations

import handarm
from handarm import ik
from handarm.ik import exact


def angle(a, b):
    return 2 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def solvable(design, p, dirs):
    return ik.count_solutions(design, np.broadcast_to(p, dirs.shape).copy(), dirs) > 0


def check_pose(design, r, p):
    """The ranges reach the relaxed target, exactly at p, and are valid."""
    p2, e2 = handarm.forward(design, r.solutions)
    np.testing.assert_allclose(p2, np.broadcast_to(p, p2.shape), atol=1e-9)
    np.testing.assert_allclose(e2, np.broadcast_to(r.achieved_direction, e2.shape), atol=1e-9)
    assert handarm.is_valid(design, r.solutions).all()
    assert r.position_error == 0.0


def circle_oracle(design, p, e, step_deg):
    """Smallest angle to a solvable direction keeping e's yaw or its pitch, by a dense grid.

    Grid points closer than 1e-6 rad to straight up/down are left out: a vertical direction
    lets L take any azimuth, which keeps neither angle.
    """
    pitch, yaw = math.asin(e[2]), math.atan2(e[1], e[0])
    t = np.radians(np.arange(-180, 180, step_deg) + 0.37 * step_deg)
    t = t[np.abs(np.cos(t)) > 1e-6]
    along_pitch = np.stack([np.cos(t) * math.cos(yaw), np.cos(t) * math.sin(yaw), np.sin(t)], 1)
    c = math.cos(pitch)
    along_yaw = np.stack([c * np.cos(t), c * np.sin(t), np.full_like(t, math.sin(pitch))], 1)
    dirs = np.concatenate([along_pitch, along_yaw])
    ok = solvable(design, p, dirs)
    return float(angle(dirs[ok], e).min()) if ok.any() else math.inf


def kept(e, v):
    """Independent check of what v keeps of e: same vertical plane, or same elevation."""
    same_plane = abs(e[0] * v[1] - e[1] * v[0]) < 1e-8 and math.hypot(*v[:2]) > 1e-8
    return same_plane or abs(e[2] - v[2]) < 1e-8


def check_level4_beats_witness(design, p, e, witness):
    """Level 4, within 0.01 deg of a direction checked here to be solvable and to keep one
    of e's angles."""
    p, e, w = (np.asarray(v, float) for v in (p, e, witness))
    e, w = e / np.linalg.norm(e), w / np.linalg.norm(w)
    assert solvable(design, p, w[None])[0] and kept(e, w)
    r = ik.solve(design, p, e)
    assert r.reached_dof == 4
    check_pose(design, r, p)
    assert kept(e, r.achieved_direction)
    assert r.direction_error <= angle(w, e) + math.radians(0.01)


def turned(d, v, t):
    """Unit d turned by t rad about the axis across d and v."""
    axis = np.cross(d, v)
    axis /= np.linalg.norm(axis)
    return d * math.cos(t) + np.cross(axis, d) * math.sin(t)


def level4_targets(design, n, seed):
    rng = np.random.default_rng(seed)
    q = valid_configurations(design, rng, 8 * n)
    p = handarm.forward(design, q)[0]
    e = rng.normal(size=p.shape)
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    keep = np.flatnonzero(ik.count_solutions(design, p, e) == 0)[:n]
    return p[keep], e[keep]


def check_level4_against_oracle(design, P, E, step_deg):
    levels = []
    for p, e in zip(P, E, strict=True):
        r = ik.solve(design, p, e)
        levels.append(r.reached_dof)
        check_pose(design, r, p)
        oracle = circle_oracle(design, p, e, step_deg)
        if r.reached_dof == 4:
            assert kept(e, r.achieved_direction)
            assert r.direction_error <= oracle + math.radians(0.01)
        else:
            assert r.reached_dof == 3 and oracle == math.inf
    return levels


def test_level4_matches_dense_circle_oracle(paper):
    P, E = level4_targets(paper, 12, seed=5)
    levels = check_level4_against_oracle(paper, P, E, 0.05)
    assert 4 in levels


def test_level4_finds_a_solvable_arc_narrower_than_its_grid(paper):
    """An independent oracle (36,000 points a circle, bisected) found a solvable arc of
    0.018 degrees on e's yaw circle, q1 at its limit and the wrist nearly straight, 1.28
    degrees nearer e than where the 0.25-degree grid first hit: the search finds it."""
    p = np.array([-0.13100154051036725, -0.12868135370526781, -0.0511380120870101])
    e = np.array([0.6010262080978026, -0.5024431695403899, 0.6215451379922329])
    w = np.array([-0.2926436244812119, -0.7266645377949275, 0.6215451379922329])
    assert solvable(paper, p, w[None])[0] and kept(e, w)
    # the arc is narrower than the grid: 0.25 and 0.5 degrees either side are not solvable
    pitch, yaw = math.asin(w[2]), math.atan2(w[1], w[0])
    t = yaw + np.radians([-0.5, -0.25, 0.25, 0.5])
    c = math.cos(pitch)
    around = np.stack([c * np.cos(t), c * np.sin(t), np.full_like(t, w[2])], 1)
    assert not solvable(paper, p, around).any()
    r = ik.solve(paper, p, e)
    assert r.reached_dof == 4
    check_pose(paper, r, p)
    assert kept(e, r.achieved_direction)
    assert r.direction_error <= angle(w, e) + math.radians(0.01)


#: (p, e, a solvable direction keeping e's pitch) near the reach sphere, the arm nearly
#: stretched, from a second oracle check (2026-11-27, seed 11): the solvable directions form
#: a cap of a few tenths of a degree that e's yaw circle crosses within the grid's first
#: step. The first came back as level 3 (0.087 degrees), the second as level 4 on the pitch
#: circle 0.016 degrees worse.
LEVEL4_SMALL_CAPS = [
    (
        [0.04127951996961739, -0.2971445846377679, 0.0006467478227108409],
        [0.13534544266489287, -0.9907721022299195, 0.00722859548945272],
        [0.13698227796729656, -0.9905471230235038, 0.00722859548945272],
    ),
    (
        [0.20646180703071765, 0.21764782500388458, -0.00012598394238309005],
        [0.686419450761801, 0.7271047507203492, -0.012125143123546126],
        [0.6877874669887463, 0.7258108439238407, -0.012125143123546126],
    ),
]


@pytest.mark.parametrize(("p", "e", "witness"), LEVEL4_SMALL_CAPS)
def test_level4_finds_an_arc_in_a_small_cap_near_the_reach(paper, p, e, witness):
    """Directions of valid configurations that reach p, projected onto the circles, find
    the arc (its witness checked solvable here, count_solutions)."""
    check_level4_beats_witness(paper, p, e, witness)


#: (design, p, e, a solvable direction keeping e's yaw or pitch) from a hostile check of a
#: level 4 that skipped the seeds' projections deeper than 1 % of the arm's length inside
#: the reach (2026-11-29): on random designs the circles' grid alone answered 0.78 and 0.67
#: rad off where these directions were 1e-5 and 3e-3 rad off, on the paper's arm 0.039 deg
#: where 0.0053 deg was solvable (joints at their limits bound the workspace there). The
#: projections are needed deep inside too.
LEVEL4_DEEP_PROJECTIONS = [
    (
        dict(
            link_lengths=(
                0.06853847342275407,
                0.053580368871344694,
                0.07835556246498597,
                0.06995986625773223,
                0.05634251487789983,
                0.03370966651784447,
                0.07012555950361023,
            ),
            joint_limits=(
                (-0.8721670543484626, 2.6919478124858243),
                (-2.2691024175511374, 1.1785045050386862),
                (-2.1368874310258463, 2.885853070361178),
                (-1.800574514045717, 1.1810049689357862),
                (-1.5728671201709183, 0.8031003348174304),
                (-2.6930796085354536, 1.882907294379584),
            ),
            collision_model="paper",
        ),
        [-0.0204251632488548, -0.04725093336904764, 0.04556015186661799],
        [-0.8060638895705504, 0.2032760673355525, -0.5558235748679496],
        [-0.8060615391204384, 0.20328538750191238, -0.5558235748679496],
    ),
    (
        dict(
            link_lengths=(
                0.05972528364192789,
                0.04409539020226512,
                0.06406148317279271,
                0.03698739233182066,
                0.07033820066767078,
                0.020329017797736274,
                0.0573759382659763,
            ),
            joint_limits=(
                (-1.8549879634068305, 1.1932506999733794),
                (-1.5865686185595307, 1.0340313142297333),
                (-2.844882082368311, 0.8383694713229681),
                (-2.189196279635466, 1.9794471340338287),
                (-2.2365957095062465, 2.294665516538878),
                (-2.2320685902963264, 2.2954683892789234),
            ),
            collision_model="printed",
        ),
        [-0.16162482607311793, 0.10229942761176285, -0.08114474126462606],
        [-0.7675401062229804, 0.06156370482632087, -0.6380376913531628],
        [-0.7677840743224025, 0.05844244715630783, -0.6380376913531627],
    ),
    (
        # the paper's arm: joints 2, 3 and 5 at their limits; 0.039 deg without projections
        {},
        [0.08624447646894742, -0.04631421857838717, 0.052849843083555684],
        [0.12908609571471819, -0.0344927302056509, 0.9910333150081742],
        [0.12906218043234163, -0.03458210702023192, 0.9910333150081742],
    ),
]


@pytest.mark.parametrize(("kwargs", "p", "e", "witness"), LEVEL4_DEEP_PROJECTIONS)
def test_level4_deep_inside_still_finds_what_only_the_projections_find(kwargs, p, e, witness):
    check_level4_beats_witness(handarm.ArmDesign(**kwargs), p, e, witness)


def test_level4_near_the_stretched_arm_matches_a_fine_circle_oracle(paper):
    """Targets by a nearly stretched arm (every joint within 3 degrees of 0), e turned off its
    direction by 0.05-0.6 degrees: the solvable directions form small caps. Level 4 is within
    0.01 degrees of the best of 2 x 1,201 directions 0.001 degrees apart on e's two circles,
    and is level 3 only where none of them is solvable."""
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, (400, 6)) * math.radians(3.0)
    q = q[handarm.is_valid(paper, q)]
    P, D = handarm.forward(paper, q)
    t = np.radians(np.linspace(-0.6, 0.6, 1201))
    checked = found = 0
    for p, d in zip(P, D, strict=True):
        if checked == 12:
            break
        e = turned(d, rng.normal(size=3), math.radians(rng.uniform(0.05, 0.6)))
        if solvable(paper, p, e[None])[0]:
            continue
        checked += 1
        pitch, yaw = math.asin(e[2]), math.atan2(e[1], e[0])
        c = math.cos(pitch)
        along_pitch = np.stack(
            [
                np.cos(pitch + t) * math.cos(yaw),
                np.cos(pitch + t) * math.sin(yaw),
                np.sin(pitch + t),
            ],
            1,
        )
        along_yaw = np.stack([c * np.cos(yaw + t), c * np.sin(yaw + t), np.full_like(t, e[2])], 1)
        dirs = np.concatenate([along_pitch, along_yaw])
        ok = solvable(paper, p, dirs)
        oracle = float(angle(dirs[ok], e).min()) if ok.any() else math.inf
        r = ik.solve(paper, p, e)
        check_pose(paper, r, p)
        if r.reached_dof == 4:
            found += 1
            assert kept(e, r.achieved_direction)
            assert r.direction_error <= oracle + math.radians(0.01)
        else:
            assert r.reached_dof == 3 and oracle == math.inf
    assert checked == 12 and found >= 4, (checked, found)


def targets_next_to_limits(design, n, seed):
    """Targets without an exact solution by configurations with one to three joints within
    0.0001-3 degrees of a limit (where solvable directions narrow), e turned 0.01-10 degrees
    off their direction or random."""
    rng = np.random.default_rng(seed)
    lo, hi = design.lower, design.upper
    P, E = [], []
    while len(P) < n:
        q = rng.uniform(lo, hi)
        for j in rng.choice(6, size=rng.integers(1, 4), replace=False):
            off = math.radians(10 ** rng.uniform(-4, 0.5))
            q[j] = hi[j] - off if rng.random() < 0.5 else lo[j] + off
        if not handarm.is_valid(design, q):
            continue
        p, d = handarm.forward(design, q)
        if rng.random() < 0.6:
            e = turned(d, rng.normal(size=3), math.radians(10 ** rng.uniform(-2, 1)))
        else:
            e = rng.normal(size=3)
            e /= np.linalg.norm(e)
        if not solvable(design, p, e[None])[0]:
            P.append(p)
            E.append(e)
    return np.array(P), np.array(E)


def test_level4_next_to_joint_limits_matches_dense_circle_oracle(paper):
    """Next to joint limits, where the solvable directions narrow, level 4 matches the
    dense oracle."""
    P, E = targets_next_to_limits(paper, 10, seed=21)
    levels = check_level4_against_oracle(paper, P, E, 0.05)
    assert levels.count(4) >= 6, levels


@pytest.mark.slow
def test_level4_matches_dense_circle_oracle_many(paper):
    # about 3 s a target (an 18,000-direction oracle and a degraded solve): CI's hour budget
    P, E = level4_targets(paper, 60, seed=6)
    check_level4_against_oracle(paper, P, E, 0.02)


def test_issue_repro_pole_is_not_level4(paper):
    """Straight down with L off e's yaw kept neither angle; 19.4 deg is reachable."""
    p = np.array([-0.01825, -0.12479, 0.0657])
    e = np.array([-0.54348, -0.07102, -0.83641])
    e /= np.linalg.norm(e)
    r = ik.solve(paper, p, e)
    check_pose(paper, r, p)
    assert r.reached_dof in (3, 4)
    if r.reached_dof == 4:
        assert kept(e, r.achieved_direction)
    other = np.array([-0.63401, -0.35761, -0.68568])
    other /= np.linalg.norm(other)
    assert solvable(paper, p, other[None])[0]
    assert r.direction_error <= angle(other, e) + math.radians(0.01)


def test_issue_repro_small_cap_near_reach_sphere(paper):
    q = np.radians([30, 1, 0, 0, 1, 0])
    p = handarm.forward(paper, q)[0]
    r = ik.solve(paper, p, [0, 0, -1])
    check_pose(paper, r, p)
    assert r.reached_dof >= 3
    assert math.degrees(r.direction_error) <= 89.67 + 0.01


def test_smallest_angle_first_order(paper):
    P, E = level4_targets(paper, 4, seed=7)
    for p, e in zip(P, E, strict=True):
        a = ik.solve(paper, p, e, order="angle")
        b = ik.solve(paper, p, e, order="paper")
        check_pose(paper, a, p)
        assert a.direction_error <= b.direction_error + 1e-9
        assert (a.reached_dof == 4) == kept(e, a.achieved_direction)


def test_degraded_result_exposes_its_relaxed_target(paper):
    p = np.array([-0.01825, -0.12479, 0.0657])
    e = np.array([-0.54348, -0.07102, -0.83641])
    r = ik.solve(paper, p, e)
    tp, te = r.target
    for br, (lo, hi) in zip(r.branches, r.intervals, strict=True):
        q = ik.configuration_at(paper, tp, te, br, 0.5 * (lo + hi), result=r)
        assert handarm.is_valid(paper, q)
        p2, e2 = handarm.forward(paper, q)
        np.testing.assert_allclose(p2, tp, atol=1e-9)
        np.testing.assert_allclose(e2, te, atol=1e-9)
    with pytest.raises(ValueError, match="degraded"):
        ik.configuration_at(paper, p, e, r.branches[0], r.intervals[0].mean(), result=r)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"p": [1e300, 0, 0]}, "^p: "),
        ({"p": [1e308, -1e308, 1e308]}, "^p: inf x the arm's reach"),
        ({"p": [40.0, 0, 0]}, "^p: .*metres"),
        ({"current": np.radians([30, 0, 0, 0, 0, 0]) * 60}, "^current: .*radians"),
        ({"e": [0, 0, 0]}, "^e: "),
        ({"order": "fast"}, "^order: "),
        ({"degrade": "yes"}, "^degrade: "),
    ],
)
@pytest.mark.filterwarnings("error")  # refused cleanly: no overflow warning on the way
def test_bad_inputs_name_the_argument(paper, kwargs, match):
    args = {"p": [0.2, 0.05, 0.05], "e": [1, 0, 0.3]} | kwargs
    with pytest.raises(ValueError, match=match):
        ik.solve(paper, **args)


def test_degrade_takes_numpy_booleans(paper):
    """degrade=np.True_ was refused while chunk took np.int64 (a hostile check)."""
    p, e = [0.2, 0.05, 0.05], [1, 0, 0.3]
    a, b = ik.solve(paper, p, e, degrade=np.True_), ik.solve(paper, p, e, degrade=True)
    np.testing.assert_array_equal(a.intervals, b.intervals)
    with pytest.raises(ValueError, match="^degrade: "):
        ik.solve(paper, p, e, degrade=np.int64(1))


def test_extreme_but_legal_directions(paper):
    p = handarm.forward(paper, np.radians([10, 30, -40, 30, 20, 10]))[0]
    for e in ([1.5e154, 0, 0], [1e-13, 0, 3e-14], [1e-300, 1e-300, 0]):
        r = ik.solve(paper, p, e)
        assert r.count > 0
        assert np.all(np.isfinite(r.solutions)) and np.all(np.isfinite(r.achieved_direction))
        np.testing.assert_allclose(np.linalg.norm(r.target[1]), 1.0)


@pytest.mark.parametrize("chunk", [-1, 0, 2.5, True])
def test_chunk_is_validated_everywhere(paper, chunk):
    P = np.array([[0.2, 0.05, 0.05]])
    E = np.array([[1.0, 0, 0.3]])
    with pytest.raises(ValueError, match="^chunk: "):
        ik.solve_batch(paper, P, E, chunk=chunk)
    with pytest.raises(ValueError, match="^chunk: "):
        ik.count_solutions(paper, P, E, chunk=chunk)
    with pytest.raises(ValueError, match="^chunk: "):
        list(ik.solve_batch_iter(paper, P, E, chunk=chunk))


@pytest.mark.parametrize("bad", ["0.001", None, True, np.array([0.0, 1e-3]), np.nan, -1e-6])
def test_min_width_is_a_number_or_a_named_error(paper, bad):
    P = np.array([[0.2, 0.05, 0.05]])
    E = np.array([[1.0, 0, 0.3]])
    with pytest.raises(ValueError, match="^min_width: expected a finite number >= 0"):
        ik.count_solutions(paper, P, E, min_width=bad)


@pytest.mark.parametrize("bad", [-3, 5.0, np.nan, "0.001", True, 1e-3])
def test_clearance_is_checked_with_or_without_a_scene(paper, bad, tmp_path):
    """Without a scene there is nothing to keep a clearance from: any value but 0 is refused
    (it was ignored, NaN included), as the CLI refuses --clearance without --scene; a build
    or a map refuses it before any work."""
    from handarm.pipeline import map_workspace

    p, e = np.array([0.2, 0.05, 0.05]), np.array([1.0, 0, 0.3])
    P, E = p[None], e[None]
    for call in (
        lambda: ik.solve(paper, p, e, clearance=bad),
        lambda: ik.solve_batch(paper, P, E, clearance=bad),
        lambda: ik.count_solutions(paper, P, E, clearance=bad),
        lambda: ik.warm_up(paper, clearance=bad),
        lambda: handarm.build(paper, tmp_path / "b", clearance=bad),
        lambda: map_workspace(paper, tmp_path / "w", clearance=bad),
    ):
        with pytest.raises(ValueError, match="^clearance: "):
            call()
    assert list(tmp_path.iterdir()) == []
    assert ik.count_solutions(paper, P, E, clearance=0.0).shape == (1,)


def test_solve_batch_iter_checks_every_row_first_and_names_it_as_the_batch_does(paper):
    """A bad row is named by its row in P and E, not in its chunk, before anything is
    yielded; shapes are compared before any chunk."""
    q = valid_configurations(paper, np.random.default_rng(8), 12)
    P, E = handarm.forward(paper, q)
    zero, far = E.copy(), P.copy()
    zero[9] = 0.0
    far[6] = [200.0, 50.0, 50.0]  # millimetres
    yielded = []
    with pytest.raises(ValueError, match=r"^E\[9\]: direction has zero length"):
        for start, _ in ik.solve_batch_iter(paper, P, zero, chunk=4):
            yielded.append(start)
    with pytest.raises(ValueError, match=r"^P\[6\]: .*metres"):
        for start, _ in ik.solve_batch_iter(paper, far, E, chunk=4):
            yielded.append(start)
    assert yielded == []
    with pytest.raises(ValueError, match=r"^P, E: .*\(12, 3\) and \(24, 3\)"):
        ik.solve_batch_iter(paper, P, np.vstack([E, E]), chunk=5)
    with pytest.raises(ValueError, match=r"^P, E: .*\(3,\) and \(3,\)"):
        ik.solve_batch_iter(paper, P[0], E[0])
    starts = [s for s, b in ik.solve_batch_iter(paper, P, E, chunk=5)]
    assert starts == [0, 5, 10]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"u": "0.1"}, "^u: expected a finite number"),
        ({"u": None}, "^u: expected a finite number"),
        ({"u": np.array([0.0, 0.1])}, "^u: expected a finite number"),
        ({"u": np.inf}, "^u: expected a finite number"),
        ({"result": "r"}, "^result: expected the IKResult"),
        ({"p": [200.0, 50.0, 50.0]}, "^p: .*metres"),
        ({"azimuth": "north"}, "^azimuth: expected a finite number"),
    ],
)
def test_configuration_at_names_a_bad_argument(paper, kwargs, match):
    p, e = np.array([0.2, 0.05, 0.02]), np.array([1.0, 0.2, -0.3])
    r = ik.solve(paper, p, e)
    args = {"p": r.target[0], "e": r.target[1], "branch": r.branches[0],
            "u": float(r.intervals[0].mean())} | kwargs  # fmt: skip
    with pytest.raises(ValueError, match=match):
        ik.configuration_at(paper, **args)


def test_configuration_at_refuses_a_batch_result(paper):
    P, E = np.array([[0.2, 0.05, 0.02]]), np.array([[1.0, 0.2, -0.3]])
    b = ik.solve_batch(paper, P, E)
    with pytest.raises(ValueError, match="^result: .*got BatchResult"):
        ik.configuration_at(paper, P[0], E[0], b.branches[0, 0], 0.0, result=b)


@pytest.mark.parametrize(
    ("configurations", "match"),
    [(np.zeros(5), "^configurations: expected shape"),
     (np.full((1, 6), 90.0), "^configurations: .*radians"),
     (np.zeros((2, 2, 6)), "^configurations: expected shape")],
)  # fmt: skip
def test_warm_up_names_bad_configurations(paper, configurations, match):
    with pytest.raises(ValueError, match=match):
        ik.warm_up(paper, configurations=configurations)


def test_batch_widens_instead_of_truncating(paper, monkeypatch):
    """With a row width smaller than some targets need, batch still keeps every range."""
    rng = np.random.default_rng(3)
    q = valid_configurations(paper, rng, 40)
    P, E = handarm.forward(paper, q)
    counts = ik.count_solutions(paper, P, E)
    monkeypatch.setattr(exact, "MAX_SOLUTIONS", 2)
    b = ik.solve_batch(paper, P, E)
    np.testing.assert_array_equal(b.counts, counts)
    assert b.solutions.shape[1] == counts.max() > 2
    assert not b.truncated.any()
    for i in range(len(P)):
        r = ik.solve(paper, P[i], E[i])
        np.testing.assert_allclose(b.intervals[i, : b.counts[i]], r.intervals, atol=1e-12)


def test_follow_is_nearest_in_range_configuration(paper):
    """follow against dense sampling of every range (Euclidean joint distance)."""
    rng = np.random.default_rng(21)
    q = valid_configurations(paper, rng, 12)
    for k in range(len(q)):
        p, e = handarm.forward(paper, q[k])
        current = np.clip(q[k] + rng.normal(scale=0.4, size=6), paper.lower, paper.upper)
        r = ik.solve(paper, p, e, current=current)
        best = math.inf
        for br, (lo, hi) in zip(r.branches, r.intervals, strict=True):
            u = np.linspace(lo, hi, 2001)  # the exact ends included
            qs, ok = ik.configurations_along(paper, p, e, br, u, azimuth=r.azimuth)
            qs = qs[ok & handarm.is_valid(paper, qs)]
            if len(qs):
                best = min(best, float(np.linalg.norm(qs - current, axis=1).min()))
        got = float(np.linalg.norm(r.follow - current))
        assert handarm.is_valid(paper, r.follow)
        assert got <= best + 1e-6


def test_near_vertical_noise_does_not_swing_the_tip_plane(paper):
    """Tilting a vertical e by 1e-6 rad in any azimuth moves follow by a tiny amount."""
    q = np.radians([20, 30, -30, 60, 40, -10])
    p = handarm.forward(paper, q)[0]
    r0 = ik.solve(paper, p, [0, 0, 1], current=q)
    assert r0.count > 0
    current = r0.follow
    rng = np.random.default_rng(2)
    for az in rng.uniform(-math.pi, math.pi, 40):
        tilt = 1e-6
        e = np.array([math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az), math.cos(tilt)])
        r = ik.solve(paper, p, e, current=current)
        assert r.reached_dof == 5
        assert r.direction_error <= 2 * tilt + 1e-12
        assert abs(r.achieved_direction[2] - e[2]) < 1e-12  # elevation kept exactly
        assert np.abs(r.follow - current).max() < 1e-4
        current = r.follow


def test_near_vertical_noise_on_a_degraded_target_keeps_the_tip_plane():
    """As above on a target that degrades (level 4, a random design of a hostile check):
    the degraded levels aim at the cone's direction in current's tip plane, so noise no
    longer swings follow (by up to 4.7 rad before) and the direction error is e's."""
    design = handarm.ArmDesign(
        link_lengths=(0.07365248524811453, 0.06608219796456924, 0.06532438022501741,
                      0.04642981992656452, 0.060549876465802066, 0.0650725182378348,
                      0.07181773254537713)
    )  # fmt: skip
    p = np.array([-0.09224018159048517, 0.00676834324429844, -0.07449828753304183])
    q = np.array([0.5802888098354599, 0.7270890536230703, -1.1870207264319512,
                  -0.8430486497634146, -0.3118526698775357, 1.599163281310386])  # fmt: skip
    r = ik.solve(design, p, [0.0, 0.0, 1.0], current=q)
    assert r.reached_dof == 4
    current = r.follow
    rng = np.random.default_rng(3)
    for az in rng.uniform(-math.pi, math.pi, 20):
        tilt = 1e-6
        e = np.array([math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az), math.cos(tilt)])
        r = ik.solve(design, p + 1e-6 * rng.normal(size=3) / math.sqrt(3), e, current=current)
        assert r.reached_dof == 4
        # the kinematics near level 4's fold may move it by ~1e-3 rad (see the IK guide)
        assert np.abs(r.follow - current).max() < 1e-2
        assert r.direction_error == pytest.approx(float(angle(r.achieved_direction, e)), abs=1e-12)
        current = r.follow


def test_least_joint_motion_is_pinv_of_the_pose_jacobian(paper):
    """Against pinv of a central-difference Jacobian of ``forward`` (independent of the kernel)."""
    from handarm.ik.api import least_joint_motion

    rng = np.random.default_rng(5)
    for q in rng.uniform(paper.lower, paper.upper, (20, 6)):
        h = 1e-7
        cols = []
        for k in range(6):
            dq = np.zeros(6)
            dq[k] = h
            (pa, ea), (pb, eb) = handarm.forward(paper, q + dq), handarm.forward(paper, q - dq)
            cols.append(np.r_[pa - pb, ea - eb] / (2 * h))
        p, e = handarm.forward(paper, q + rng.normal(scale=1e-4, size=6))
        p0, e0 = handarm.forward(paper, q)
        want = np.linalg.norm(np.linalg.pinv(np.array(cols).T, rcond=1e-6) @ np.r_[p - p0, e - e0])
        assert least_joint_motion(paper, q, p, e) == pytest.approx(want, rel=1e-5)


def test_noise_never_ends_the_family(paper):
    """1e-6 rad / 1e-6 m of noise on a pose the arm holds: follow stays on its range."""
    rng = np.random.default_rng(8)
    for q in valid_configurations(paper, rng, 40):
        p, e = handarm.forward(paper, q)
        axis = np.cross(e, rng.normal(size=3))
        axis /= np.linalg.norm(axis)
        e2 = e * math.cos(1e-6) + np.cross(axis, e) * math.sin(1e-6)
        p2 = p + 1e-6 * rng.normal(size=3) / math.sqrt(3)
        r = ik.solve(paper, p2, e2, current=q)
        assert r.reached_dof == 5 and not r.family_ended
        assert r.follow_distance == pytest.approx(float(np.linalg.norm(r.follow - q)))
        assert r.to_dict()["family_ended"] is False


#: Degraded targets after 1e-6 rad / 1e-6 m of noise, with the previous answer's follow as
#: current (from leaving paths of benchmarks/bench_tracking.py's kind, paper's arm).
_DEGRADED_NOISE = [
    # level 2: follow moved 3.2 rad before holding ties and the pointing pose
    ([0.03118129827497272, 0.06575015043294388, 0.25675108762895965],
     [0.16831721241979417, -0.518410739940099, 0.8384030180754294],
     [-0.6188143935004194, 1.9800245643300594, 0.6200112631965818, 1.5707963318866014,
      2.405292742751532e-10, 4.801295416026706e-09]),
    # level 2: 0.81 rad
    ([0.03819225086160652, 0.0805317109302323, 0.31447683755051553],
     [0.16831790406696426, -0.5184090851716272, 0.8384039024134016],
     [-0.34653146320856876, 1.8030867003615556, 0.4092155350270278, 1.5707963169083479,
      1.2735726740037534e-09, 1.0712362252304467e-09]),
    # level 2: 0.13 rad
    ([0.04239848341635803, 0.08940228104899076, 0.34911335708752966],
     [0.1683184804230264, -0.5184094989624319, 0.8384035308451435],
     [-0.10035955228168345, 2.075960419345115, -0.6542135093068352, 1.5707963096482562,
      7.096035776790558e-09, 3.8087804632476655e-09]),
    # level 3: 3.2e-3 rad
    ([0.06896234078151794, 0.13396294825980387, -0.10145553580376473],
     [-0.07381214859851695, 0.1803667200205688, 0.9808259850902666],
     [0.37753935226280294, -0.003261786885088959, 1.4389970845650495, -1.568701430323449,
      -0.00012748806968765607, 1.5397215109194509]),
]  # fmt: skip


@pytest.mark.parametrize("case", range(len(_DEGRADED_NOISE)))
def test_noise_on_a_degraded_target_keeps_follow(paper, case):
    """Noise moves a degraded answer's follow by microradians, and costs no accuracy.

    The answer with current may differ from the one without it only by a tie
    (``HOLD_DISTANCE`` in position, ``HOLD_ANGLE`` in direction).
    """
    from handarm.ik.degrade import HOLD_ANGLE, HOLD_DISTANCE

    p, e, current = (np.array(x) for x in _DEGRADED_NOISE[case])
    r = ik.solve(paper, p, e, current=current)
    alone = ik.solve(paper, p, e)
    assert r.reached_dof == alone.reached_dof < 5
    assert np.abs(r.follow - current).max() < 1e-4
    assert not r.family_ended
    assert handarm.is_valid(paper, r.follow)
    p_f, e_f = handarm.forward(paper, r.follow)
    np.testing.assert_allclose(p_f, r.achieved_position, atol=1e-9)
    np.testing.assert_allclose(e_f, r.achieved_direction, atol=1e-9)
    assert r.position_error <= alone.position_error + HOLD_DISTANCE
    assert r.position_error == pytest.approx(float(np.linalg.norm(p_f - p)), abs=1e-12)
    if r.reached_dof >= 3:
        assert r.direction_error <= alone.direction_error + HOLD_ANGLE


def test_a_held_level2_target_does_not_creep(paper):
    """The same unreachable target solved again and again from its own follow (a loop
    holding still): follow stays put. Each polish from current used to gain 2e-9 m and move
    follow 0.9, 0.5, 0.3 ... degrees, flagged family_ended from the second call on (a hostile
    check's case)."""
    from handarm.ik.degrade import HOLD_DISTANCE

    p = np.array([0.016975288421196708, 0.14911256188678465, 0.16370428725149527])
    e = np.array([0.989108783660329, 0.044118185510304025, -0.14041865899253894])
    current = np.array([1.435733428331349, 0.03912673329196742, -0.013136059069413009,
                        1.5702157663246252, -0.0, -7.651046855887236e-06])  # fmt: skip
    alone = ik.solve(paper, p, e)
    start = current
    for _ in range(8):
        r = ik.solve(paper, p, e, current=current)
        assert r.reached_dof == 2 and not r.family_ended
        assert r.position_error <= alone.position_error + HOLD_DISTANCE
        current = r.follow
    assert np.abs(current - start).max() < 1e-6


def nearest_in_ranges(design, r, p, e, q, samples: int) -> float:
    """Joint-space distance from q to the nearest valid configuration of r's ranges,
    sampled at ``samples`` points of each (independent of ``follow``)."""
    nearest = math.inf
    for br, (lo, hi) in zip(r.branches, r.intervals, strict=True):
        qs, ok = ik.configurations_along(
            design, p, e, br, np.linspace(lo, hi, samples), azimuth=r.azimuth
        )
        qs = qs[ok & handarm.is_valid(design, qs)]
        nearest = min(nearest, float(np.linalg.norm(qs - q, axis=1).min(initial=math.inf)))
    return nearest


def test_a_range_ending_at_a_joint_limit_is_reported(paper):
    """Joint 2 at its limit, the target pushed past it: follow must jump, and says so."""
    from handarm.ik.api import FAMILY_END_RATIO, least_joint_motion

    q = np.radians([10.0, 0.0, 0.0, 15.0, 30.0, -20.0])
    q[1] = paper.upper[1]
    pushed = q.copy()
    pushed[1] += 1e-3
    p, e = handarm.forward(paper, pushed)
    r = ik.solve(paper, p, e, current=q)
    assert r.reached_dof == 5 and r.family_ended
    least = least_joint_motion(paper, q, p, e)
    assert r.follow_distance > FAMILY_END_RATIO * least
    # independently: no configuration of any range lies within that distance of q
    nearest = nearest_in_ranges(paper, r, p, e, q, 2001)
    assert nearest > FAMILY_END_RATIO * least
    assert r.follow_distance <= nearest + 1e-6


#: Leaving paths (benchmarks/bench_tracking.py's kind, paper's arm, 2 mm steps, e held)
#: where the best relaxed pose jumps: (p, e, current = the previous answer's follow, the
#: previous target). Before ANSWER_JUMP none of these was flagged.
_ANSWER_JUMPS = [
    # level 4: follow moved 222 degrees, the tool direction 164 degrees
    ([-0.17596930874979871, 0.13299366385965067, -0.0627276099018315],
     [0.6298911298131539, -0.4011464433514363, 0.6650704440652896],
     [2.3561922251510725, 0.0845625690653186, 0.13376222839767832, -0.21129156762694654,
      0.0015050570429689786, -1.9604764763332287],
     [-0.174434597663495, 0.1318337635805414, -0.06218053291995534]),
    # level 3: 85 degrees, the direction 50 degrees
    ([0.055946124187437676, -0.20123048117449135, 0.03749168086234094],
     [0.0279906277325499, 0.11941116633745721, -0.992450249691674],
     [-0.33535153153693364, -2.580956827951785e-08, -1.4656932174046897,
      0.6757962880822436, 0.002683993189243084, -1.2140871017038453],
     [0.05541883071435014, -0.19933387938391728, 0.03713832093078321]),
    # level 3: 24 degrees, the direction 10 degrees
    ([0.12112711629230336, 0.13723875935178584, -0.1290020273386781],
     [0.1614318738774498, 0.9258690131404016, -0.3416230680191753],
     [0.14816412909867593, 0.0, 1.2500103559200102, -1.1849117560486908,
      -0.002325010695126432, 0.40735735464657086],
     [0.12004531991069296, 0.1360130685417678, -0.12784989946948475]),
]  # fmt: skip


@pytest.mark.parametrize("case", range(len(_ANSWER_JUMPS)))
def test_a_degraded_answer_that_jumps_is_reported(paper, case):
    """A 2 mm step moves the best relaxed pose far: follow must jump, and says so.

    Independently of the flag: current is the previous target's answer (solving that
    target from it keeps it), and the new answer's tool direction, from forward kinematics
    of follow, lies over 5 degrees from current's.
    """
    p, e, current, before = (np.array(x) for x in _ANSWER_JUMPS[case])
    assert np.linalg.norm(p - before) == pytest.approx(2e-3)
    held = ik.solve(paper, before, e, current=current)
    assert held.reached_dof < 5 and np.abs(held.follow - current).max() < 1e-6
    r = ik.solve(paper, p, e, current=current)
    assert r.reached_dof < 5 and r.family_ended
    assert np.abs(r.follow - current).max() > math.radians(20.0)
    _, e_now = handarm.forward(paper, r.follow)
    _, e_was = handarm.forward(paper, current)
    assert math.degrees(math.acos(min(1.0, float(e_now @ e_was)))) > 5.0


#: Exact targets next to a singular pose (a hostile check's, paper's arm): the tool
#: direction tilted by 0.23 and 0.5 degrees from current's pose, p kept; follow must jump
#: 67 and 153 degrees, and the first-order least motion (1,219 rad on the first) hid it.
_EXACT_JUMPS = [
    ([-0.031000809859168088, -0.13926902026999216, -0.02304996807717935],
     [-0.006750832975442037, -0.008553858872106971, -0.999940627113697],
     [-0.9962002031793775, -0.0008351705453352905, -1.5694174854506775, 1.4373915771528218,
      -1.9065662656934603, -1.0931160104898763]),
    ([-0.031000809859168088, -0.13926902026999216, -0.02304996807717935],
     [-0.004995628421605196, -0.017101563727098677, -0.9998412775109664],
     [-1.9857149598897186, 1.1649969144136034, -1.418208265692527, 2.102235278032113,
      -2.4312782320557393, -1.230856265463778]),
]  # fmt: skip


@pytest.mark.parametrize("case", range(len(_EXACT_JUMPS)))
def test_an_exact_jump_next_to_a_singular_pose_is_reported(paper, case):
    """A small tilt near a singular pose: no configuration of any range lies near current
    (dense sampling), so follow jumps, and says so."""
    from handarm.ik.api import ANSWER_JUMP

    p, e, current = (np.array(x) for x in _EXACT_JUMPS[case])
    p_c, e_c = handarm.forward(paper, current)
    assert np.linalg.norm(p_c - p) < 1e-12 and math.degrees(math.acos(e_c @ e)) < 0.51
    r = ik.solve(paper, p, e, current=current)
    assert r.reached_dof == 5 and r.family_ended
    nearest = nearest_in_ranges(paper, r, p, e, current, 4001)
    assert nearest > ANSWER_JUMP
    assert r.follow_distance <= nearest + 1e-6


def test_straight_arm_is_an_exact_single_point(paper):
    """The straight arm's pose has one configuration: a zero-length range at level 5."""
    p, e = handarm.forward(paper, np.zeros(6))
    r = ik.solve(paper, p, e)
    assert r.reached_dof == 5
    assert r.position_error == 0.0 and r.direction_error == 0.0
    assert r.count >= 1
    np.testing.assert_allclose(r.intervals[:, 0], r.intervals[:, 1])
    p2, e2 = handarm.forward(paper, r.solutions)
    np.testing.assert_allclose(p2, np.broadcast_to(p, p2.shape), atol=1e-9)
    np.testing.assert_allclose(e2, np.broadcast_to(e, e2.shape), atol=1e-9)
    assert handarm.is_valid(paper, r.solutions).all()


@pytest.mark.parametrize(
    ("p", "e"),
    [
        # an independent oracle's cases (2026-11-27): level 2 with a 1e-17 m position error
        ([0.25479176771485074, -0.15837031004813226, 0.0], [0.8507103, -0.525606, -0.005496]),
        ([0.3 * math.cos(0.4), 0.3 * math.sin(0.4), 0.0], [0.0, 0.0, -1.0]),
        ([0.3 * math.cos(-1.2), 0.3 * math.sin(-1.2), 0.0], [0.3, -0.2, 0.9]),
    ],
)
def test_a_point_only_the_stretched_arm_reaches_keeps_its_position(paper, p, e):
    """On the reach sphere in the base plane only the stretched arm reaches p, pointing
    radially: a single direction, which level 3's search of the sphere cannot see. The
    answer is level 3 at p with that direction, not level 2 at a rounding's distance."""
    p, e = np.asarray(p), np.asarray(e) / np.linalg.norm(e)
    radial = p / np.linalg.norm(p)
    stretched = np.array([math.atan2(p[1], p[0]), 0.0, 0.0, 0.0, 0.0, 0.0])
    assert handarm.is_valid(paper, stretched)  # that pose exists
    np.testing.assert_allclose(handarm.forward(paper, stretched)[0], p, atol=1e-15)
    r = ik.solve(paper, p, e)
    assert r.reached_dof == 3
    assert r.position_error == 0.0
    np.testing.assert_array_equal(r.achieved_position, p)
    assert angle(r.achieved_direction, radial) < 1e-6
    assert r.direction_error == pytest.approx(angle(r.achieved_direction, e), abs=1e-12)
    p2, e2 = handarm.forward(paper, r.solutions)
    np.testing.assert_allclose(p2, np.broadcast_to(p, p2.shape), atol=1e-12)
    np.testing.assert_allclose(e2, np.broadcast_to(r.achieved_direction, e2.shape), atol=1e-9)
    assert handarm.is_valid(paper, r.solutions).all()


#: (p, e, a solvable direction at p) from an independent oracle check (2026-11-27: a
#: 20,000-point sphere refined by shrinking caps) that level 3 answered worse than by more
#: than 0.01 degrees: the pattern search's ring of 16 stepped over the closer directions.
LEVEL3_MISSES = [
    (
        [0.2343788801165287, -0.0431847524539032, 0.08391829790884282],
        [-0.5540530902710713, 0.7857050694699245, -0.27512309421482123],
        [-0.10965355499051303, 0.022020661518380155, 0.9937259120825196],
    ),  # 4.7 degrees worse, stopped next to straight up
    (
        [-0.1487286433864153, -0.1927183394840304, 0.045595421448977505],
        [-0.04552061674891396, 0.5462414384427875, -0.836389959515747],
        [-0.47656705517098574, -0.5273031134081722, -0.7034452846637776],
    ),
    (
        [-0.03136595649168085, -0.2907293138254817, 0.022583523465752098],
        [-0.18024508527086777, 0.906810821446593, -0.3810588449872971],
        [-0.1298270744448993, -0.964021093900142, -0.23196607781452108],
    ),
    (
        [-0.12260494571166514, -0.002735544079493291, 0.13818862131364026],
        [0.2969023251789501, 0.678543094677253, -0.671884125403443],
        [0.42761700531182306, 0.3482027391674056, 0.8342053399520194],
    ),
]


@pytest.mark.parametrize(("p", "e", "witness"), LEVEL3_MISSES)
def test_level3_is_no_worse_than_an_oracles_solvable_direction(paper, p, e, witness):
    """Level 3 (both orders) is within 0.01 degrees of the oracle's direction, which is
    checked solvable here (count_solutions)."""
    p, e, w = (np.asarray(v, float) for v in (p, e, witness))
    e, w = e / np.linalg.norm(e), w / np.linalg.norm(w)
    assert solvable(paper, p, w[None])[0]
    for order in ("paper", "angle"):
        r = ik.solve(paper, p, e, order=order)
        assert r.reached_dof in (3, 4)
        check_pose(paper, r, p)
        assert r.direction_error <= angle(w, e) + math.radians(0.01), order


#: A random design, and (p, e, a solvable direction) where level 3 answered 2.6 deg worse
#: (a hostile check of 2026-11-27): the direction's configuration has joint 1 at its limit
#: and the wrist straight, and none of the 8 configurations level 3 started from lay in its
#: basin (32 now, as level 2's).
RANDOM_R1 = dict(
    link_lengths=(0.06174426416967699, 0.05963158200557567, 0.04314467124381542,
                  0.040312923942853594, 0.05337981657219151, 0.07139357632615503,
                  0.041012489459177084),
)  # fmt: skip
LEVEL3_MISSES_RANDOM = [
    (
        [-0.15847864108007573, 0.07733608170935964, -0.14219379513653485],
        [0.18526544938305817, 0.9756783928767854, -0.11716819934720636],
        [-0.4161657511579471, 0.47686097467579736, -0.7742155245113536],
    ),
]


@pytest.mark.parametrize(("p", "e", "witness"), LEVEL3_MISSES_RANDOM)
def test_level3_starts_from_a_basin_the_nearest_few_miss(p, e, witness):
    """As above, on a random design."""
    design = handarm.ArmDesign(**RANDOM_R1)
    p, e, w = (np.asarray(v, float) for v in (p, e, witness))
    assert solvable(design, p, w[None])[0]
    r = ik.solve(design, p, e)
    assert r.reached_dof in (3, 4)
    check_pose(design, r, p)
    assert r.direction_error <= angle(w, e) + math.radians(0.01)


@pytest.mark.parametrize(
    "p",
    [
        [0.06434171225932628, -0.12719881916497952, -0.10740049550764583],
        [-0.08079806866062753, 0.045172260227236936, -0.08609858980256976],
    ],
)
def test_a_vertical_e_can_still_be_kept_at_level_4(p):
    """Straight up: level 4 keeps the tip plane of L's azimuth (found by the level-4 search;
    a filter meant for ``current``'s held directions once dropped these to level 3)."""
    design = handarm.ArmDesign(**RANDOM_R1)
    p, e = np.asarray(p, float), np.array([0.0, 0.0, 1.0])
    r = ik.solve(design, p, e)
    assert r.reached_dof == 4
    check_pose(design, r, p)
    assert r.direction_error == pytest.approx(float(angle(r.achieved_direction, e)), abs=1e-12)
    # the achieved direction lies in the vertical plane of L's azimuth
    c, s_ = math.cos(r.azimuth), math.sin(r.azimuth)
    assert abs(-s_ * r.achieved_direction[0] + c * r.achieved_direction[1]) < 1e-9


def test_the_searches_count_as_count_solutions_does(paper):
    """Degradation counts its own directions without the input checks: same answers for
    random (unnormalised) directions, vertical ones, and a point on joint 1's axis."""
    from handarm.ik.degrade import _first_solvable, _solvable

    rng = np.random.default_rng(8)
    q = valid_configurations(paper, rng, 12)
    P = list(handarm.forward(paper, q)[0]) + [np.array([0.0, 0.0, 0.12])]
    dirs = rng.normal(size=(60, 3))
    dirs = np.concatenate([dirs, [[0, 0, 1.0], [0, 0, -1.0], [1e-13, 0, -1.0]]])
    for p in P:
        want = solvable(paper, p, dirs)
        np.testing.assert_array_equal(_solvable(paper, p, dirs), want)
        for k in (1, 3):
            np.testing.assert_array_equal(
                _first_solvable(paper, p, dirs, k), np.flatnonzero(want)[:k]
            )
    assert 0 < sum(solvable(paper, p, dirs).sum() for p in P) < len(P) * len(dirs)


def test_level4_search_stops_each_side_at_the_best_answer(paper):
    """The level-4 search stops a side once it cannot beat the best grid angle found: the
    same nearest direction as searching every side of both circles out to the end, for far
    fewer directions."""
    from handarm.ik import degrade

    tested = []
    P, E = level4_targets(paper, 12, seed=7)
    cost = {True: 0, False: 0}
    found = 0
    for p, e in zip(P, E, strict=True):
        best = {}
        for prune in (True, False):
            tested.clear()
            cands = degrade._circle_candidates(paper, p, e, None, prune=prune, stats=tested)
            cost[prune] += tested[0]  # grid directions (tested[1]: suspects scanned)
            best[prune] = min((float(angle(v, e)) for v in cands), default=math.inf)
        assert best[True] == pytest.approx(best[False], abs=1e-12)
        found += math.isfinite(best[True])
    assert found >= 6
    assert cost[True] < 0.5 * cost[False], cost


def test_a_sub_problem_with_no_valid_stretch_rules_out_its_whole_circle(paper):
    """Where the base problem alone has no valid stretch, no direction of e's azimuth is
    solvable at p (360 on the vertical great circle through e); where the tip problem alone
    has none, no direction of e's elevation is (360 on its small circle)."""
    rng = np.random.default_rng(10)
    q = valid_configurations(paper, rng, 200)
    P = handarm.forward(paper, q)[0] * rng.uniform(1.0, 1.4, (200, 1))
    P = P[np.linalg.norm(P, axis=1) < 0.29]
    t = np.radians(np.arange(0.0, 360.0, 1.0) + 0.3)
    ruled_out = {"base": 0, "tip": 0}
    for p in P[:120]:
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        pitch, yaw = math.asin(e[2]), math.atan2(e[1], e[0])
        base, tip = exact.sub_problems_solvable(paper, p, e, yaw)
        if not base:
            ruled_out["base"] += 1
            circle = np.stack([np.cos(t) * math.cos(yaw), np.cos(t) * math.sin(yaw), np.sin(t)], 1)
            assert not solvable(paper, p, circle).any()
        if not tip:
            ruled_out["tip"] += 1
            c = math.cos(pitch)
            circle = np.stack([c * np.cos(t), c * np.sin(t), np.full_like(t, e[2])], 1)
            assert not solvable(paper, p, circle).any()
    assert min(ruled_out.values()) >= 5, ruled_out


#: (p, e, a valid configuration whose tool point lies nearer p than level 2 answered) from
#: the oracle check (2026-11-27: 280,435 valid configurations, the nearest 24 polished):
#: points near the base axis, where the nearest reachable point lies on a collision boundary
#: and polishing stopped where its step first met one (10.9, 10.2 and 5.5 mm worse).
LEVEL2_MISSES = [
    (
        [-0.01162035811460684, -0.0036923587068426657, -0.16344228044995596],
        [0.11079387565021934, 0.6075286748952945, -0.7865326606685645],
        [-0.9713459385928555, -1.509576862512004, -2.135626903311491, -1.4988978887013678,
         -0.03877566223897255, 0.11129371931998727],
    ),
    (
        [-0.012717687108024187, 0.0009785888561152849, 0.17994963143430173],
        [-0.5322980427399815, -0.7356561383449214, -0.4188900092036368],
        [-1.101847818704221, -1.5193364591002163, -2.1086225710268884, 1.5528137477810957,
         -0.0382876492378518, -0.13372744882194748],
    ),
    (
        [-5.5638970823737534e-05, -0.000155030559992098, -0.18833503682366814],
        [0.04303301658582982, 0.9558474160437308, -0.29069550517000875],
        [-0.4120688034124138, 1.5743424583089611, 2.1477378622637913, -1.471653274257098,
         -0.029352068765313113, 0.011319826066967294],
    ),
]  # fmt: skip

#: A random design of a second oracle check (link lengths 40-74 mm), and (p, e, witness)
#: where level 2 stopped 3.4 and 7.3 um farther than the witness, and on the paper's arm
#: 33 um farther: the witnesses have the wrist straight (joints 5 and 6 near 0), which the
#: slide now reaches by moving single joints.
RANDOM103 = dict(
    link_lengths=(0.04907074547253264, 0.045094320018172145, 0.043190437764243736,
                  0.07370803905170445, 0.07358941197711663, 0.03966030951112132,
                  0.04800904267104079),
    hub_radius=0.00996943043487774, beam_width=0.01361036610903393,
    cable_diameter=0.0013264160037434638, clearance=0.00029628132074842887,
)  # fmt: skip
LEVEL2_MISSES_STRAIGHT_WRIST = [
    (
        None,
        [-0.016718367618449928, -0.0017285371464782135, -0.1944988202607913],
        [0.5697731272009999, 0.628529245791749, 0.5294426982252642],
        [-1.0996723502638812, -1.5212007284671043, -2.124677083393828, -1.479565367951304,
         -4.135557818400533e-08, 3.5482316226324816e-08],
    ),
    (
        RANDOM103,
        [-0.030271680963577186, 0.0029556056845395496, -0.14564884468245737],
        [0.07546234097384312, -0.809181900772879, -0.5826921027063419],
        [1.4576320787571595, 2.2828114680194114, -2.151896349407646, -2.1303055570705443,
         2.7614597191368225e-07, -3.166025694528396e-08],
    ),
    (
        RANDOM103,
        [-0.025405023949336792, -0.007409179064276628, 0.24141424107545903],
        [0.7724177076598259, -0.23340503145827773, 0.5906716314361984],
        [0.4280144845259397, -1.8773643964433187, -1.6922427325048741, 1.57926342726958,
         7.89642702013412e-08, -1.2236228263477312e-10],
    ),
]  # fmt: skip


#: (p, e, witness) on the paper's arm where the second oracle check's longer local search
#: ended 0.083 mm nearer p than level 2 (0.143 mm away): the slides stopped after 100
#: iterations that gained under 1e-10 m, and now crawl on (1,000 iterations of patience).
LEVEL2_MISSES_LONG_SLIDE = [
    (
        [-0.042458041445129574, 0.016635851426244828, 0.15006504233658088],
        [-0.4634411170691718, 0.2619289043182851, 0.8465314997637717],
        [1.4443419022671031, 1.2496971311960183, 1.950893019520331, 1.5483916058497138,
         -0.013454221898122556, -0.00034026048085362395],
    ),
]  # fmt: skip


@pytest.mark.parametrize(("p", "e", "witness"), LEVEL2_MISSES_LONG_SLIDE)
def test_level2_slides_on_along_a_contact_it_crawls_on(paper, p, e, witness):
    """As below, where the slide must keep going through hundreds of small gains."""
    _check_level2_against_witness(paper, p, e, witness)


#: (design, p, e, witness) where the slide zig-zagged along a curved contact and stopped
#: short: the three misses of ``benchmarks/bench_level2.py --targets 30`` near the base axis
#: (0.047, 0.0008 and 0.0015 mm farther than its oracle's configuration, paper's arm) and two
#: of the second oracle check's on RANDOM103 (0.011 and 0.046 mm). Pattern moves along the
#: slide's net displacement (``handarm.ik._nearest._TRENDS``) reach them.
LEVEL2_MISSES_VALLEY = [
    (
        None,
        [-0.05661610521975304, 0.014519430413132847, 0.17461340432314285],
        [0.24774541302244948, -0.8321218084343028, -0.4961809208891061],
        [2.1050842897440174, 0.46873878869217755, 2.3353385230398893, 1.5539423654119058,
         -0.02836215274966222, -8.07895843761947e-08],
    ),
    (
        None,
        [-0.026083523252115742, -0.00430313805997371, -0.178515209109238],
        [-0.752732924683861, -0.5063038736112011, 0.4207725414795666],
        [-1.19037668427777, -1.4830836571864026, -2.038928640231093, -1.4887286681730127,
         1.5294401472131824e-07, -1.831504844043793e-08],
    ),
    (
        None,
        [0.0006812527962160904, -0.004754773624386797, 0.18848050424814256],
        [-0.6138938343902539, -0.4953723164780421, 0.6146060756003068],
        [-2.3561944862780444, 1.3757455757013033, 2.32708624233796, 1.4537784387420272,
         1.0575453832462853e-07, -5.358755154850721e-08],
    ),
    (
        RANDOM103,
        [-0.01636585242165005, 0.014431193343006576, -0.16668193114888188],
        [-0.6353764853558381, -0.18935158249639988, -0.7486272103410158],
        [-0.42227806263389933, 1.6262364027603495, 1.9376343142349681, -1.5751050391342885,
         6.510898325226521e-07, -7.668750337953058e-08],
    ),
    (
        RANDOM103,
        [0.005234531873934079, -0.006054017981713301, 0.16450808633682804],
        [0.7104411971367837, -0.5967469835765457, 0.3730500542864827],
        [-2.356194490192345, 0.9772308615075198, 2.356194490192345, 1.5768219004852686,
         1.1537828984027983e-06, -1.1539087301137745e-07],
    ),
]  # fmt: skip


#: A second random design of that check, and (design, p, e, witness) where level 2 still
#: stopped 11, 4.7 and 6.3 um farther than the witness (found by the oracle's longer local
#: search), wrists straight: a contact blocks the descent nearly head-on, and the valid
#: descending directions lie within 0.1 deg of the contact's tangent plane, where only the
#: grazing polls (``handarm.ik._nearest._GRAZES``) look.
RANDOM101 = dict(
    link_lengths=(0.07745896275247494, 0.0511739465003708, 0.07031624353864897,
                  0.06160751833532353, 0.04824478525386177, 0.07652265588903115,
                  0.07411991951053562),
    beam_width=0.015785414517063154, hub_radius=0.008184830557743137,
    cable_diameter=0.0010694291968821575, clearance=0.0003610991735856244,
)  # fmt: skip
LEVEL2_MISSES_GRAZING = [
    (
        RANDOM101,
        [-0.011675018353515334, -0.00018928590893117352, -0.3313251089428549],
        [-0.528188699316376, -0.7159818564343745, 0.45649389828480913],
        [0.8791189477011028, 1.5849975301142316, 2.3184175166094696, -1.502693234910573,
         -9.612993898909839e-08, 3.616999833980645e-08],
    ),
    (
        RANDOM103,
        [-0.018014128099751447, -0.001862507769447194, -0.20957349086891777],
        [0.5697731272009999, 0.628529245791749, 0.5294426982252642],
        [0.3785228039005246, -1.616457112693739, -1.9036583478138787, -1.5692660980477509,
         -2.9043168955005426e-08, 4.313902102936369e-08],
    ),
    (
        RANDOM103,
        [-0.016056877012982224, 0.008233054883290713, -0.30565474175061996],
        [0.7484118380772666, 0.07307556144631812, 0.6591962400872085],
        [-0.40449908022710296, 1.5636598560500141, 1.9824320519336196, -1.567246872203636,
         -4.75783872131487e-08, 2.8680188249746556e-08],
    ),
]  # fmt: skip


@pytest.mark.parametrize(("design", "p", "e", "witness"), LEVEL2_MISSES_GRAZING)
def test_level2_slides_along_a_contact_that_blocks_the_descent(paper, design, p, e, witness):
    """As below, where the slide must move nearly square to the steepest descent."""
    _check_level2_against_witness(handarm.ArmDesign(**design), p, e, witness)


@pytest.mark.parametrize(("design", "p", "e", "witness"), LEVEL2_MISSES_VALLEY)
def test_level2_follows_a_curved_contact_to_its_end(paper, design, p, e, witness):
    """As below, where moves along single polls zig-zag and stop short."""
    _check_level2_against_witness(handarm.ArmDesign(**design) if design else paper, p, e, witness)


@pytest.mark.parametrize(("p", "e", "witness"), LEVEL2_MISSES)
def test_level2_is_no_farther_than_an_oracles_valid_configuration(paper, p, e, witness):
    """Level 2 gets within 1e-7 m of the distance of the oracle's configuration, which is
    checked valid here (is_valid under the printed-link model)."""
    _check_level2_against_witness(paper, p, e, witness)


@pytest.mark.parametrize(("design", "p", "e", "witness"), LEVEL2_MISSES_STRAIGHT_WRIST)
def test_level2_reaches_a_nearest_point_with_a_straight_wrist(paper, design, p, e, witness):
    """As above, where the witness has the wrist straight (joints 5 and 6 near 0)."""
    _check_level2_against_witness(handarm.ArmDesign(**design) if design else paper, p, e, witness)


def _check_level2_against_witness(design, p, e, witness):
    p, e, w = (np.asarray(v, float) for v in (p, e, witness))
    assert handarm.is_valid(design, w)
    best = float(np.linalg.norm(handarm.forward(design, w)[0] - p))
    r = ik.solve(design, p, e / np.linalg.norm(e))
    assert r.reached_dof == 2
    assert r.position_error <= best + 1e-7
    p2, _ = handarm.forward(design, r.solutions)
    np.testing.assert_allclose(p2, np.broadcast_to(r.achieved_position, p2.shape), atol=1e-9)
    assert handarm.is_valid(design, r.solutions).all()
    assert r.position_error == pytest.approx(np.linalg.norm(r.achieved_position - p), abs=1e-12)


def test_level2_near_the_base_axis_matches_brute_force(paper):
    """Points within 3 cm of the base axis that the arm cannot reach (the oracle check's
    misses clustered there): level 2 is never farther than the nearest tool point of 300,000
    valid configurations drawn at random, nor than that configuration polished within its
    neighbourhood by coordinate steps that keep it valid (an independent local search)."""
    rng = np.random.default_rng(7)

    def near_axis():
        r_ax, th = 0.03 * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
        z = rng.choice([-1, 1]) * rng.uniform(0.15, 0.2)
        return np.array([r_ax * math.cos(th), r_ax * math.sin(th), z])

    _check_level2_against_descents(paper, rng, near_axis, n=8, starts=1)


@pytest.mark.slow
def test_level2_matches_a_brute_force_oracle_inside_and_beyond_the_reach(paper):
    """40 points no pose reaches, 20 inside the reach sphere and 20 beyond it: level 2 is
    never farther (by 1e-7 m) than the best of the 8 configurations of 300,000 valid ones
    nearest the point, each improved by single-joint steps that keep it valid. (Within
    6 cm of the base axis the library still stops up to 0.06 mm short of such an oracle on
    some points; see the IK guide.)"""
    rng = np.random.default_rng(11)
    reach = float(np.sum(paper.lengths[1:]))
    for scale in ((0.3, 0.98), (1.02, 1.3)):

        def point(scale=scale):
            v = rng.normal(size=3)
            return v / np.linalg.norm(v) * reach * rng.uniform(*scale)

        _check_level2_against_descents(paper, rng, point, n=20, starts=8)


def _check_level2_against_descents(design, rng, point, n, starts):
    """n points from ``point()`` that level 2 answers (random e): its distance is at most
    the cloud's nearest tool point's (300,000 valid configurations) and, to 1e-7 m, the
    best ``_coordinate_descent`` from the ``starts`` nearest of them."""
    q = valid_configurations(design, rng, 300_000)
    cloud = handarm.forward(design, q)[0]
    n_checked = 0
    while n_checked < n:
        p, e = point(), rng.normal(size=3)
        r = ik.solve(design, p, e / np.linalg.norm(e))
        if r.reached_dof != 2:
            continue
        n_checked += 1
        dist = np.linalg.norm(cloud - p, axis=1)
        assert r.position_error <= dist.min() + 1e-9
        best = min(_coordinate_descent(design, q[k], p) for k in np.argsort(dist)[:starts])
        assert r.position_error <= best + 1e-7, (p, e, r.position_error - best)


def _coordinate_descent(design, q, p, step=0.05, tol=1e-6):
    """Distance from p of a valid configuration reached from q by single-joint steps."""
    q = q.copy()
    best = float(np.linalg.norm(handarm.forward(design, q)[0] - p))
    while step > tol:
        trials = q + step * np.vstack([np.eye(6), -np.eye(6)])
        ok = handarm.is_valid(design, trials)
        dist = np.linalg.norm(handarm.forward(design, trials)[0] - p, axis=1)
        dist[~ok] = np.inf
        k = int(np.argmin(dist))
        if dist[k] < best:
            q, best = trials[k], float(dist[k])
        else:
            step *= 0.5
    return best


def _fibonacci(n):
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    t = math.pi * (1.0 + math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(t), r * np.sin(t), z], axis=1)


def _cap(c, radius, n, rng):
    """n directions uniform in the cap of angular radius ``radius`` round the unit c."""
    a = np.array([1.0, 0, 0]) if abs(c[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(c, a)
    u /= np.linalg.norm(u)
    w = np.cross(c, u)
    th = np.sqrt(rng.uniform(0, 1, n)) * radius
    ph = rng.uniform(0, 2 * math.pi, n)
    v = np.cos(th)[:, None] * c + np.sin(th)[:, None] * (
        np.cos(ph)[:, None] * u + np.sin(ph)[:, None] * w
    )
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def sphere_oracle(design, p, e, starts, rng, n=6000, per_cap=300):
    """Smallest angle from e to a solvable direction at p: a Fibonacci sphere and the
    ``starts`` (directions known solvable), the best two refined by shrinking caps (a
    move to any closer solvable sample of the cap, else half the cap, down to 1e-6 rad)."""
    cand = np.vstack([_fibonacci(n), starts])
    cand = cand[solvable(design, p, cand)]
    ang = angle(cand, e)
    best = math.inf
    for i in np.argsort(ang)[:2]:
        v, a, r = cand[i], ang[i], 0.05
        while r > 1e-6:
            s = _cap(v, r, per_cap, rng)
            sa = angle(s, e)
            closer = sa < a
            ok = np.zeros(len(s), bool)
            if closer.any():
                ok[closer] = solvable(design, p, s[closer])
            if ok.any():
                j = int(np.argmin(np.where(ok, sa, np.inf)))
                v, a = s[j], sa[j]
            else:
                r *= 0.5
        best = min(best, a)
    return best


@pytest.mark.slow
def test_level3_matches_a_sphere_oracle_on_many_targets(paper):
    """Level 3 on 300 targets (tool points of valid configurations, one in two pushed 3 %
    outwards, random directions, no exact solution): never farther from e than the oracle's
    direction by more than 0.01 degrees. The generating configuration's own direction is
    one of the oracle's starts: it is solvable at p."""
    rng = np.random.default_rng(21)
    q = valid_configurations(paper, rng, 12000)
    P, E0 = handarm.forward(paper, q)
    P[::2] *= 1.03
    E = rng.normal(size=P.shape)
    E /= np.linalg.norm(E, axis=1, keepdims=True)
    checked, worse = 0, []
    for i in np.flatnonzero(ik.count_solutions(paper, P, E) == 0):
        if checked == 300:
            break
        r = ik.solve(paper, P[i], E[i])
        if r.reached_dof != 3:
            continue
        checked += 1
        check_pose(paper, r, P[i])
        starts = E0[i][None] if solvable(paper, P[i], E0[i][None])[0] else np.zeros((0, 3))
        best = sphere_oracle(paper, P[i], E[i], starts, rng)
        if r.direction_error > best + math.radians(0.01):
            worse.append((i, math.degrees(r.direction_error - best)))
    assert checked == 300
    assert not worse, worse
