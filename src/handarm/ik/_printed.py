"""The printed-link collision model along L: certified valid stretches of u (numba).

On one branch (sign of d, elbow of B, elbow of E) every joint angle is a function of u, the
coordinate of joint 4 along L. Joint limits and reach are exact events of the canonical
problems (``_events``); what is left is the printed-link model of ``handarm.collision``,
which is decided here on the whole arm.

Certification. Over a stretch [ua, ub] of u, with its middle um, every piece of a link moves
at most ``delta`` from where it is at um, and ``delta`` is bounded from the stretch's ends:
l3 slides along L by at most (ub - ua) / 2; l1 and l5 turn about joints fixed in space; l2
and l4 move with one of their joints and turn; the absolute angles of l1, l2, l4 and l5 change
most, from the middle, at the stretch's ends or where they are stationary (where l2 or l1 is
perpendicular to L in the base plane, l4 or l5 in the tip plane; these points are found
exactly), so their largest change is known (``handarm.collision.motion_coefficients``).
Every test of the model is monotone in the pieces' radii, so:

* if the model finds no contact with every radius grown by its piece's delta, no
  configuration of the stretch has one (the stretch is free for that link pair);
* if it finds contact with every radius shrunk by delta, every configuration has one
  (contact being the model's whole test: bounding spheres, then pieces, for the pair and its
  group's bounding pair, see ``handarm._collide.groups_status``).

A stretch where neither holds is halved, down to ``TOL`` (5e-10 m); a stretch that narrow is
decided by the model at its middle. So no change of validity wider than ``TOL`` is missed,
and range ends are exact to ``TOL``. Link pairs proven free on a stretch are not tested again
inside it.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm._collide import N_FRAMES, PLACED, groups_status, new_pose, place_frames, set_frames
from handarm._pairtable import FREE, HIT, QUERY_STACK, query_box
from handarm.ik._common import INLINE, JIT, MERGE_GAP, wrap

#: Narrowest stretch of u (m) that is halved again; narrower ones are decided at their middle:
#: no change of validity wider than this is missed.
TOL = 5e-10
_STACK = 96
_MAX_BREAKS = 18  # 8 stationary angles and a foot per sub-problem


@nb.njit(**JIT)
def _angles_clamped(nx, ny, dx, dy, tau, elbow, b1, b2, psi):
    """Canonical angles at tau like ``_classify._angles``, with |cos qb| <= 1 + 1e-9 clamped.

    Range ends sit on reach circles, where rounding can put cos qb a hair beyond 1.
    """
    px, py = nx + tau * dx, ny + tau * dy
    r2 = px * px + py * py
    cb = (r2 - b1 * b1 - b2 * b2) / (2.0 * b1 * b2)
    if cb > 1.0 + 1e-9 or cb < -1.0 - 1e-9:
        return False, 0.0, 0.0, 0.0
    cb = min(1.0, max(-1.0, cb))
    qb = elbow * math.acos(cb)
    qa = wrap(math.atan2(py, px) - math.atan2(b2 * math.sin(qb), b1 + b2 * math.cos(qb)))
    qc = wrap(psi - qa - qb)
    return True, qa, qb, qc


@nb.njit(**JIT)
def configuration(fr, dx, dy, u, elbow_b, elbow_e, a, out):
    """Joint angles at u on a branch into ``out``; False if out of reach (see ``_solve``)."""
    ok, q1, q2, q3 = _angles_clamped(
        fr[0], fr[1], dx, dy, u - fr[2], elbow_b, a[1], a[2], math.atan2(dy, dx)
    )
    if not ok:
        return False
    ok, qa, qb, qc = _angles_clamped(
        fr[3], fr[4], fr[5], fr[6], -u - fr[7], -elbow_e, a[5], a[4], math.atan2(fr[6], fr[5])
    )
    if not ok:
        return False
    out[0], out[1], out[2] = q1, q2, q3
    out[3], out[4], out[5] = -qc, -qb, -qa
    return True


@nb.njit(**JIT)
def _elbow(px, py, b1, b2, elbow):
    """Elbow point A of a 2R chain from the origin to P (|A| = b1, |P - A| = b2).

    The elbow sign is that of the angle at A (qb), as in ``_classify._angles``. Returns
    (ok, ax, ay); points a hair beyond reach (rounding at a range end) are clamped.
    """
    rho2 = px * px + py * py
    rho = math.sqrt(rho2)
    if rho == 0.0:
        return False, 0.0, 0.0
    x = (b1 * b1 - b2 * b2 + rho2) / (2.0 * rho)
    h2 = b1 * b1 - x * x
    if h2 < 0.0:
        if h2 < -1e-9 * b1 * b1:
            return False, 0.0, 0.0
        h2 = 0.0
    y = -elbow * math.sqrt(h2)
    ux, uy = px / rho, py / rho
    return True, x * ux - y * uy, x * uy + y * ux


@nb.njit(**INLINE)
def pose_frames(fr, dx, dy, u, elbow_b, elbow_e, a, frames):
    """Place every link frame at u on a branch, with no trigonometry (see ``_collide``).

    Returns (ok, u1x, u1y, u2x, u2y, u4x, u4y, u5x, u5y): the unit directions of l1, l2
    (base plane) and l4, l5 (tip plane), whose changes bound the motion of the links.
    """
    tb = u - fr[2]
    px, py = fr[0] + tb * dx, fr[1] + tb * dy  # joint 3 (world)
    ok, ax, ay = _elbow(px, py, a[1], a[2], elbow_b)
    if not ok:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    u1x, u1y = ax / a[1], ay / a[1]
    u2x, u2y = (px - ax) / a[2], (py - ay) / a[2]
    te = -u - fr[7]
    qx, qy = fr[3] + te * fr[5], fr[4] + te * fr[6]  # joint 4 (tip canonical)
    ok, bx, by = _elbow(qx, qy, a[5], a[4], -elbow_e)  # joint 5 (tip canonical)
    if not ok:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    cg, sg, t6s, t6v = fr[8], fr[9], fr[10], fr[11]
    j5s, j5v = t6s + cg * bx - sg * by, t6v + sg * bx + cg * by
    u4x, u4y = (j5s - u) / a[4], j5v / a[4]  # joint 4 sits at (u, 0)
    u5x, u5y = (t6s - j5s) / a[5], (t6v - j5v) / a[5]
    j4x, j4y = px + a[3] * dx, py + a[3] * dy
    set_frames(
        frames,
        ax,
        ay,
        u1x,
        u1y,
        u2x,
        u2y,
        px,
        py,
        dx,
        dy,
        j4x - u * dx,
        j4y - u * dy,
        u,
        j5s,
        j5v,
        u4x,
        u4y,
        u5x,
        u5y,
        t6s,
        t6v,
        fr[12],
        fr[13],
    )
    return True, u1x, u1y, u2x, u2y, u4x, u4y, u5x, u5y


@nb.njit(**JIT)
def _turn(ax, ay, bx, by):
    """An upper bound of the angle between two unit vectors (rad), from their chord c.

    The angle is 2 asin(c / 2) <= c / sqrt(1 - c^2 / 4) (asin x <= tan(asin x)).
    """
    c2 = (ax - bx) ** 2 + (ay - by) ** 2
    if c2 >= 3.96:
        return math.pi
    return math.sqrt(c2 / (1.0 - 0.25 * c2)) * (1.0 + 1e-12)


@nb.njit(**JIT)
def _stationary(nx, ny, dx, dy, b1, b2, out, n):
    """The tau where the canonical l1 or l2 is perpendicular to L (an angle is stationary)."""
    c = -nx * dy + ny * dx  # N.n: every point of L has this coordinate across L
    for sgn in (-1.0, 1.0):
        # l2 perpendicular to L: A = P +- b2 n, |A| = b1 -> A.n = c +- b2, tau = A.d
        w = c + sgn * b2
        if b1 * b1 >= w * w:
            r = math.sqrt(b1 * b1 - w * w)
            out[n] = r
            out[n + 1] = -r
            n += 2
        # l1 perpendicular to L: A = +-b1 n, |P - A| = b2 -> tau = +-sqrt(b2^2 - (c -+ b1)^2)
        w = c - sgn * b1
        if b2 * b2 >= w * w:
            r = math.sqrt(b2 * b2 - w * w)
            out[n] = r
            out[n + 1] = -r
            n += 2
    return n


@nb.njit(**JIT)
def motion_breaks(fr, dx, dy, a, lo, hi, out):
    """Sorted u in (lo, hi) where an absolute angle of l1, l2, l4 or l5 is stationary.

    Also where joint 2 or joint 5 is (the feet of the perpendiculars from joint 1 and joint
    6 to L: an elbow's angle follows its chain's span): between these points every joint
    angle is monotone in u.
    """
    tau = np.empty(18)
    n = _stationary(fr[0], fr[1], dx, dy, a[1], a[2], tau, 0)
    tau[n] = 0.0
    n += 1
    nb_ = n
    n = _stationary(fr[3], fr[4], fr[5], fr[6], a[5], a[4], tau, n)
    tau[n] = 0.0
    n += 1
    m = 0
    for i in range(n):
        u = tau[i] + fr[2] if i < nb_ else -(tau[i] + fr[7])
        if lo < u < hi:
            out[m] = u
            m += 1
    for i in range(1, m):  # insertion sort
        x = out[i]
        j = i - 1
        while j >= 0 and out[j] > x:
            out[j + 1] = out[j]
            j -= 1
        out[j + 1] = x
    return m


@nb.njit(**JIT)
def stretch_setup(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, frames, st_v, bv, breaks):
    """Link directions at the stationary points in (lo, hi) and at its ends (stack row 0).

    Returns the number of stationary points, -1 if an end is out of reach (cannot happen
    inside a reachable stretch), -2 if a stationary point is.
    """
    nbk = motion_breaks(fr, dx, dy, a, lo, hi, breaks)
    for k in range(nbk):
        ok, v0, v1, v2, v3, v4, v5, v6, v7 = pose_frames(
            fr, dx, dy, breaks[k], elbow_b, elbow_e, a, frames
        )
        if not ok:
            return -2
        bv[k, 0], bv[k, 1], bv[k, 2], bv[k, 3] = v0, v1, v2, v3
        bv[k, 4], bv[k, 5], bv[k, 6], bv[k, 7] = v4, v5, v6, v7
    ok = True
    for end in range(2):
        ok_e, v0, v1, v2, v3, v4, v5, v6, v7 = pose_frames(
            fr, dx, dy, lo if end == 0 else hi, elbow_b, elbow_e, a, frames
        )
        ok = ok and ok_e
        st_v[0, end, 0], st_v[0, end, 1], st_v[0, end, 2], st_v[0, end, 3] = v0, v1, v2, v3
        st_v[0, end, 4], st_v[0, end, 5], st_v[0, end, 6], st_v[0, end, 7] = v4, v5, v6, v7
    return nbk if ok else -1


@nb.njit(**INLINE)
def add_free(out, first, n_out, ua, ub):
    """Record the free stretch [ua, ub]; returns the new count, -1 if ``out`` is full.

    It extends ``out[n_out - 1]`` (if that row is from this call, row ``first`` on) when
    closer than MERGE_GAP, else it starts a row.
    """
    if n_out > first and ua - out[n_out - 1, 1] <= MERGE_GAP:
        out[n_out - 1, 1] = ub
        return n_out
    if n_out >= out.shape[0]:
        return -1
    out[n_out, 0], out[n_out, 1] = ua, ub
    return n_out + 1


@nb.njit(**INLINE)
def split_stretch(st_u, st_v, top, ua, um, ub, m0, m1, m2, m3, m4, m5, m6, m7):
    """Replace stack row ``top`` by its halves, the left one above: they come off in order."""
    for k in range(8):
        st_v[top + 1, 0, k] = st_v[top, 0, k]
    st_v[top + 1, 1, 0], st_v[top + 1, 1, 1] = m0, m1
    st_v[top + 1, 1, 2], st_v[top + 1, 1, 3] = m2, m3
    st_v[top + 1, 1, 4], st_v[top + 1, 1, 5] = m4, m5
    st_v[top + 1, 1, 6], st_v[top + 1, 1, 7] = m6, m7
    st_u[top + 1, 0], st_u[top + 1, 1] = ua, um
    for k in range(8):
        st_v[top, 0, k] = st_v[top + 1, 1, k]
    st_u[top, 0], st_u[top, 1] = um, ub


@nb.njit(**INLINE)
def stretch_motion(st_v, top, ua, ub, m0, m1, m2, m3, m4, m5, m6, m7, breaks, bv, nbk, motion):
    """``motion`` of the stretch [ua, ub] on the stack at ``top`` (see ``groups_status``).

    The largest turn of l1, l2, l4, l5 from the middle (directions m0..m7), each monotone
    between the stretch's ends and the stationary points inside it.
    """
    va, vb = st_v[top, 0], st_v[top, 1]
    motion[0] = 0.5 * (ub - ua)
    motion[1] = max(_turn(va[0], va[1], m0, m1), _turn(vb[0], vb[1], m0, m1))
    motion[2] = max(_turn(va[2], va[3], m2, m3), _turn(vb[2], vb[3], m2, m3))
    motion[3] = max(_turn(va[4], va[5], m4, m5), _turn(vb[4], vb[5], m4, m5))
    motion[4] = max(_turn(va[6], va[7], m6, m7), _turn(vb[6], vb[7], m6, m7))
    for k in range(nbk):
        if ua < breaks[k] < ub:
            w = bv[k]
            motion[1] = max(motion[1], _turn(w[0], w[1], m0, m1))
            motion[2] = max(motion[2], _turn(w[2], w[3], m2, m3))
            motion[3] = max(motion[3], _turn(w[4], w[5], m4, m5))
            motion[4] = max(motion[4], _turn(w[6], w[7], m6, m7))


@nb.njit(**JIT)
def _angle_between(ax, ay, bx, by):
    return math.atan2(ax * by - ay * bx, ax * bx + ay * by)


@nb.njit(**JIT)
def joint_angles(v, dx, dy, ex, ey, out):
    """The six joint angles from the link directions ``v`` of ``pose_frames`` (8,).

    (dx, dy) is l3's direction, (ex, ey) l6's in the tip plane (the tool direction).
    """
    out[0] = math.atan2(v[1], v[0])
    out[1] = _angle_between(v[0], v[1], v[2], v[3])
    out[2] = _angle_between(v[2], v[3], dx, dy)
    out[3] = math.atan2(v[5], v[4])
    out[4] = _angle_between(v[4], v[5], v[6], v[7])
    out[5] = _angle_between(v[6], v[7], ex, ey)


#: Padding (rad) of a stretch's box of joint angles: rounding of the angles at its ends.
_BOX_PAD = 1e-10


@nb.njit(**INLINE)
def tables_status(mask, tmask, st_q, top, ua, ub, bq, breaks, nbk, tnodes, toff, tdom, qs, qb):
    """The joint-space tables' verdict on the stretch at ``top``: (hit, mask left to test).

    Over the stretch every joint angle lies between its values at the ends and at the
    breaks inside (``motion_breaks``: each angle is monotone between them). A table pair
    whose groups are in ``mask`` is FREE there (its groups leave the mask), HIT (the
    stretch is invalid) or unsure (its groups stay). ``tmask[k]``: the groups of table k.
    """
    for k in range(tmask.shape[0]):
        if not mask & tmask[k]:
            continue
        lo0 = min(st_q[top, 0, k], st_q[top, 1, k])
        hi0 = max(st_q[top, 0, k], st_q[top, 1, k])
        lo1 = min(st_q[top, 0, k + 1], st_q[top, 1, k + 1])
        hi1 = max(st_q[top, 0, k + 1], st_q[top, 1, k + 1])
        for b in range(nbk):
            if ua < breaks[b] < ub:
                lo0, hi0 = min(lo0, bq[b, k]), max(hi0, bq[b, k])
                lo1, hi1 = min(lo1, bq[b, k + 1]), max(hi1, bq[b, k + 1])
        if hi0 - lo0 > math.pi or hi1 - lo1 > math.pi:
            continue  # an angle at +-pi may read as either end: leave it to the model
        s = query_box(
            tnodes, toff[k], tdom[k], lo0 - _BOX_PAD, hi0 + _BOX_PAD, lo1 - _BOX_PAD,
            hi1 + _BOX_PAD, qs, qb,
        )  # fmt: skip
        if s == HIT:
            return True, mask
        if s == FREE:
            mask &= ~tmask[k]
    return False, mask


@nb.njit(**JIT)
def free_at(q, u, a, env, coef, frames, xy, stamp, motion):
    """The printed-link model at one configuration (joint 4 at u along L): no contact."""
    pi, pf, groups, rows, c = env[0], env[1], env[2], env[4], env[5]
    place_frames(q, a, u, frames)
    new_pose(stamp)
    motion[0] = -1.0  # nothing moves
    hit, _ = groups_status(
        (1 << groups.shape[0]) - 1, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c
    )
    return not hit


@nb.njit(**JIT)
def printed_scratch(n_pieces):
    """Scratch arrays of ``printed_ranges`` for one solving thread."""
    return (
        np.empty((_STACK, 2)),  # stretch ends
        np.empty((_STACK, 2, 8)),  # link directions at the ends (see ``pose_frames``)
        np.empty(_STACK, np.int64),  # groups of piece pairs still unsure (bit mask)
        np.zeros((N_FRAMES, 4)),
        np.empty((n_pieces, PLACED)),
        np.zeros(n_pieces + 1, np.int64),
        np.empty(5),  # motion of the stretch (see ``groups_status``)
        np.empty((_MAX_BREAKS, 8)),  # link directions where an angle is stationary
        np.empty(_MAX_BREAKS),
        np.empty((_STACK, 2, 6)),  # joint angles at the stretch ends (tables only)
        np.empty((_MAX_BREAKS, 6)),  # joint angles at the breaks
        np.empty(QUERY_STACK, np.int64),  # the tables' query stack
        np.empty((QUERY_STACK, 4)),
        np.empty(8),  # the middle's link directions
    )


@nb.njit(**JIT)
def printed_ranges(
    fr, dx, dy, lo, hi, elbow_b, elbow_e, a, mdl, scratch, out, n_out, sure, mask0, witness
):
    """Append to ``out[n_out:]`` the maximal stretches of [lo, hi] free under the model.

    [lo, hi] is a stretch where the joint limits hold on this branch. Stretches closer than
    MERGE_GAP are one. ``sure[k]`` says whether range k is free at every point: it is made
    of certified stretches only, with no gap merged over and no stretch narrower than TOL
    (decided at its middle alone). ``mask0``: the groups of piece pairs to test (the others
    never meet on this target). Returns the new count, or -1 if ``out`` (or the stack) is
    full.

    ``witness``: whether, not where. The first stretch found free, or the first stretch
    whose middle the model finds free (the model's test is strict, so that configuration
    has free neighbours), is appended alone, unsure, and the search stops. Only a target
    with no free configuration is certified throughout: next to a grazing contact a free
    stretch is certified in pieces as narrow as its clearance (thousands of them).
    """
    pi, pf, groups, rows, c, coef = mdl[1], mdl[2], mdl[3], mdl[5], mdl[6], mdl[7]
    tnodes, toff, tdom, tmask = mdl[9], mdl[10], mdl[11], mdl[12]
    st_u, st_v, st_mask, frames, xy, stamp, motion, bv, breaks = scratch[:9]
    st_q, bq, qs, qb, mv = scratch[9:]
    # where an absolute angle is stationary: its largest change over a stretch holding such
    # a point may be there rather than at the stretch's ends
    nbk = stretch_setup(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, frames, st_v, bv, breaks)
    if nbk < -1:
        return -1
    tall = 0
    for k in range(tmask.shape[0]):
        tall |= tmask[k]
    ex, ey = fr[12], fr[13]
    if mask0 & tall and nbk >= 0:
        # joint angles where the tables will need them: the breaks and the range's ends
        for b in range(nbk):
            joint_angles(bv[b], dx, dy, ex, ey, bq[b])
        joint_angles(st_v[0, 0], dx, dy, ex, ey, st_q[0, 0])
        joint_angles(st_v[0, 1], dx, dy, ex, ey, st_q[0, 1])
    first = n_out
    ok = nbk >= 0
    if ok:
        st_u[0, 0], st_u[0, 1] = lo, hi
        st_mask[0] = mask0
        top = 1
    else:
        top = 0  # cannot happen inside a reachable stretch; stay safe
    while top > 0:
        top -= 1
        ua, ub, mask = st_u[top, 0], st_u[top, 1], st_mask[top]
        um = 0.5 * (ua + ub)
        ok, m0, m1, m2, m3, m4, m5, m6, m7 = pose_frames(
            fr, dx, dy, um, elbow_b, elbow_e, a, frames
        )
        if not ok:
            continue
        tables = mask & tall != 0
        if tables:
            # the pairs two links apart first, from their joint-space tables
            hit, mask = tables_status(
                mask, tmask, st_q, top, ua, ub, bq, breaks, nbk, tnodes, toff, tdom, qs, qb
            )
            if hit:
                continue
        new_pose(stamp)
        narrow = ub - ua <= TOL
        if narrow:
            motion[0] = -1.0  # decided at the middle
        else:
            stretch_motion(
                st_v, top, ua, ub, m0, m1, m2, m3, m4, m5, m6, m7, breaks, bv, nbk, motion
            )
        hit, unsure = groups_status(mask, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c)
        if hit or (narrow and unsure):
            continue  # an invalid stretch: the open range (if any) ends before it
        if witness:
            free_middle = unsure == 0
            if not free_middle:
                # the model itself at the middle, for the pairs still unsure (nothing moves)
                new_pose(stamp)
                motion[0] = -1.0
                hit, _ = groups_status(unsure, frames, stamp, xy, pi, pf, groups, rows, coef,
                                       motion, c)  # fmt: skip
                free_middle = not hit
            if free_middle:
                if n_out >= out.shape[0]:
                    return -1
                out[n_out, 0], out[n_out, 1] = ua, ub
                sure[n_out] = False
                return n_out + 1
        if unsure == 0:
            # a free stretch: extend the open range or start one
            joins = n_out > first and ua - out[n_out - 1, 1] <= MERGE_GAP
            gap = joins and ua > out[n_out - 1, 1]
            n_out = add_free(out, first, n_out, ua, ub)
            if n_out < 0:
                return -1
            if not joins:
                sure[n_out - 1] = True
            if narrow or gap:
                sure[n_out - 1] = False
            continue
        if top + 2 > st_u.shape[0]:
            return -1
        if tables:
            # the halves' joint angles: the left one ends, the right one starts, at um
            mv[0], mv[1], mv[2], mv[3], mv[4], mv[5], mv[6], mv[7] = m0, m1, m2, m3, m4, m5, m6, m7
            st_q[top + 1, 0, :] = st_q[top, 0, :]
            joint_angles(mv, dx, dy, ex, ey, st_q[top + 1, 1])
            st_q[top, 0, :] = st_q[top + 1, 1, :]
        split_stretch(st_u, st_v, top, ua, um, ub, m0, m1, m2, m3, m4, m5, m6, m7)
        st_mask[top + 1] = unsure
        st_mask[top] = unsure
        top += 2
    return n_out
