"""The geometry of degradation's compiled searches (``handarm.ik._search``)."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.ik.conftest import random_design, valid_configurations

import handarm
from handarm import ik
from handarm.ik import _search as K
from handarm.ik import _solve as S

unit = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: 1e-3 < math.sqrt(sum(x * x for x in v))
)


#: The paper's arm and three random designs (unequal lengths, asymmetric limits).
DESIGNS = [handarm.ArmDesign()] + [random_design(np.random.default_rng(s)) for s in (1, 2, 3)]


def normal(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def angle(a, b):
    """Angle between unit vectors, exact near 0 (arccos of the dot product is not: 1.5e-8
    for vectors one rounding step apart)."""
    return float(2 * np.arctan2(np.linalg.norm(a - b), np.linalg.norm(a + b)))


@settings(max_examples=300, deadline=None)
@given(a=unit, b=unit, t=st.floats(0.0, 1.0))
def test_slerp_walks_the_great_circle(a, b, t):
    """A unit vector on the plane of a and b, t of the way from a (antipodal: any circle)."""
    a, b = normal(a), normal(b)
    out = np.empty(3)
    K.slerp(a, b, t, out)
    assert abs(np.linalg.norm(out) - 1.0) < 1e-12
    omega = angle(a, b)
    assert abs(angle(a, out) - t * omega) < 1e-6
    if omega < math.pi - 1e-6:
        assert abs(angle(out, b) - (1 - t) * omega) < 1e-6
        assert abs(np.dot(np.cross(a, b), out)) < 1e-9  # on the circle through a and b
    assert abs(K.angle3(*a, *b) - omega) < 1e-6


@settings(max_examples=300, deadline=None)
@given(v=unit)
def test_tangents_complete_a_right_handed_frame(v):
    v = normal(v)
    t = np.array(K.tangents(*v)).reshape(2, 3)
    frame = np.array([t[0], t[1], v])
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(frame) > 0.0


def reference_refine(design, p, e0, good):
    """The search in plain Python with public counts: arc bisection, then rings."""
    from handarm import ik
    from handarm.ik.degrade import _PATTERN_ROUNDS, _RING, ANGLE_TOL

    def solvable(v):
        return ik.count_solutions(design, p[None], normal(v)[None])[0] > 0

    def slerp(a, b, t):
        omega = angle(a, b)
        if omega < 1e-15:
            return b.copy()
        v = (math.sin((1 - t) * omega) * a + math.sin(t * omega) * b) / math.sin(omega)
        return v / np.linalg.norm(v)

    arc = max(angle(e0, good), ANGLE_TOL)
    lo, hi = 0.0, 1.0
    while hi - lo > ANGLE_TOL / arc:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if solvable(slerp(e0, good, mid)) else (mid, hi)
    good = slerp(e0, good, hi)
    top = step = math.radians(2.0)
    ring = _RING  # the same trial directions
    for _ in range(_PATTERN_ROUNDS):
        if step <= ANGLE_TOL:
            break
        t1, t2 = np.array(K.tangents(*good)).reshape(2, 3)
        bearings = [math.cos(r) * t1 + math.sin(r) * t2 for r in ring]
        towards = e0 - np.dot(e0, good) * good  # nearly tangent to the circle round e0
        if np.linalg.norm(towards) > 1e-12:
            w = towards / np.linalg.norm(towards)
            v = np.cross(good, w)
            for turn in K.TANGENT_TURNS:
                bearings += [math.sin(turn) * w + side * math.cos(turn) * v for side in (1, -1)]
        trials = [math.cos(step) * good + math.sin(step) * b for b in bearings]
        closer = sorted(
            (angle(v / np.linalg.norm(v), e0), k, v)
            for k, v in enumerate(trials)
            if angle(v / np.linalg.norm(v), e0) < angle(good, e0)
        )
        moved = next((v for _, _, v in closer if solvable(v)), None)
        if moved is not None:
            good, step = moved, min(2.0 * step, top)
        else:
            step *= 0.5
    return good


def test_compiled_search_ends_where_the_plain_one_does(paper):
    """Level-3 starts of targets that need level 3: the compiled search (one call, which
    stops at a coarse ring and goes on from there) and a plain Python one with public counts
    end on the same direction."""
    from tests.ik.conftest import valid_configurations

    import handarm
    from handarm import ik
    from handarm.ik import degrade

    rng = np.random.default_rng(3)
    q = valid_configurations(paper, rng, 300)
    p = handarm.forward(paper, q)[0] * 1.06
    e = normal(rng.normal(size=3))
    checked = 0
    for pk in p:
        e = normal(rng.normal(size=3))
        if ik.count_solutions(paper, pk[None], e[None])[0]:
            continue
        sphere = degrade._sphere_by_angle(paper, pk, e)
        starts = degrade._nearest_solvable(paper, pk, sphere, 2)
        if not starts:
            continue
        for start in starts:
            # one start a call: searches from several that meet share an answer
            # (test_searches_that_meet_cost_nothing_in_angle)
            (got,) = degrade._refine(paper, pk, e, [start])
            want = reference_refine(paper, pk, e, start)
            assert angle(normal(got), normal(want)) < 1e-9, (pk, e, start)
        checked += 1
        if checked == 4:
            break
    assert checked == 4


def test_searches_that_meet_cost_nothing_in_angle(paper):
    """``refine_directions`` goes on to the fine tolerance only with searches that did not
    meet an earlier one (``SAME_END``); the best direction it finds is as close to e as the
    best of every start searched alone, to ``ANGLE_TOL``."""
    from tests.ik.conftest import valid_configurations

    import handarm
    from handarm import ik
    from handarm.ik import degrade

    rng = np.random.default_rng(11)
    q = valid_configurations(paper, rng, 300)
    p = handarm.forward(paper, q)[0] * 1.06
    checked = met = 0
    for pk in p:
        e = normal(rng.normal(size=3))
        if ik.count_solutions(paper, pk[None], e[None])[0]:
            continue
        starts = degrade._nearest_solvable(paper, pk, degrade._sphere_by_angle(paper, pk, e), 6)
        if len(starts) < 2:
            continue
        together = degrade._refine(paper, pk, e, starts)
        alone = [degrade._refine(paper, pk, e, [s])[0] for s in starts]
        best_together = min(angle(normal(v), e) for v in together)
        best_alone = min(angle(normal(v), e) for v in alone)
        assert best_together <= best_alone + degrade.ANGLE_TOL, (pk, e)
        # the first search never meets another: it is the search alone, exactly
        assert angle(normal(together[0]), normal(alone[0])) < 1e-12
        pairs = zip(together, alone, strict=True)
        met += sum(angle(normal(t), normal(a)) > 1e-12 for t, a in pairs)
        checked += 1
        if checked == 6:
            break
    assert checked == 6
    assert met > 0  # some searches did meet (else this test shows nothing)


def _solver_reach(p, e, a):
    """The solver's own reach test: both chains reach L for a sign of d (``_line_window``)."""
    fr = np.empty(S.FRAMES_SIZE)
    h = math.hypot(e[0], e[1])
    margins = []
    reach = False
    for sgn in (1.0, -1.0):
        lo, hi = S._line_window(p, e, sgn * e[0] / h, sgn * e[1] / h, a, fr)
        reach = reach or lo < hi
        margins += [
            (a[1] + a[2]) ** 2 - (fr[0] ** 2 + fr[1] ** 2),
            (a[4] + a[5]) ** 2 - (fr[3] ** 2 + fr[4] ** 2),
        ]
        if margins[-1] > 0 and margins[-2] > 0:
            margins.append(hi - lo)
    return reach, min(abs(m) for m in margins)


