"""The certificates of the printed-link model along L, held against ``is_valid`` by sampling.

Over a stretch of u the kernel claims "contact all along" (hit) or "no contact anywhere"
(free) from one placement and a bound of how far the pieces move (``handarm.ik._printed``).
Each claim is checked here at many configurations of the stretch, as the IK's user sees them.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.ik.conftest import random_design, valid_configurations

import handarm
from handarm import ik
from handarm._collide import PLACED, _swept
from handarm.collision import collision_free
from handarm.ik import _printed as PR
from handarm.ik import _solve as S
from handarm.ik.exact import _model


def _stretch(design, p, e, branch, ua, ub):
    """The kernel's setup of the stretch [ua, ub] on ``branch``: (model, scratch, frames)."""
    m = _model(design)
    scratch = PR.printed_scratch(len(m[1]))
    st_u, st_v, st_mask, frames, xy, stamp, motion, bv, breaks = scratch[:9]
    hn = math.hypot(e[0], e[1])
    dx, dy = branch[0] * e[0] / hn, branch[0] * e[1] / hn
    fr = np.empty(S.FRAMES_SIZE)
    S._frames(p, e, dx, dy, design.lengths, fr)
    nbk = PR.stretch_setup(
        fr, dx, dy, ua, ub, float(branch[1]), float(branch[2]), design.lengths, frames, st_v,
        bv, breaks,
    )  # fmt: skip
    assert nbk >= 0
    return m, scratch, (fr, dx, dy, nbk)


def _claim(design, p, e, branch, ua, ub):
    """(hit, free) of the kernel's test of the stretch [ua, ub] on ``branch``."""
    m, scratch, (fr, dx, dy, nbk) = _stretch(design, p, e, branch, ua, ub)
    pi, pf, groups, rows, c, coef = m[1], m[2], m[3], m[5], m[6], m[7]
    st_u, st_v, st_mask, frames, xy, stamp, motion, bv, breaks = scratch[:9]
    ok, *mid = PR.pose_frames(
        fr, dx, dy, 0.5 * (ua + ub), float(branch[1]), float(branch[2]), design.lengths, frames
    )
    assert ok
    PR.new_pose(stamp)
    PR.stretch_motion(st_v, 0, ua, ub, *mid, breaks, bv, nbk, motion)
    hit, unsure = PR.groups_status(
        (1 << len(groups)) - 1, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c
    )
    return hit, not hit and unsure == 0


def _check(design, p, e, branch, ua, ub, azimuth, n=64):
    """The claim on [ua, ub] against ``collision_free`` at n configurations; (hit, free)."""
    hit, free = _claim(design, p, e, branch, ua, ub)
    if hit or free:
        u = np.linspace(ua, ub, n)
        q, ok = ik.configurations_along(design, p, e, branch, u, azimuth=azimuth)
        assert ok.all()
        clear = collision_free(design, q)
        where = (branch, ua, ub, u[clear == hit][:3])
        assert not (hit and clear.any()), f"claimed contact all along, free at {where}"
        assert not (free and not clear.all()), f"claimed free, contact at {where}"
    return hit, free


def test_a_contact_claim_holds_where_the_bounding_spheres_part():
    """The default arm's tool against l2: the pieces' test meets but the spheres part.

    The kernel once claimed contact over [0.05252, 0.05560] (pieces shrunk by their motion
    still met) while ``is_valid``, which first compares bounding spheres, found the arm free
    up to u = 0.053112: the IK ended that range 0.6 mm early.
    """
    design = handarm.ArmDesign()
    p = np.array([0.08327305785544017, -0.019069270779909532, 0.07188574869621137])
    e = np.array([-0.3576838306657586, -0.1750435985934261, 0.9172905842053174])
    e = e / np.linalg.norm(e)
    r = ik.solve(design, p, e, degrade=False)
    _check(design, p, e, (-1, 1, 1), 0.0525197, 0.0555994, r.azimuth)
    mine = r.intervals[np.all(r.branches == (-1, 1, 1), axis=1)]
    u = np.linspace(0.0525197, 0.0555994, 61)
    q, ok = ik.configurations_along(design, p, e, (-1, 1, 1), u, azimuth=r.azimuth)
    free = ok & handarm.is_valid(design, q)
    assert 5 <= free.sum() < len(u)  # the range ends inside the stretch
    # every free sample lies in a returned range: the range is not ended early
    for x in u[free]:
        assert any(lo - 1e-9 <= x <= hi + 1e-9 for lo, hi in mine), x


