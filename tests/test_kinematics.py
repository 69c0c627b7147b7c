import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import handarm
from handarm.kinematics import COLLISION_PAIRS, segments_intersect

D = math.radians


def _rz(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])


def _tx(a):
    m = np.eye(4)
    m[0, 3] = a
    return m


RX90 = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=float)


def chain(design, q):
    """DESIGN.md's product of elementary transforms, written out independently."""
    a = design.link_lengths
    t = np.eye(4)
    for k in range(6):
        if k == 3:
            t = t @ RX90
        t = t @ _rz(q[k]) @ _tx(a[k + 1])
    return t


@pytest.mark.parametrize(
    ("q_deg", "p", "e"),
    [
        ([0, 0, 0, 0, 0, 0], [0.30, 0, 0], [1, 0, 0]),
        ([90, 0, 0, 0, 0, 0], [0, 0.30, 0], [0, 1, 0]),
        ([0, 90, 0, 0, 0, 0], [0.05, 0.25, 0], [0, 1, 0]),
        ([0, 0, -90, 0, 0, 0], [0.10, -0.20, 0], [0, -1, 0]),
        # joint 4 lifts the tip out of the base plane towards +z (the 90 degree twist)
        ([0, 0, 0, 90, 0, 0], [0.15, 0, 0.15], [0, 0, 1]),
        ([0, 0, 0, 0, 0, 90], [0.25, 0, 0.05], [0, 0, 1]),
        ([0, 0, 90, 90, 0, 0], [0.10, 0.05, 0.15], [0, 0, 1]),
        ([90, 0, 0, -90, 0, 0], [0, 0.15, -0.15], [0, 0, -1]),
        ([0, 0, 0, 0, 90, -90], [0.25, 0, 0.05], [1, 0, 0]),
    ],
)
def test_hand_computed_poses(design, q_deg, p, e):
    p_got, e_got = handarm.forward(design, np.radians(q_deg))
    np.testing.assert_allclose(p_got, p, atol=1e-15)
    np.testing.assert_allclose(e_got, e, atol=1e-15)


def test_matches_the_transform_chain(design, rng):
    q = rng.uniform(-math.pi, math.pi, (200, 6))
    d2 = design.replace(link_lengths=rng.uniform(0.02, 0.1, 7))
    for dd in (design, d2):
        p, e = handarm.forward(dd, q)
        t = handarm.forward_matrix(dd, q)
        for i in range(len(q)):
            ref = chain(dd, q[i])
            np.testing.assert_allclose(p[i], ref[:3, 3], atol=1e-15)
            np.testing.assert_allclose(e[i], ref[:3, 0], atol=1e-15)
            np.testing.assert_allclose(t[i], ref, atol=1e-15)


def test_batch_equals_loop_and_keeps_leading_dims(design, rng):
    q = rng.uniform(-3, 3, (4, 5, 6))
    p, e = handarm.forward(design, q)
    pos = handarm.joint_positions(design, q)
    valid = handarm.is_valid(design, q)
    assert p.shape == (4, 5, 3) and e.shape == (4, 5, 3)
    assert pos.shape == (4, 5, 8, 3) and valid.shape == (4, 5)
    for i in range(4):
        for j in range(5):
            p1, e1 = handarm.forward(design, q[i, j])
            np.testing.assert_array_equal(p1, p[i, j])
            np.testing.assert_array_equal(e1, e[i, j])
            assert handarm.is_valid(design, q[i, j]) == valid[i, j]


def test_joint_positions_agree_with_frames(design, rng):
    q = rng.uniform(-3, 3, (50, 6))
    pos = handarm.joint_positions(design, q)
    frames = handarm.joint_frames(design, q)
    np.testing.assert_allclose(pos[:, 0], [[-0.05, 0, 0]] * 50, atol=1e-15)
    np.testing.assert_allclose(pos[:, 1:], frames[..., :3, 3], atol=1e-15)
    a = np.linalg.norm(np.diff(pos, axis=1), axis=-1)
    np.testing.assert_allclose(a, 0.05, atol=1e-15)


def test_bad_q_is_named(design):
    with pytest.raises(ValueError, match=r"q: expected shape \(\.\.\., 6\)"):
        handarm.forward(design, np.zeros(5))
    with pytest.raises(ValueError, match="q: contains NaN"):
        handarm.forward(design, [0, 0, 0, np.nan, 0, 0])
    with pytest.raises(TypeError, match="design: expected an ArmDesign"):
        handarm.forward("paper", np.zeros(6))


def test_limits_are_closed(design):
    q = design.upper.copy()
    q[[0, 2]] = 0.0  # keep the arm from folding onto the handle
    assert handarm.within_limits(design, q)
    q[1] = np.nextafter(q[1], 4.0)
    assert not handarm.within_limits(design, q)
    assert not handarm.is_valid(design, q)


# (pair, crossing configuration, a neighbouring configuration that does not cross), degrees.
CASES = [
    (("l0", "l2"), [130, 140, 0, 0, 0, 0], [130, 100, 0, 0, 0, 0]),
    (("l0", "l3"), [60, 120, 90, 0, 0, 0], [60, 120, 45, 0, 0, 0]),
    (("l1", "l3"), [0, 150, 120, 0, 0, 0], [0, 150, 30, 0, 0, 0]),
    (("l6", "l4"), [0, 0, 0, 0, 150, 120], [0, 0, 0, 0, 150, 30]),
    (("l6", "l3"), [0, 0, 0, 60, 120, 90], [0, 0, 0, 60, 120, 45]),
    (("l5", "l3"), [0, 0, 0, 120, 150, 0], [0, 0, 0, 120, 100, 0]),
]


