"""The certificates of the printed-link model along L, held against ``is_valid`` by sampling.

Over a stretch of u the kernel claims "contact all along" (hit) or "no contact anywhere"
(free) from one placement and a bound of how far the pieces move (``handarm.ik._printed``).
Each claim is checked here at many configurations of the stretch, as the IK's user sees them.
"""

import math

import numpy as np
import pytest
from tests.ik.conftest import random_design, valid_configurations

import handarm
from handarm import ik
from handarm.collision import collision_free
from handarm.ik import _printed as PR
from handarm.ik import _solve as S
from handarm.ik.exact import _model


def _claim(design, p, e, branch, ua, ub):
    """(hit, free) of the kernel's test of the stretch [ua, ub] on ``branch``."""
    a = design.lengths
    _, pi, pf, groups, _, rows, c, coef, _ = _model(design)
    st_u, st_v, st_mask, frames, xy, stamp, motion, bv, breaks = PR.printed_scratch(len(pi))
    hn = math.hypot(e[0], e[1])
    dx, dy = branch[0] * e[0] / hn, branch[0] * e[1] / hn
    fr = np.empty(S.FRAMES_SIZE)
    S._frames(p, e, dx, dy, a, fr)
    eb, ee = float(branch[1]), float(branch[2])
    nbk = PR.stretch_setup(fr, dx, dy, ua, ub, eb, ee, a, frames, st_v, bv, breaks)
    assert nbk >= 0
    ok, *mid = PR.pose_frames(fr, dx, dy, 0.5 * (ua + ub), eb, ee, a, frames)
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
    u = np.linspace(0.0526, 0.0531, 11)
    q, _ = ik.configurations_along(design, p, e, (-1, 1, 1), u, azimuth=r.azimuth)
    assert handarm.is_valid(design, q).all()
    assert any(lo < 0.0526 and hi > 0.0531 for lo, hi in mine)


@pytest.mark.parametrize("seed", [0, 1])
def test_stretch_claims_hold_at_every_sample(seed):
    """Stretches of every width along the joint-limit ranges of FK targets: each claim holds."""
    rng = np.random.default_rng(seed)
    counts = {"hit": 0, "free": 0, "unsure": 0}
    for k in range(30):
        design = handarm.ArmDesign() if k % 2 == 0 else random_design(rng)
        q = valid_configurations(design, rng, 1)[0]
        p, e = handarm.forward(design, q)
        if math.hypot(e[0], e[1]) < 1e-3:
            continue
        limits = ik.solve(design.replace(collision_model="paper"), p, e, degrade=False)
        for branch, (lo, hi) in zip(limits.branches, limits.intervals, strict=True):
            for _ in range(6):
                width = min(hi - lo, 10 ** rng.uniform(-5, -1.5))
                ua = rng.uniform(lo, hi - width)
                hit, free = _check(design, p, e, tuple(branch), ua, ua + width, limits.azimuth)
                counts["hit" if hit else "free" if free else "unsure"] += 1
    assert min(counts.values()) >= 20, counts  # every kind of claim was put to the test