def _stretches(seed, targets, widest):
    """Stretches along the joint-limit ranges of FK targets (the paper's arm and random
    designs), 6 per range, of widths 1e-5 m to 10**widest m:
    (design, p, e, branch, ua, ub, azimuth)."""
    rng = np.random.default_rng(seed)
    for k in range(targets):
        design = handarm.ArmDesign() if k % 2 == 0 else random_design(rng)
        q = valid_configurations(design, rng, 1)[0]
        p, e = handarm.forward(design, q)
        if math.hypot(e[0], e[1]) < 1e-3:
            continue
        limits = ik.solve(design.replace(collision_model="paper"), p, e, degrade=False)
        for branch, (lo, hi) in zip(limits.branches, limits.intervals, strict=True):
            for _ in range(6):
                width = min(hi - lo, 10 ** rng.uniform(-5, widest))
                ua = lo if width == hi - lo else rng.uniform(lo, max(lo, hi - width))
                yield design, p, e, tuple(branch), ua, ua + width, limits.azimuth


@pytest.mark.parametrize("seed", [0, 1])
def test_stretch_claims_hold_at_every_sample(seed):
    """Stretches of every width along the joint-limit ranges of FK targets: each claim holds."""
    counts = {"hit": 0, "free": 0, "unsure": 0}
    for design, p, e, branch, ua, ub, azimuth in _stretches(seed, 30, -1.5):
        hit, free = _check(design, p, e, branch, ua, ub, azimuth)
        counts["hit" if hit else "free" if free else "unsure"] += 1
    assert min(counts.values()) >= 20, counts  # every kind of claim was put to the test


def _table_claims(design, p, e, branch, ua, ub):
    """The joint-space tables' claims on [ua, ub]: {pair index: "free" / "hit"}.

    Each table pair asked alone, the stretch's box of joint angles built as
    ``printed_ranges`` builds it (the angles at the ends and the breaks inside).
    """
    m, scratch, (fr, dx, dy, nbk) = _stretch(design, p, e, branch, ua, ub)
    tnodes, toff, tdom, tmask = m[9], m[10], m[11], m[12]
    st_v, bv, breaks = scratch[1], scratch[7], scratch[8]
    st_q, bq, qs, qb, _ = scratch[9:]
    for b in range(nbk):
        PR.joint_angles(bv[b], dx, dy, fr[12], fr[13], bq[b])
    PR.joint_angles(st_v[0, 0], dx, dy, fr[12], fr[13], st_q[0, 0])
    PR.joint_angles(st_v[0, 1], dx, dy, fr[12], fr[13], st_q[0, 1])
    claims = {}
    for k, lp in enumerate(handarm.collision.TABLE_PAIRS):
        hit, left = PR.tables_status(
            int(tmask[k]), tmask, st_q, 0, ua, ub, bq, breaks, nbk, tnodes, toff, tdom, qs, qb
        )
        if hit:
            claims[lp] = "hit"
        elif left == 0:
            claims[lp] = "free"
    return claims


