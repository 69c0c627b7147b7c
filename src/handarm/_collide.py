"""Numba kernels of the printed-link collision model (see ``handarm.collision``).

Pieces are slab stadiums in the frame of a joint. Placing the arm gives each frame an
orientation and an origin in its plane's 2D coordinates:

* base plane: world (x, y); the slab is along world z;
* tip plane: (sigma, v), sigma along L's direction d from a point F of L (``sigma4`` is joint
  4's sigma), v vertical; the slab is along the joint axles, whose local z is -n, with
  n = (-d_y, d_x) the horizontal normal of the tip plane.

A base piece and a tip piece are compared in (s, t) = ((X - F).d, (X - F).n) for the base
piece and (sigma, v) for the tip piece: see ``_cross_collide``. Every test takes a growth
added to the pieces' radii (negative shrinks): with the growth set to how far the pieces can
move, the same test proves that a pair stays apart or stays in contact over a stretch of
motion (``handarm.ik._printed``). A bounding sphere per piece answers far pairs first.

Data (see ``handarm.collision.Envelopes``), passed as separate arrays because numba passes a
tuple of arrays by value with a reference count per member, which dominated the cost:

* ``pi`` (n, 4) int: link, frame (0 proximal, 1 distal), plane (0 base, 1 tip), and 1 if
  the piece slides along its own segment when l3 slides along L (``handarm.collision``);
* ``pf`` (n, 8) float: segment x0, y0, x1, y1 in the frame, radius, slab z0, z1, and the
  radius of the bounding sphere;
* ``groups`` (g, 4), ``rows`` (m, 2), ``lp_groups`` (15, 2): which piece pairs to test;
* a placement: ``frames`` (N_FRAMES, 4), each slot's (cos, sin, ox, oy) and last row
  (dx, dy, fx, fy); ``xy`` (n, PLACED) placed pieces; ``stamp`` (n + 1,): a piece is placed
  for the current pose when ``stamp[i] == stamp[n]``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

JIT = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}
#: For the small helpers of ``groups_status`` that take arrays: numba counts a reference up
#: and down for every array argument of every call it does not inline, and those counts
#: were a fifth of the time of counting solutions under the printed-link model.
INLINE = {**JIT, "inline": "always"}

#: Frame slots: (link, frame) -> slot 2 * link + frame; l6 (one frame) is slot 12; row 13
#: holds L's direction and the origin F of sigma.
N_FRAMES = 14
#: Columns of a placed piece: segment ends in its plane (4), bounding-sphere centre (3), how
#: far it can move (1), how far it slides along its own segment and the unit direction of
#: that slide (3), how far it can move relative to l3 (1, l2 and l4 only: see ``REL``).
PLACED = 12
#: Column of a placed piece's motion relative to l3. l2 turns about joint 3 and l4 about
#: joint 4, and both joints slide along L with l3 by the same amount: seen from l3, which
#: only slides, a piece of l2 or l4 moves by its turn alone. The model is unchanged when
#: both pieces of a pair slide together along L, so the pair (l2, l4) is tested with these
#: motions (their slide cancels), and every other pair with the pieces' motions in space.
REL = 11


@nb.njit(**JIT)
def _slot(out, k, c, s, ox, oy):
    out[k, 0], out[k, 1], out[k, 2], out[k, 3] = c, s, ox, oy


@nb.njit(**JIT)
def place_frames(q, a, sigma4, out):
    """Orientation and origin of every link frame from joint angles q (see module doc).

    Joint 4 sits at ``sigma4`` along L.
    """
    t1 = q[0]
    t2 = t1 + q[1]
    t3 = t2 + q[2]
    c1, s1 = math.cos(t1), math.sin(t1)
    c2, s2 = math.cos(t2), math.sin(t2)
    c3, s3 = math.cos(t3), math.sin(t3)
    j2x, j2y = a[1] * c1, a[1] * s1
    j3x, j3y = j2x + a[2] * c2, j2y + a[2] * s2
    j4x, j4y = j3x + a[3] * c3, j3y + a[3] * s3
    sa4 = q[3]
    sa5 = sa4 + q[4]
    sa6 = sa5 + q[5]
    c4, s4 = math.cos(sa4), math.sin(sa4)
    c5, s5 = math.cos(sa5), math.sin(sa5)
    c6, s6 = math.cos(sa6), math.sin(sa6)
    j5s, j5z = sigma4 + a[4] * c4, a[4] * s4
    j6s, j6z = j5s + a[5] * c5, j5z + a[5] * s5
    set_frames(
        out,
        j2x,
        j2y,
        c1,
        s1,
        c2,
        s2,
        j3x,
        j3y,
        c3,
        s3,
        j4x - sigma4 * c3,
        j4y - sigma4 * s3,
        sigma4,
        j5s,
        j5z,
        c4,
        s4,
        c5,
        s5,
        j6s,
        j6z,
        c6,
        s6,
    )


@nb.njit(**JIT)
def set_frames(
    out,
    j2x,
    j2y,
    c1,
    s1,
    c2,
    s2,
    j3x,
    j3y,
    dx,
    dy,
    fx,
    fy,
    sigma4,
    j5s,
    j5z,
    c4,
    s4,
    c5,
    s5,
    j6s,
    j6z,
    c6,
    s6,
):
    """Fill the frame slots from joint positions and link directions (see module doc)."""
    _slot(out, 0, 1.0, 0.0, 0.0, 0.0)  # l0
    _slot(out, 1, 1.0, 0.0, 0.0, 0.0)  # unused: l0 has one frame
    _slot(out, 2, c1, s1, 0.0, 0.0)  # l1 prox
    _slot(out, 3, c1, s1, j2x, j2y)  # l1 dist
    _slot(out, 4, c2, s2, j2x, j2y)  # l2 prox
    _slot(out, 5, c2, s2, j3x, j3y)  # l2 dist
    _slot(out, 6, dx, dy, j3x, j3y)  # l3 prox
    _slot(out, 7, 1.0, 0.0, sigma4, 0.0)  # l3 dist (tip plane)
    _slot(out, 8, c4, s4, sigma4, 0.0)  # l4 prox
    _slot(out, 9, c4, s4, j5s, j5z)  # l4 dist
    _slot(out, 10, c5, s5, j5s, j5z)  # l5 prox
    _slot(out, 11, c5, s5, j6s, j6z)  # l5 dist
    _slot(out, 12, c6, s6, j6s, j6z)  # l6
    _slot(out, 13, dx, dy, fx, fy)


@nb.njit(**JIT)
def new_pose(stamp):
    """Pieces are placed again, on demand, for the pose just set in the frames."""
    stamp[stamp.shape[0] - 1] += 1


@nb.njit(**JIT)
def _placed(c, s, ox, oy, sx0, sy0, sx1, sy1, z0, z1, plane, dx, dy, fx, fy):
    """Segment ends and bounding-sphere centre of a piece in a frame (cos, sin, origin)."""
    x0 = ox + c * sx0 - s * sy0
    y0 = oy + s * sx0 + c * sy0
    x1 = ox + c * sx1 - s * sy1
    y1 = oy + s * sx1 + c * sy1
    mx, my, mw = 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1)
    if plane == 0:
        return x0, y0, x1, y1, mx, my, mw
    # sigma, v in the tip plane; local z is -n = (dy, -dx)
    return x0, y0, x1, y1, fx + mx * dx + mw * dy, fy + mx * dy - mw * dx, my


@nb.njit(**INLINE)
def place_piece(k, frames, pi, pf, xy):
    """Place piece k for the pose in ``frames``: its segment and sphere centre into xy[k].

    Returns the piece's frame slot.
    """
    slot = 12 if pi[k, 0] == 6 else 2 * pi[k, 0] + pi[k, 1]
    x0, y0, x1, y1, cx, cy, cz = _placed(
        frames[slot, 0], frames[slot, 1], frames[slot, 2], frames[slot, 3],
        pf[k, 0], pf[k, 1], pf[k, 2], pf[k, 3], pf[k, 5], pf[k, 6], pi[k, 2],
        frames[13, 0], frames[13, 1], frames[13, 2], frames[13, 3],
    )  # fmt: skip
    xy[k, 0], xy[k, 1], xy[k, 2], xy[k, 3] = x0, y0, x1, y1
    xy[k, 4], xy[k, 5], xy[k, 6] = cx, cy, cz
    return slot


@nb.njit(**JIT)
def _point_segment2(px, py, ax, ay, bx, by):
    """Squared distance from a point to a closed segment."""
    dx, dy = bx - ax, by - ay
    den = dx * dx + dy * dy
    t = 0.0
    if den > 0.0:
        t = ((px - ax) * dx + (py - ay) * dy) / den
        t = min(1.0, max(0.0, t))
    ex, ey = px - (ax + t * dx), py - (ay + t * dy)
    return ex * ex + ey * ey


@nb.njit(**JIT)
def segment_distance2(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y):
    """Squared distance between two closed segments (0 when they cross).

    Squared, so that the model's test (closer than a reach) takes no square root.
    """
    d1 = (b1x - b0x) * (a0y - b0y) - (b1y - b0y) * (a0x - b0x)
    d2 = (b1x - b0x) * (a1y - b0y) - (b1y - b0y) * (a1x - b0x)
    d3 = (a1x - a0x) * (b0y - a0y) - (a1y - a0y) * (b0x - a0x)
    d4 = (a1x - a0x) * (b1y - a0y) - (a1y - a0y) * (b1x - a0x)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and (
        (d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)
    ):
        return 0.0
    d = _point_segment2(a0x, a0y, b0x, b0y, b1x, b1y)
    d = min(d, _point_segment2(a1x, a1y, b0x, b0y, b1x, b1y))
    d = min(d, _point_segment2(b0x, b0y, a0x, a0y, a1x, a1y))
    return min(d, _point_segment2(b1x, b1y, a0x, a0y, a1x, a1y))


@nb.njit(**JIT)
def _clip(s0, w0, s1, w1, lo, hi):
    """s-extent of segment (s0, w0)-(s1, w1) where lo <= w <= hi; (inf, -inf) if empty."""
    ta, tb = 0.0, 1.0
    dw = w1 - w0
    if dw == 0.0:
        if w0 < lo or w0 > hi:
            return math.inf, -math.inf
    else:
        u0, u1 = (lo - w0) / dw, (hi - w0) / dw
        if u0 > u1:
            u0, u1 = u1, u0
        ta, tb = max(ta, u0), min(tb, u1)
        if ta > tb:
            return math.inf, -math.inf
    sa, sb = s0 + ta * (s1 - s0), s0 + tb * (s1 - s0)
    return min(sa, sb), max(sa, sb)


@nb.njit(**JIT)
def _cross_collide(
    bx0, by0, bx1, by1, rb, bz0, bz1, ts0, tv0, ts1, tv1, rt, tz0, tz1, dx, dy, fx, fy, c
):
    """A base piece (x, y; slab bz0..bz1) against a tip piece ((sigma, v); slab tz0..tz1).

    The radii are already grown. Along L, the stretch of the base piece inside the tip
    piece's slab (its t range is [-tz1, -tz0], the slab being along local z = -n) and the
    stretch of the tip piece inside the base piece's slab, each grown by its radius, overlap.
    """
    if rb < -c or rt < -c:
        return False
    s0 = (bx0 - fx) * dx + (by0 - fy) * dy
    t0 = -(bx0 - fx) * dy + (by0 - fy) * dx
    s1 = (bx1 - fx) * dx + (by1 - fy) * dy
    t1 = -(bx1 - fx) * dy + (by1 - fy) * dx
    lo, hi = _clip(s0, t0, s1, t1, -tz1 - rb - c, -tz0 + rb + c)
    if lo > hi:
        return False
    b_lo, b_hi = lo - rb - 0.5 * c, hi + rb + 0.5 * c
    lo, hi = _clip(ts0, tv0, ts1, tv1, bz0 - rt - c, bz1 + rt + c)
    if lo > hi:
        return False
    t_lo, t_hi = lo - rt - 0.5 * c, hi + rt + 0.5 * c
    return b_lo <= b_hi and t_lo <= t_hi and b_lo <= t_hi and t_lo <= b_hi


@nb.njit(**JIT)
def _collide_placed(
    ax0, ay0, ax1, ay1, ra, az0, az1, pa, bx0, by0, bx1, by1, rb, bz0, bz1, pb, dx, dy, fx, fy, c
):
    """Whether two placed pieces (segment, grown radius, slab, plane) collide."""
    if pa == pb:
        reach = ra + rb + c
        if reach < 0.0:
            return False
        return segment_distance2(ax0, ay0, ax1, ay1, bx0, by0, bx1, by1) < reach * reach
    if pa == 0:
        return _cross_collide(
            ax0, ay0, ax1, ay1, ra, az0, az1, bx0, by0, bx1, by1, rb, bz0, bz1, dx, dy, fx, fy, c
        )
    return _cross_collide(
        bx0, by0, bx1, by1, rb, bz0, bz1, ax0, ay0, ax1, ay1, ra, az0, az1, dx, dy, fx, fy, c
    )


@nb.njit(**JIT)
def _apart(ax, ay, az, ra, bx, by, bz, rb):
    """Two spheres (centres, radii) are farther apart than their radii (a radius may be < 0)."""
    ex, ey, ez = ax - bx, ay - by, az - bz
    reach = ra + rb
    if reach < 0.0:
        return True
    return ex * ex + ey * ey + ez * ez > reach * reach


@nb.njit(**JIT)
def _cover_along(along, across):
    """Least-area stadium along one axis: (area, start, end, middle line).

    ``along``, ``across`` (n,): the points' coordinates along and across the axis. The segment
    runs on the middle line of the points' extent across it; its ends are searched on a 7 x 7
    grid (start in the lower half of the extent along, end in the upper half) refined three
    times.
    """
    n = along.shape[0]
    middle = 0.5 * (across.max() + across.min())
    lo, hi = along.min(), along.max()
    mid = 0.5 * (lo + hi)
    a0, a1, b0, b1 = lo, mid, mid, hi
    best, best_s0, best_s1 = math.inf, 0.0, 0.0
    # a point's squared distance from the segment [s0, s1] (s0 <= s1) on the middle line is
    # w2 across it, plus (u - s0)^2 before s0 or (u - s1)^2 beyond s1: the farthest is the
    # largest of the farthest before s0, the farthest beyond s1 and the largest w2 of all
    # (no point's w2 exceeds its own distance)
    w2 = np.empty(n)
    w2_max = 0.0
    for p in range(n):
        w = across[p] - middle
        w2[p] = w * w
        w2_max = max(w2_max, w2[p])
    starts, ends = np.empty(7), np.empty(7)
    before, beyond = np.empty(7), np.empty(7)
    for _ in range(3):
        top, t0, t1 = math.inf, a0, b1
        for i in range(7):
            starts[i] = a0 + i / 6.0 * (a1 - a0)
            ends[i] = b0 + i / 6.0 * (b1 - b0)
            r0 = r1 = 0.0
            for p in range(n):
                u = along[p]
                if u < starts[i]:
                    r0 = max(r0, (u - starts[i]) ** 2 + w2[p])
                if u > ends[i]:
                    r1 = max(r1, (u - ends[i]) ** 2 + w2[p])
            before[i], beyond[i] = r0, r1
        for i in range(7):
            for j in range(7):
                s0, s1 = starts[i], ends[j]
                r = math.sqrt(max(before[i], beyond[j], w2_max))
                area = 2.0 * r * (s1 - s0) + math.pi * r * r
                if area < top:
                    top, t0, t1 = area, s0, s1
        if top < best:
            best, best_s0, best_s1 = top, t0, t1
        h0, h1 = (a1 - a0) / 6.0, (b1 - b0) / 6.0
        a0, a1 = max(lo, t0 - h0), min(mid, t0 + h0)
        b0, b1 = max(mid, t1 - h1), min(hi, t1 + h1)
    return best, best_s0, best_s1, middle


@nb.njit(**JIT)
def stadium(pts):
    """A stadium containing the points (n, 2): (x0, y0, x1, y1, radius).

    See ``handarm.collision.stadium_cover``, which documents the search and calls this.
    """
    n = pts.shape[0]
    cx = 0.5 * (pts[:, 0].min() + pts[:, 0].max())
    cy = 0.5 * (pts[:, 1].min() + pts[:, 1].max())
    x = np.empty((n, 2))
    x[:, 0] = pts[:, 0] - cx
    x[:, 1] = pts[:, 1] - cy
    spread, near = 0.0, math.inf
    for p in range(n):
        dist = math.hypot(x[p, 0], x[p, 1])
        spread, near = max(spread, dist), min(near, dist)
    if spread == 0.0 or (n >= 12 and near > 0.98 * spread):
        return cx, cy, cx, cy, spread * (1.0 + 1e-12)
    # candidate axes: the principal axis and the four longest edges
    axes = np.empty((5, 2))
    axes[0] = np.linalg.eigh(x.T @ x)[1][:, 1]
    m = 1
    lengths = np.empty(n)
    for p in range(n):
        q = (p + 1) % n
        lengths[p] = math.hypot(pts[q, 0] - pts[p, 0], pts[q, 1] - pts[p, 1])
    order = np.argsort(-lengths, kind="mergesort")
    for i in order[:4]:
        if lengths[i] > 1e-9 * spread:
            q = (i + 1) % n
            axes[m, 0] = (pts[q, 0] - pts[i, 0]) / lengths[i]
            axes[m, 1] = (pts[q, 1] - pts[i, 1]) / lengths[i]
            m += 1
    best, best_k, best_s0, best_s1, best_mid = math.inf, 0, 0.0, 0.0, 0.0
    along, across = np.empty(n), np.empty(n)
    for k in range(m):
        ax, ay = axes[k, 0], axes[k, 1]
        for p in range(n):
            along[p] = ax * x[p, 0] + ay * x[p, 1]
            across[p] = -ay * x[p, 0] + ax * x[p, 1]
        area, s0, s1, middle = _cover_along(along, across)
        if area < best:
            best, best_k, best_s0, best_s1, best_mid = area, k, s0, s1, middle
    ax, ay = axes[best_k, 0], axes[best_k, 1]
    bx, by = cx - best_mid * ay, cy + best_mid * ax
    x0, y0 = bx + best_s0 * ax, by + best_s0 * ay
    x1, y1 = bx + best_s1 * ax, by + best_s1 * ay
    r2 = 0.0  # the radius: the farthest point from the segment
    for p in range(n):
        r2 = max(r2, _point_segment2(pts[p, 0], pts[p, 1], x0, y0, x1, y1))
    return x0, y0, x1, y1, math.sqrt(r2) * (1.0 + 1e-12) + 1e-12 * spread


@nb.njit(**INLINE)
def _moves(xy, i, col):
    """How far placed piece i (and its bounding sphere) can move: grow plus slide.

    ``col`` is 7 (in space) or ``REL`` (relative to l3: no slide).
    """
    if col == REL:
        return xy[i, REL]
    return xy[i, 7] + xy[i, 8]


@nb.njit(**INLINE)
def _swept(xy, pf, i, sgn, col):
    """Segment ends and radius of placed piece i over its motion: sgn 1 grown, -1 shrunk.

    Grown: the piece wherever it can be (a superset of every position); shrunk: inside the
    piece at every position. A piece that moves at most ``xy[i, 7]`` grows or shrinks its
    radius by that. A piece that slides along its own segment by at most ``e = xy[i, 8]``
    (l3 along L) sweeps exactly its segment lengthened by e at both ends; every position of
    it holds the segment shortened by e at both ends, or, when the segment is shorter than
    2 e, the disc at its middle with the radius shrunk by e minus half the length.
    """
    x0, y0, x1, y1 = xy[i, 0], xy[i, 1], xy[i, 2], xy[i, 3]
    if col == REL:
        return x0, y0, x1, y1, pf[i, 4] + sgn * xy[i, REL]
    r = pf[i, 4] + sgn * xy[i, 7]
    e = xy[i, 8]
    if e > 0.0:
        ux, uy = xy[i, 9], xy[i, 10]  # from end 0 towards end 1
        if sgn > 0.0:
            x0, y0, x1, y1 = x0 - e * ux, y0 - e * uy, x1 + e * ux, y1 + e * uy
        else:
            half = 0.5 * math.hypot(x1 - x0, y1 - y0)
            if half >= e:
                x0, y0, x1, y1 = x0 + e * ux, y0 + e * uy, x1 - e * ux, y1 - e * uy
            else:
                mx, my = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
                x0, y0, x1, y1 = mx, my, mx, my
                r -= e - half
    return x0, y0, x1, y1, r


@nb.njit(**INLINE)
def _contact(xy, pi, pf, i, j, sgn, dx, dy, fx, fy, c, col):
    """Whether placed pieces i, j are in contact, grown (sgn 1) or shrunk (-1) by their motion.

    The model's two tests: bounding spheres that overlap and pieces that meet (see
    ``_swept``; a bounding sphere moves with its piece, by at most grow + slide). ``col``:
    motions in space (7) or relative to l3 (``REL``).
    """
    gi = sgn * _moves(xy, i, col)
    gj = sgn * _moves(xy, j, col)
    if _apart(xy[i, 4], xy[i, 5], xy[i, 6], pf[i, 7] + gi,
              xy[j, 4], xy[j, 5], xy[j, 6], pf[j, 7] + gj + c):  # fmt: skip
        return False
    ax0, ay0, ax1, ay1, ra = _swept(xy, pf, i, sgn, col)
    bx0, by0, bx1, by1, rb = _swept(xy, pf, j, sgn, col)
    return _collide_placed(
        ax0, ay0, ax1, ay1, ra, pf[i, 5], pf[i, 6], pi[i, 2],
        bx0, by0, bx1, by1, rb, pf[j, 5], pf[j, 6], pi[j, 2],
        dx, dy, fx, fy, c,
    )  # fmt: skip


@nb.njit(**JIT)
def groups_status(mask, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c):
    """The groups of piece pairs in ``mask`` (bit g for group g), pieces grown by their motion.

    A piece moves at most ``grow = min(coef[i, 0] @ motion, coef[i, 1] @ motion)`` (see
    ``handarm.collision.motion_coefficients``; ``motion`` is None-like when ``motion[0] < 0``:
    nothing moves; l3's pieces along L slide instead, see ``_swept``). Returns (hit, unsure):
    ``hit`` when some pair, and its group's bounding pair, are in contact (``_contact``)
    with their pieces shrunk by ``grow`` (so the model finds contact wherever the pieces
    are within ``grow`` of where they are placed; the bounding pieces hold the pair's, so
    only their spheres are tested again), else
    ``unsure``, the mask of groups where some pair is in contact with its pieces grown but not
    shrunk; the other groups are free (on a hit, the second value is the bit of the group
    that hit: ``collides`` can test it first next time). With nothing moving this is the
    model itself. One function for every group: numba counts a reference for every array
    argument of every call, which would cost more than the geometry.
    """
    moving = motion[0] >= 0.0
    m0, m1, m2, m3, m4 = motion[0], motion[1], motion[2], motion[3], motion[4]
    n = stamp.shape[0] - 1
    now = stamp[n]
    dx, dy, fx, fy = frames[13, 0], frames[13, 1], frames[13, 2], frames[13, 3]
    unsure = 0
    for g in range(groups.shape[0]):
        if not (mask >> g) & 1:
            continue
        first = groups[g, 2] - 1  # row -1 of the group: its two bounding pieces
        single = groups[g, 2] == groups[g, 3]  # the group is that one pair
        col = REL if pi[groups[g, 0], 0] == 2 and pi[groups[g, 1], 0] == 4 else 7
        g_unsure = False
        for r in range(first, groups[g, 3]):
            if r == first:
                i, j = groups[g, 0], groups[g, 1]
            else:
                i, j = rows[r, 0], rows[r, 1]
            for k in (i, j):
                if stamp[k] != now:
                    stamp[k] = now
                    slot = place_piece(k, frames, pi, pf, xy)
                    grow, slide, rel = 0.0, 0.0, 0.0
                    if moving and pi[k, 3] == 1:
                        # l3 moves by sliding along L, here along the segment: exactly
                        slide = m0
                        ux, uy = frames[slot, 0], frames[slot, 1]
                        if pf[k, 2] < pf[k, 0]:
                            ux, uy = -ux, -uy
                        xy[k, 9], xy[k, 10] = ux, uy
                    elif moving:
                        g0 = coef[k, 0, 0] * m0 + coef[k, 0, 1] * m1 + coef[k, 0, 2] * m2
                        g0 += coef[k, 0, 3] * m3 + coef[k, 0, 4] * m4
                        g1 = coef[k, 1, 0] * m0 + coef[k, 1, 1] * m1 + coef[k, 1, 2] * m2
                        g1 += coef[k, 1, 3] * m3 + coef[k, 1, 4] * m4
                        grow = min(g0, g1)
                        if pi[k, 0] == 2 or pi[k, 0] == 4:
                            # the bound that moves the piece with the joint on L, less the slide
                            o = 0 if coef[k, 0, 0] > 0.0 else 1
                            rel = g0 if o == 0 else g1
                            rel -= coef[k, o, 0] * m0
                    xy[k, 7] = grow
                    xy[k, 8] = slide
                    xy[k, REL] = rel
            still = _moves(xy, i, col) == 0.0 and _moves(xy, j, col) == 0.0
            if g_unsure:
                # the group is unsure already: only a contact all along can change that
                # (shrunk contact implies grown contact, so the grown test is skipped)
                if not _contact(xy, pi, pf, i, j, 1.0 if still else -1.0, dx, dy, fx, fy, c, col):
                    continue
            else:
                if not _contact(xy, pi, pf, i, j, 1.0, dx, dy, fx, fy, c, col):
                    if r == first:
                        break
                    continue
                if r == first and not single:
                    continue  # the bounding pieces meet: look at the pieces
            if g_unsure or still or _contact(xy, pi, pf, i, j, -1.0, dx, dy, fx, fy, c, col):
                # contact all along, if the group's bounding pair (the model tests it first)
                # is in contact all along. Its pieces hold these two wherever they are, and
                # the pieces' test grows with the pieces, so its pieces meet all along: what
                # is left is its bounding spheres, shrunk by their motion. (Shrinking the
                # bounding pieces too never proved a contact held all along at a joint on a
                # bounding piece's segment, l1's hub on joint 1 say, whose piece turns:
                # stretches were halved down to TOL over a whole range.)
                bi, bj = groups[g, 0], groups[g, 1]
                gbi, gbj = _moves(xy, bi, col), _moves(xy, bj, col)
                if single or (gbi == 0.0 and gbj == 0.0):
                    return True, 1 << g
                if not _apart(xy[bi, 4], xy[bi, 5], xy[bi, 6], pf[bi, 7] - gbi,
                              xy[bj, 4], xy[bj, 5], xy[bj, 6], pf[bj, 7] - gbj + c):  # fmt: skip
                    return True, 1 << g
            g_unsure = True
        if g_unsure:
            unsure |= 1 << g
    return False, unsure


@nb.njit(**JIT)
def scratch(n_pieces):
    """(frames, xy, stamp, coef, motion) of one thread, for a pose that does not move."""
    return (
        np.zeros((N_FRAMES, 4)),
        np.empty((n_pieces, PLACED)),
        np.zeros(n_pieces + 1, np.int64),
        np.zeros((1, 2, 5)),
        -np.ones(5),
    )


@nb.njit(**JIT)
def colliding_link_pairs(
    q, a, pi, pf, groups, lp_groups, rows, c, frames, xy, stamp, coef, motion, out
):
    """Which of the 15 link pairs collide at q: ``out`` (15,) bool; returns how many."""
    place_frames(q, a, 0.0, frames)
    new_pose(stamp)
    n = 0
    for lp in range(15):
        mask = 0
        for g in range(lp_groups[lp, 0], lp_groups[lp, 1]):
            mask |= 1 << g
        hit, _ = groups_status(mask, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c)
        out[lp] = hit
        n += hit
    return n


@nb.njit(**JIT)
def collides(q, a, pi, pf, groups, rows, c, frames, xy, stamp, coef, motion, first):
    """Whether any link pair collides at q: (hit, the bit of the group that hit, else 0).

    The groups in the mask ``first`` are tested before the others, and the first hit ends
    the test; whether some group hits does not depend on the order. A search that creeps
    along a contact (``handarm.ik._nearest.slide``) asks about configurations that the same
    pair blocks, over and over: with that group first, the others are never placed.
    """
    place_frames(q, a, 0.0, frames)
    new_pose(stamp)
    every = (1 << groups.shape[0]) - 1
    first &= every
    if first:
        hit, which = groups_status(first, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c)
        if hit:
            return True, which
    return groups_status(every & ~first, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c)


@nb.njit(parallel=True, **JIT)
def colliding_many(Q, a, pi, pf, groups, lp_groups, rows, c, out):
    """colliding_link_pairs for every row of Q (N, 6) into out (N, 15), in parallel."""
    n = Q.shape[0]
    block = 256
    for b in nb.prange((n + block - 1) // block):
        colliding_rows(
            Q, a, pi, pf, groups, lp_groups, rows, c, out, b * block, min(n, (b + 1) * block)
        )


@nb.njit(**JIT)
def colliding_rows(Q, a, pi, pf, groups, lp_groups, rows, c, out, start, stop):
    """colliding_link_pairs for rows start..stop of Q, on this thread."""
    frames, xy, stamp, coef, motion = scratch(pi.shape[0])
    for i in range(start, stop):
        colliding_link_pairs(
            Q[i], a, pi, pf, groups, lp_groups, rows, c, frames, xy, stamp, coef, motion, out[i]
        )


@nb.njit(parallel=True, **JIT)
def free_many(Q, a, pi, pf, groups, rows, c, out):
    """out[i] = no link pair collides at Q[i], in parallel."""
    n = Q.shape[0]
    block = 256
    for b in nb.prange((n + block - 1) // block):
        free_rows(Q, a, pi, pf, groups, rows, c, out, b * block, min(n, (b + 1) * block))


@nb.njit(**JIT)
def free_rows(Q, a, pi, pf, groups, rows, c, out, start, stop):
    """out[i] = no link pair collides at Q[i], for rows start..stop, on this thread."""
    frames, xy, stamp, coef, motion = scratch(pi.shape[0])
    for i in range(start, stop):
        hit, _ = collides(Q[i], a, pi, pf, groups, rows, c, frames, xy, stamp, coef, motion, 0)
        out[i] = not hit