@pytest.mark.parametrize(("pair", "crossing", "clear"), CASES)
def test_each_pair_crosses_by_hand(loose, pair, crossing, clear):
    """The paper's segment model (collision_model = "paper"); the printed links collide too."""
    paper = loose.replace(collision_model="paper")
    which = handarm.link_crossings(paper, np.radians(crossing))
    expected = np.array([p == pair for p in COLLISION_PAIRS])
    np.testing.assert_array_equal(which, expected)
    assert not handarm.is_valid(paper, np.radians(crossing))
    assert not handarm.link_crossings(paper, np.radians(clear)).any()
    assert handarm.is_valid(paper, np.radians(clear))
    # segments that cross lie inside envelopes that overlap
    a, b = (int(name[1]) for name in pair)
    printed = handarm.colliding_pairs(loose, np.radians(crossing))
    assert printed[handarm.collision.LINK_PAIRS.index((min(a, b), max(a, b)))]


def test_crossings_alike_one_by_one_and_in_bulk(loose):
    """Few configurations take the six pairs in one call, many pair by pair: same answers."""
    paper = loose.replace(collision_model="paper")
    rng = np.random.default_rng(7)
    q = rng.uniform(paper.lower, paper.upper, (600, 6))
    q[:40] = np.round(q[:40], 1)  # straight and folded arms: collinear links
    q[40:60, 1:3] = 0.0
    bulk = handarm.link_crossings(paper, q)
    assert bulk.any() and not bulk.all()
    one = np.array([handarm.link_crossings(paper, row) for row in q])
    np.testing.assert_array_equal(one, bulk)
    np.testing.assert_array_equal(handarm.link_crossings(paper, q[:100]), bulk[:100])


def test_straight_arm_is_valid(design):
    # all links collinear: rounding noise must not make disjoint segments "cross"
    for psi in np.linspace(-2, 2, 9):
        q = np.array([psi, 0, 0, 0.3, 0, 0])
        assert handarm.is_valid(design, q)


def _reference_intersect(p1, p2, p3, p4):
    """Solve p1 + t (p2 - p1) = p3 + s (p4 - p3) for t, s in [0, 1]."""
    r, s_ = p2 - p1, p4 - p3
    den = r[0] * s_[1] - r[1] * s_[0]
    if abs(den) < 1e-12:
        return None  # parallel: left to the exact test
    w = p3 - p1
    t = (w[0] * s_[1] - w[1] * s_[0]) / den
    s = (w[0] * r[1] - w[1] * r[0]) / den
    return -1e-9 <= t <= 1 + 1e-9 and -1e-9 <= s <= 1 + 1e-9, min(
        abs(t), abs(t - 1), abs(s), abs(s - 1)
    )


def _point_segment_distance(p, a, b):
    t = np.clip(np.dot(p - a, b - a) / max(np.dot(b - a, b - a), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t * (b - a)))


@settings(max_examples=300, deadline=None)
@given(arrays(np.float64, (4, 2), elements=st.floats(-1, 1)))
def test_segment_test_agrees_with_parametric_solution(pts):
    ref = _reference_intersect(*pts)
    if ref is None or ref[1] < 1e-7:
        return  # parallel or grazing an end: the parametric form is ill-conditioned there
    p1, p2, p3, p4 = pts
    gap = min(
        _point_segment_distance(p1, p3, p4),
        _point_segment_distance(p2, p3, p4),
        _point_segment_distance(p3, p1, p2),
        _point_segment_distance(p4, p1, p2),
    )
    if not ref[0] and gap < 1e-9:
        return  # within the collinearity tolerance (COLLINEAR_TOL) touching is by design
    assert bool(segments_intersect(*pts)) == ref[0]


def test_collinear_segments():
    a, b = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    assert segments_intersect(a, b, np.array([0.5, 0.0]), np.array([2.0, 0.0]))
    assert segments_intersect(a, b, np.array([1.0, 0.0]), np.array([2.0, 0.0]))  # touching
    assert not segments_intersect(a, b, np.array([1.5, 0.0]), np.array([2.0, 0.0]))


@settings(max_examples=400, deadline=None)
@given(
    pts=st.lists(st.tuples(st.integers(-4, 4), st.integers(-4, 4)), min_size=4, max_size=4),
    scale=st.sampled_from([1.0, 0.05, 1e-3]),
    jitter=st.floats(-1e-12, 1e-12),
)
def test_numpy_and_numba_segment_predicates_agree(pts, scale, jitter):
    """kinematics.segments_intersect (numpy) and the IK kernel's segments_touch (numba).

    Integer grid points make collinear, touching and endpoint-sharing cases common; a
    sub-tolerance jitter checks that both round the same way.
    """
    from handarm.ik._classify import segments_touch

    p = np.array(pts, dtype=float) * scale
    p[0, 0] += jitter
    numpy_says = bool(segments_intersect(p[0], p[1], p[2], p[3]))
    numba_says = bool(segments_touch(*p[0], *p[1], *p[2], *p[3]))
    assert numpy_says == numba_says