@pytest.mark.parametrize("seed", [0, 1])
def test_the_tables_claims_hold_along_the_line(seed):
    """Stretches of every width along the limit ranges of FK targets (the paper's arm and
    random designs): wherever a joint-space table calls its pair free (in contact) over a
    stretch, the pair is free (in contact) at every sample of it. 48 targets: with 24,
    short links' forks stopping short of their proximal grooves left seed 1 only 8 hit
    claims to test."""
    counts = {"hit": 0, "free": 0}
    for design, p, e, branch, ua, ub, azimuth in _stretches(seed, 48, -1.0):
        claims = _table_claims(design, p, e, branch, ua, ub)
        if not claims:
            continue
        u = np.linspace(ua, ub, 64)
        qq, ok = ik.configurations_along(design, p, e, branch, u, azimuth=azimuth)
        assert ok.all()
        pairs = handarm.collision.printed_collisions(design, qq)
        for lp, claim in claims.items():
            counts[claim] += 1
            if claim == "hit":
                assert pairs[:, lp].all(), (lp, branch, ua, ub)
            else:
                assert not pairs[:, lp].any(), (lp, branch, ua, ub)
    assert counts["hit"] >= 10 and counts["free"] >= 100, counts  # both kinds were tested


@pytest.mark.parametrize("seed", [0, 2])
def test_claims_hold_where_l2_meets_l4(seed):
    """l2 and l4 are tested with their motions relative to l3 (their common slide along L
    cancels): stretches at and beside configurations where l2 and l4 touch, each claim held
    against ``collision_free`` at every sample."""
    rng = np.random.default_rng(seed)
    design = handarm.ArmDesign()
    if seed:  # other lengths (a short l3: l2 and l4 meet in 2 % of the box)
        design = design.replace(link_lengths=rng.uniform(0.035, 0.065, 7))
    pair = handarm.collision.LINK_PAIRS.index((2, 4))
    q = rng.uniform(design.lower, design.upper, (40000, 6))
    hits = handarm.collision.printed_collisions(design, q)
    q = q[hits[:, pair]][:40]
    assert len(q) >= 20
    branch, u = ik.branch_of(design, q)
    p, e = handarm.forward(design, q)
    counts = {"hit": 0, "free": 0, "unsure": 0}
    for k in range(len(q)):
        if math.hypot(e[k, 0], e[k, 1]) < 1e-3:
            continue
        azimuth = math.atan2(e[k, 1], e[k, 0])
        for width in (3e-5, 3e-4, 1e-3, 3e-3):
            for ua in u[k] + width * np.array([-30.0, -8.0, -3.0, -1.0, -0.5, 0.1, 2.0, 7.0, 30.0]):
                ub = ua + width
                uu = np.linspace(ua, ub, 64)
                _, ok = ik.configurations_along(design, p[k], e[k], branch[k], uu, azimuth=azimuth)
                if not ok.all():
                    continue
                hit, free = _check(design, p[k], e[k], tuple(branch[k]), ua, ub, azimuth)
                counts["hit" if hit else "free" if free else "unsure"] += 1
    assert min(counts.values()) >= 10, counts


def test_a_contact_held_all_along_at_l1s_joint_is_decided_on_a_wide_stretch():
    """A direction on the edge of the solvable set: l1's hub touches l3 all along the range.

    Degradation bisects directions to where solutions end; here the end is l1's hub (a
    disc on joint 1, which turning does not move) touching l3, which slides along L, by less
    than 1e-10 m over 55 mm of u. The kernel demanded that the group's bounding pieces be in
    contact all along too, shrunk by their own motion (l1's bounding piece turns about
    joint 1), which held only on stretches narrower than TOL: one ``count_solutions`` took
    six minutes. The bounding pieces hold the pair's pieces, so only their spheres are
    tested again; the claim over the whole range is checked against ``is_valid`` here.
    """
    design = handarm.ArmDesign()
    p = np.array([-0.10351231627560778, -0.08873657720919487, -0.01257884682347245])
    e = np.array([-0.8569285834176997, -0.5056398116014333, -0.10000891882927904])
    e = e / np.linalg.norm(e)
    limits = ik.solve(design.replace(collision_model="paper"), p, e, degrade=False)
    branch = (1, -1, -1)
    (lo, hi), *_ = limits.intervals[np.all(limits.branches == branch, axis=1)]
    assert hi - lo > 0.05
    mid = 0.5 * (lo + hi)  # 10 mm in the middle (the ends near the reach move fast)
    hit, _ = _check(design, p, e, branch, mid - 0.005, mid + 0.005, limits.azimuth, n=400)
    assert hit
    assert ik.count_solutions(design, p[None], e[None])[0] == 0