@settings(max_examples=500, deadline=None)
@given(
    seed=st.integers(0, 3),
    x=st.tuples(st.floats(-1.3, 1.3), st.floats(-1.3, 1.3), st.floats(-1.3, 1.3)),
    v=unit,
)
def test_the_closed_form_reach_test_is_the_solvers(seed, x, v):
    """``may_reach`` (no trigonometry) answers as the solver's ``_line_window`` does, for
    points around the reach of the paper's arm and random designs (away from a boundary
    by 1e-9, where rounding decides)."""
    design = DESIGNS[seed]
    a = design.lengths
    p = np.asarray(x) * float(np.sum(a[1:]))
    e = normal(v)
    if math.hypot(e[0], e[1]) < 1e-6:
        return
    want, margin = _solver_reach(p, e, a)
    if margin > 1e-9:
        assert S.may_reach(p, *e, a) == want
        assert S.may_reach(p, *(3.5 * e), a) == want  # any length of e


def test_the_reach_test_never_rules_out_a_solvable_direction():
    """Every direction ``count_solutions`` finds solvable passes ``may_reach``: the tool
    poses of valid configurations (solvable by construction) and random directions at
    their points, on the paper's arm and three random designs."""
    rng = np.random.default_rng(5)
    for design in DESIGNS:
        q = valid_configurations(design, rng, 300)
        P, E0 = handarm.forward(design, q)
        E = rng.normal(size=P.shape)
        E /= np.linalg.norm(E, axis=1, keepdims=True)
        for dirs in (E0, E):
            counts = ik.count_solutions(design, P, dirs)
            passed = [S.may_reach(p, *e, design.lengths) for p, e in zip(P, dirs, strict=True)]
            assert all(passed[i] for i in np.flatnonzero(counts > 0))
        assert (ik.count_solutions(design, P, E0) > 0).mean() > 0.9
