"""Classification of the gaps between events: which tau of a canonical problem are valid."""

from __future__ import annotations

import math

import numba as nb

from handarm.ik._common import JIT, MAX_IV, MERGE_GAP, POINT_GAP, widened, wrap
from handarm.ik._events import ELBOW_NEG, ELBOW_POS, canonical_events
from handarm.kinematics import COLLINEAR_TOL


@nb.njit(**JIT)
def _cross(ox, oy, ax, ay, bx, by):
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


@nb.njit(**JIT)
def segments_touch(p1x, p1y, p2x, p2y, p3x, p3y, p4x, p4y):
    """Closed segments p1p2 and p3p4 share a point (same predicate as kinematics)."""
    len_a = math.sqrt((p2x - p1x) ** 2 + (p2y - p1y) ** 2)
    len_b = math.sqrt((p4x - p3x) ** 2 + (p4y - p3y) ** 2)
    grow = COLLINEAR_TOL * max(len_a, len_b)
    if min(p1x, p2x) - grow > max(p3x, p4x) or min(p3x, p4x) > max(p1x, p2x) + grow:
        return False
    if min(p1y, p2y) - grow > max(p3y, p4y) or min(p3y, p4y) > max(p1y, p2y) + grow:
        return False
    tol = COLLINEAR_TOL * len_a * len_b
    d1 = _snap(_cross(p3x, p3y, p4x, p4y, p1x, p1y), tol)
    d2 = _snap(_cross(p3x, p3y, p4x, p4y, p2x, p2y), tol)
    d3 = _snap(_cross(p1x, p1y, p2x, p2y, p3x, p3y), tol)
    d4 = _snap(_cross(p1x, p1y, p2x, p2y, p4x, p4y), tol)
    return d1 * d2 <= 0.0 and d3 * d4 <= 0.0


@nb.njit(**JIT)
def _snap(x, tol):
    return 0.0 if abs(x) <= tol else x


@nb.njit(**JIT)
def _angles(nx, ny, dx, dy, tau, elbow, b1, b2, psi):
    """(ok, qa, qb, qc) at tau on one elbow; ok is False outside the reach annulus."""
    px, py = nx + tau * dx, ny + tau * dy
    r2 = px * px + py * py
    cb = (r2 - b1 * b1 - b2 * b2) / (2.0 * b1 * b2)
    if cb > 1.0 or cb < -1.0:
        return False, 0.0, 0.0, 0.0
    qb = elbow * math.acos(cb)
    qa = wrap(math.atan2(py, px) - math.atan2(b2 * math.sin(qb), b1 + b2 * math.cos(qb)))
    qc = wrap(psi - qa - qb)  # psi = atan2(dy, dx), constant along L
    return True, qa, qb, qc


@nb.njit(**JIT)
def canonical_valid(nx, ny, dx, dy, tau, elbow, b0, b1, b2, b3, lim, psi, paper):
    """Whether the canonical configuration at tau on ``elbow`` is valid (psi = angle of d)."""
    ok, qa, qb, qc = _angles(nx, ny, dx, dy, tau, elbow, b1, b2, psi)
    if not ok:
        return False
    if qa < lim[0] or qa > lim[1] or qb < lim[2] or qb > lim[3] or qc < lim[4] or qc > lim[5]:
        return False
    if not paper:
        return True
    px, py = nx + tau * dx, ny + tau * dy
    qx, qy = px + b3 * dx, py + b3 * dy
    ax, ay = b1 * math.cos(qa), b1 * math.sin(qa)
    if segments_touch(-b0, 0.0, 0.0, 0.0, ax, ay, px, py):
        return False
    if segments_touch(-b0, 0.0, 0.0, 0.0, px, py, qx, qy):
        return False
    if segments_touch(0.0, 0.0, ax, ay, px, py, qx, qy):
        return False
    return True


@nb.njit(**JIT)
def canonical_intervals(
    nx,
    ny,
    dx,
    dy,
    b0,
    b1,
    b2,
    b3,
    lim,
    lo,
    hi,
    allowed,
    n_allowed,
    iv,
    counts,
    buf,
    tags,
    ws,
    paper,
):
    """Valid tau intervals of a canonical problem within [lo, hi], per elbow.

    Fills ``iv[e, k] = (lo, hi)`` for elbow index e (0: qb >= 0, 1: qb < 0) and sets
    ``counts[e]``. Gaps that miss every interval of ``allowed[:n_allowed]`` (sorted, in
    tau; ``n_allowed < 0`` allows everything) are not classified: the other sub-problem
    has no solution there. Returns False if an elbow had more than MAX_IV intervals.
    """
    n = canonical_events(nx, ny, dx, dy, b0, b1, b2, b3, lim, lo, hi, buf, tags, ws, paper)
    psi = math.atan2(dy, dx)
    counts[0] = 0
    counts[1] = 0
    complete = True
    for e in range(2):
        elbow = 1.0 if e == 0 else -1.0
        other = ELBOW_NEG if e == 0 else ELBOW_POS
        open_ = False
        j = 0
        i1 = 0
        while i1 < n - 1:
            # the gap from this event to the next one that concerns this elbow
            i0 = i1
            i1 += 1
            while i1 < n - 1 and tags[i1] == other:
                i1 += 1
            t0, t1 = buf[i0], buf[i1]
            if n_allowed >= 0:
                # (an allowed range that only touches the gap may meet it in one point)
                while j < n_allowed and allowed[j, 1] < t0 - POINT_GAP:
                    j += 1
                if j >= n_allowed or allowed[j, 0] > t1 + POINT_GAP:
                    open_ = False
                    continue
            if t1 - t0 <= POINT_GAP:
                # two events at one tau, two joints at their limits at once (an event of
                # each sub-problem's three): the valid set may be that point alone, whose
                # limits hold to the events' rounding
                if i0 == 0 or i1 == n - 1:
                    continue  # the window's ends: the caller's stretch stops there
                ok = canonical_valid(
                    nx, ny, dx, dy, 0.5 * (t0 + t1), elbow, b0, b1, b2, b3, widened(lim), psi,
                    paper,
                )  # fmt: skip
                t0 = t1 = 0.5 * (t0 + t1)
            else:
                ok = canonical_valid(
                    nx, ny, dx, dy, 0.5 * (t0 + t1), elbow, b0, b1, b2, b3, lim, psi, paper
                )
            if ok and (open_ or (counts[e] > 0 and t0 - iv[e, counts[e] - 1, 1] <= MERGE_GAP)):
                # contiguous, or across a hole narrower than MERGE_GAP (a tangency)
                iv[e, counts[e] - 1, 1] = t1
                open_ = True
            elif ok:
                if counts[e] < MAX_IV:
                    iv[e, counts[e], 0] = t0
                    iv[e, counts[e], 1] = t1
                    counts[e] += 1
                    open_ = True
                else:
                    complete = False
            else:
                open_ = False
    return complete