@settings(max_examples=300, deadline=None)
@given(
    x0=st.floats(-0.03, 0.03),
    length=st.floats(0.0, 0.03),
    r=st.floats(0.002, 0.01),
    e=st.floats(0.0, 0.02),
    t=st.floats(-1.0, 1.0),
    angle=st.floats(-math.pi, math.pi),
    point=st.tuples(st.floats(-0.06, 0.06), st.floats(-0.03, 0.03)),
)
def test_a_sliding_piece_sweeps_its_lengthened_segment_and_holds_its_shortened_one(
    x0, length, r, e, t, angle, point
):
    """``_swept`` of an l3 piece sliding by at most e along its segment, against geometry.

    A point within r of the piece slid by t * e lies inside the grown piece; a point inside
    the shrunk piece lies within r of the piece wherever it slides.
    """
    c, s = math.cos(angle), math.sin(angle)
    xy = np.zeros((1, PLACED))
    xy[0, :4] = x0 * c, x0 * s, (x0 + length) * c, (x0 + length) * s
    xy[0, 8:11] = e, c, s
    pf = np.zeros((1, 8))
    pf[0, 4] = r
    a = np.array(xy[0, :2])
    b = np.array(xy[0, 2:4])
    u = np.array([c, s])
    pt = np.array(point)

    def dist(a, b, p):
        ab = b - a
        den = float(ab @ ab)
        k = 0.0 if den == 0.0 else min(1.0, max(0.0, float((p - a) @ ab) / den))
        return float(np.linalg.norm(p - a - k * ab))

    gx0, gy0, gx1, gy1, gr = _swept(xy, pf, 0, 1.0, 7)
    if dist(a + t * e * u, b + t * e * u, pt) <= r:
        assert dist(np.array([gx0, gy0]), np.array([gx1, gy1]), pt) <= gr + 1e-12
    sx0, sy0, sx1, sy1, sr = _swept(xy, pf, 0, -1.0, 7)
    if dist(np.array([sx0, sy0]), np.array([sx1, sy1]), pt) <= sr:
        assert dist(a + t * e * u, b + t * e * u, pt) <= r + 1e-12


#: A level-4 answer of the paper's arm (``benchmarks/bench_ik.py``'s "hard level 4 (a)"):
#: l2 grazes l6, and the free range is a cap of clearance at most 1.2e-7 m, 0.13 mm wide.
GRAZING_P = (-0.007995099319075539, -0.056149791856425005, -0.015041556422583029)
GRAZING_E = (-0.27143998, 0.31211768, -0.91044104)


def test_whether_a_direction_is_solvable_agrees_with_counting_next_to_a_grazing_contact():
    """Asking whether stops at the first configuration the model finds free (a witness);
    only a direction with none is certified throughout. Around a grazing contact, where the
    free range shrinks to nothing, every answer agrees with ``count_solutions``."""
    from handarm.ik.exact import solvable_checked

    design = handarm.ArmDesign()
    p, v = np.array(GRAZING_P), np.array(GRAZING_E)
    v = v / np.linalg.norm(v)
    axis = np.cross(v, [0.0, 0.0, 1.0])
    axis /= np.linalg.norm(axis)
    offsets = np.array([-1e-3, -1e-4, -1e-5, -1e-6, 0.0, 1e-6, 2e-6, 4e-6, 1e-5, 1e-4])
    # turns of v about a horizontal axis, and random directions at the same point
    turned = [v * math.cos(t) + np.cross(axis, v) * math.sin(t) for t in offsets]
    rng = np.random.default_rng(3)
    rand = rng.normal(size=(40, 3))
    E = np.concatenate([turned, rand / np.linalg.norm(rand, axis=1)[:, None]])
    P = np.repeat(p[None], len(E), axis=0)
    counts = ik.count_solutions(design, P, E)
    got = solvable_checked(design, P, E, np.zeros(len(E)))
    np.testing.assert_array_equal(got, counts > 0)
    assert 0 < counts[: len(offsets)].astype(bool).sum() < len(offsets)  # both sides met
