"""Numba kernels of the full 5-DoF problem: both canonical problems merged along L.

Both 3R sub-problems (base B, tip E) are solved as one *canonical* planar problem:

* a fixed link from H = (-b0, 0) to the joint O = (0, 0) (pointing along +x);
* a 2R chain O -> A (length b1, angle qa from +x) -> P (length b2, relative angle qb);
* P on the line L = {N + tau d}, |d| = 1, N the foot of the perpendicular from O (N.d = 0);
* the shared link l3 from P to Q = P + b3 d; qc = angle(d) - angle(AP), wrapped to (-pi, pi].

Validity: qa, qb, qc in their limits, and no touching of the closed segments
(HO, AP), (HO, PQ), (OA, PQ). The base problem is this with (b0..b3) = (a0..a3) and
(qa, qb, qc) = (q1, q2, q3). The tip problem, seen from the tool, is this with
(b0..b3) = (a6, a5, a4, a3) and (qa, qb, qc) = (-q6, -q5, -q4) after a rigid motion of the
tip plane that puts joint 6 at O and the tool point at H.

Along tau, validity can change only where some predicate changes truth value (the
*events*): a joint angle meets a limit or wraps through pi, P meets a reach circle, or
an endpoint of one segment of a checked pair touches the other segment (for closed
segments moving continuously these are the only ways contact begins or ends). Every
event is the root of a polynomial in tau of degree <= 6, solved exactly below; each gap
between consecutive events is then classified by one interior point.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm.ik._classify import canonical_intervals, canonical_valid
from handarm.ik._common import (
    INLINE,
    JIT,
    LIMIT_SNAP,
    MAX_CAND,
    MAX_IV,
    PI,
    POINT_GAP,
    VERTICAL_EPS,
    WS_SIZE,
    horizontal,
    widened,
    wrap,
)
from handarm.ik._events import reach_half_width
from handarm.ik._printed import configuration as _configuration
from handarm.ik._printed import free_at, printed_ranges, printed_scratch

#: Length of the array ``_frames`` fills.
FRAMES_SIZE = 14


@nb.njit(**JIT)
def _frames(p, e, dx, dy, a, out):
    """Canonical frames of both sub-problems for the line direction (dx, dy).

    Returns (base N, base offset, tip N, tip direction, tip offset) packed in an array::

        [bnx, bny, bofs, tnx, tny, tdx, tdy, tofs, cos g, sin g, t6u, t6v, eu, ev]

    with u = tau_B + bofs for the base and u = -(tau_E + tofs) for the tip; then the tip
    canonical frame: a point X_c of it is T6 + R(g) X_c in the tip plane (U along d from
    F = (p_x, p_y), V vertical), T6 = (t6u, t6v) is joint 6, and (eu, ev) the tool
    direction in that plane.
    """
    fx, fy = p[0], p[1]
    fd = fx * dx + fy * dy
    out[0], out[1] = fx - fd * dx, fy - fd * dy
    out[2] = a[3] - fd  # P = J3 = F + (u - a3) d = N + (u - a3 + F.d) d
    # tip plane (U along d, V along z), origin at F
    eu = e[0] * dx + e[1] * dy
    ev = e[2]
    en = math.sqrt(eu * eu + ev * ev)
    eu, ev = eu / en, ev / en
    t6u, t6v = -a[6] * eu, p[2] - a[6] * ev  # joint 6
    gamma = math.atan2(ev, eu) + PI  # direction from the tool to joint 6
    cg, sg = math.cos(-gamma), math.sin(-gamma)
    # F - T6 and the direction -U, rotated by -gamma
    fcx, fcy = cg * (-t6u) - sg * (-t6v), sg * (-t6u) + cg * (-t6v)
    tdx, tdy = -cg, -sg
    fcd = fcx * tdx + fcy * tdy
    out[3], out[4] = fcx - fcd * tdx, fcy - fcd * tdy
    out[5], out[6] = tdx, tdy
    out[7] = -fcd  # P = J4 = F_c - u d_c = N_c + (F_c.d_c - u) d_c
    out[8], out[9] = cg, -sg  # R(g) undoes R(-g)
    out[10], out[11] = t6u, t6v
    out[12], out[13] = eu, ev


@nb.njit(**JIT)
def _limits(lower, upper, lb, lt):
    for k in range(3):
        lb[2 * k], lb[2 * k + 1] = lower[k], upper[k]
        # tip: (qa, qb, qc) = (-q6, -q5, -q4)
        lt[2 * k], lt[2 * k + 1] = -upper[5 - k], -lower[5 - k]


@nb.njit(**JIT)
def configuration_at_u(p, e, dx, dy, u, elbow_b, elbow_e, a, out):
    """Joint angles at u on the branch (elbows as +1/-1); returns False if unreachable."""
    fr = np.empty(FRAMES_SIZE)
    _frames(p, e, dx, dy, a, fr)
    return _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, out)


@nb.njit(**JIT)
def _union_to_tip(iv_b, cnt_b, ofs_b, ofs_t, out):
    """Union of both base elbows' intervals, mapped to tip tau (ascending); returns count."""
    n = 0
    i = 0
    j = 0
    # merge the two sorted lists by their lower ends
    while i < cnt_b[0] or j < cnt_b[1]:
        if j >= cnt_b[1] or (i < cnt_b[0] and iv_b[0, i, 0] <= iv_b[1, j, 0]):
            lo, hi = iv_b[0, i, 0], iv_b[0, i, 1]
            i += 1
        else:
            lo, hi = iv_b[1, j, 0], iv_b[1, j, 1]
            j += 1
        if n > 0 and lo <= out[n - 1, 1]:
            out[n - 1, 1] = max(out[n - 1, 1], hi)
        else:
            out[n, 0], out[n, 1] = lo, hi
            n += 1
    # u = tau_B + ofs_b and tau_E = -u - ofs_t reverse the order
    for k in range(n):
        lo, hi = out[k, 0], out[k, 1]
        out[k, 0], out[k, 1] = -(hi + ofs_b) - ofs_t, -(lo + ofs_b) - ofs_t
    for k in range(n // 2):
        for c in range(2):
            tmp = out[k, c]
            out[k, c] = out[n - 1 - k, c]
            out[n - 1 - k, c] = tmp
    return n


VERTICAL_STEP = math.radians(0.5)


#: Stretches of one range that the printed-link model can leave (per range and branch).
MAX_SUB = 64


@nb.njit(**JIT)
def _workspace(lower, upper, n_pieces):
    """Scratch space of one solving thread: limits, then arrays reused for every target."""
    lb = np.empty(6)
    lt = np.empty(6)
    _limits(lower, upper, lb, lt)
    return (
        lb,
        lt,
        np.empty((2, MAX_IV, 2)),
        np.empty((2, MAX_IV, 2)),
        np.zeros(2, np.int64),
        np.zeros(2, np.int64),
        np.empty((2 * MAX_IV, 2)),
        np.empty(6),
        np.empty(FRAMES_SIZE),
        np.empty(MAX_CAND),
        np.empty(MAX_CAND, np.int8),
        np.empty(WS_SIZE),
        np.empty((MAX_SUB, 2)),
        np.empty(MAX_SUB, np.bool_),
        printed_scratch(n_pieces),
    )


@nb.njit(**JIT)
def solve_target(p, e, psi_vertical, a, lower, upper, out_q, out_br, out_iv, psi_used, mdl):
    """Every 5-DoF solution range of one target.

    Returns the number of ranges found (rows beyond ``out_q.shape[0]`` are not stored),
    or -1 if an internal interval buffer overflowed. When ``e`` is vertical, L may take
    any azimuth: the first azimuth with a solution, going out from ``psi_vertical`` in
    steps of VERTICAL_STEP, is used. The azimuth of d = +1 goes to ``psi_used[0]``.

    ``mdl`` is the collision model, one flat tuple (numba's parallel loops take no nested
    tuples): paper, then the envelopes as ``handarm.collision.kernel_env`` gives them
    (``mdl[1:7]``: pi, pf, groups, lp_groups, rows, clearance), their motion coefficients,
    the groups' far thresholds (``handarm.collision.far_thresholds``), the joint-space
    tables (``mdl[9:13]``, ``handarm.collision.kernel_tables``), the narrowest range
    counted (``mdl[-1]``).
    """
    work = _workspace(lower, upper, mdl[1].shape[0])
    n = _solve_any_azimuth(p, e, psi_vertical, a, out_q, out_br, out_iv, psi_used, work, mdl, False)
    for i in range(min(n, out_q.shape[0])):
        snap_to_limits(out_q[i], lower, upper)
    return n


@nb.njit(**INLINE)
def _solve_any_azimuth(p, e, psi_vertical, a, out_q, out_br, out_iv, psi_used, work, mdl, first):
    """``_solve_target`` at e's azimuth, or at the first that has a solution if e is vertical.

    ``first``: stop at the first solution range found (returns 1 if there is one).
    """
    if horizontal(e[0], e[1]) >= VERTICAL_EPS:
        psi_used[0] = math.atan2(e[1], e[0])
        return _solve_target(p, e, 0.0, a, out_q, out_br, out_iv, work, mdl, first)
    # d = +-(cos psi, sin psi) covers psi and psi + pi: a quarter turn each way suffices
    n_steps = int(math.ceil(0.5 * PI / VERTICAL_STEP))
    for k in range(2 * n_steps + 1):
        off = ((k + 1) // 2) * VERTICAL_STEP * (1.0 if k % 2 == 1 else -1.0)
        psi = wrap(psi_vertical + off)
        n = _solve_target(p, e, psi, a, out_q, out_br, out_iv, work, mdl, first)
        if n != 0:
            psi_used[0] = psi
            return n
    psi_used[0] = psi_vertical
    return 0


@nb.njit(**JIT)
def _valid_at(fr, dx, dy, u, elbow_b, elbow_e, a, lb, lt, paper):
    """Both sub-problems valid at u (the classification's own predicate)."""
    return canonical_valid(
        fr[0],
        fr[1],
        dx,
        dy,
        u - fr[2],
        elbow_b,
        a[0],
        a[1],
        a[2],
        a[3],
        lb,
        math.atan2(dy, dx),
        paper,
    ) and canonical_valid(
        fr[3],
        fr[4],
        fr[5],
        fr[6],
        -u - fr[7],
        -elbow_e,
        a[6],
        a[5],
        a[4],
        a[3],
        lt,
        math.atan2(fr[6], fr[5]),
        paper,
    )


@nb.njit(**JIT)
def snap_to_limits(q, lower, upper):
    """Angles of q (6,) within ``LIMIT_SNAP`` beyond a limit set onto it, in place.

    The range ends are exact, but the angles at them are computed by trigonometry and
    came out up to a few ulp beyond the limit the range stops at: such a configuration
    failed ``is_valid`` (a zero-length range's only one, in 1 of the hostile checks).
    """
    for k in range(6):
        if upper[k] < q[k] <= upper[k] + LIMIT_SNAP:
            q[k] = upper[k]
        elif lower[k] - LIMIT_SNAP <= q[k] < lower[k]:
            q[k] = lower[k]


@nb.njit(**JIT)
def _representative(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, lb, lt, q, mdl, sc, sure):
    """Configuration at the range's midpoint into q; returns False if none is usable.

    Where a constraint only touches its bound inside a range (a tangency: valid on both
    sides), the midpoint can sit on it and fail by one rounding step; then the nearest of
    the points at 1/4, 3/4, 1/8, 7/8, ... of the range that passes is used. ``sure``: the
    printed-link model holds on the whole range (``printed_ranges``), so only the limits
    are checked.
    """
    if hi - lo <= POINT_GAP:
        # a single configuration between two limits: they hold to their rounding (the
        # caller snaps the angles onto them)
        lb, lt = widened(lb), widened(lt)
    frac = 0.5
    step = 0.25
    for attempt in range(13):
        u = lo + frac * (hi - lo)
        if _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, q) and _valid_at(
            fr, dx, dy, u, elbow_b, elbow_e, a, lb, lt, mdl[0]
        ):
            if mdl[0] or sure or free_at(q, u, a, mdl[1:7], mdl[7], sc[3], sc[4], sc[5], sc[6]):
                return True
        # 0.5, 0.25, 0.75, 0.125, 0.875, ...
        if attempt % 2 == 0:
            frac = 0.5 - step
        else:
            frac = 0.5 + step
            step *= 0.5
    return False


@nb.njit(**JIT)
def _valid_middle(fr, dx, dy, u, elbow_b, elbow_e, a, lb, lt, q, mdl, sc):
    """The configuration at u (into q) keeps the limits and the printed-link model.

    Strictly inside a stretch where the limits hold, a configuration the model finds free
    has free neighbours (its test is strict), so the target has a range of positive width.
    """
    return (
        _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, q)
        and _valid_at(fr, dx, dy, u, elbow_b, elbow_e, a, lb, lt, False)
        and free_at(q, u, a, mdl[1:7], mdl[7], sc[3], sc[4], sc[5], sc[6])
    )


@nb.njit(**JIT)
def _near_groups(p, e, a, far):
    """Mask of the groups of piece pairs that can meet for this target (see ``far_thresholds``).

    Groups between l0..l2 and l4..l6 whose threshold joint 6 lies beyond are left out.
    """
    x, y, z = p[0] - a[6] * e[0], p[1] - a[6] * e[1], p[2] - a[6] * e[2]
    dist = math.sqrt(x * x + y * y + z * z)
    mask = 0
    for g in range(far.shape[0]):
        if not dist > far[g]:
            mask |= 1 << g
    return mask


@nb.njit(**INLINE)
def _line_window(p, e, dx, dy, a, fr):
    """Frames for L's direction (dx, dy) into ``fr``, and where both chains reach L.

    Returns (u_lo, u_hi), the u-range where both reach (tau_B = u - fr[2], tau_E = -u -
    fr[7]); no solution outside it, none at all when u_lo >= u_hi.
    """
    _frames(p, e, dx, dy, a, fr)
    wb = reach_half_width(fr[0], fr[1], a[1], a[2])
    wt = reach_half_width(fr[3], fr[4], a[5], a[4])
    if wb < 0.0 or wt < 0.0:
        return 1.0, 0.0
    return max(-wb + fr[2], -wt - fr[7]), min(wb + fr[2], wt - fr[7])


@nb.njit(**INLINE)
def may_reach(p, ex, ey, ez, a):
    """False if both chains cannot reach L for either sign of its direction.

    The direction e = (ex, ey, ez) need not be a unit vector. The first test of whether a
    direction is solvable, made with nothing but p, e and a: most directions the searches
    of degradation try fail it (all of those near level 3's reach boundaries, and whole
    circles and spheres of them for a level-2 target). Call it in the loop itself, before
    ``_has_range`` or ``handarm.ik._search.solvable``: numba copies the scratch tuples those
    take into every call, even inlined. A direction it rules out costs 0.016 us; through
    ``_line_window``'s frames (trigonometry) it cost 0.14 us, and through the tuples 0.36.

    It is ``_line_window``'s test for both signs of d = (e_x, e_y) / |(e_x, e_y)|, in closed
    form: the base reaches L where it passes within a1 + a2 of joint 1 (|N|, the same for
    both signs), over tau_B in [-wb, wb] with u = tau_B + a3 - F.d (F = (p_x, p_y)); the tip
    reaches L, which lies at height 0 of the tip plane, where joint 6 (height p_z - a6 e_z,
    at -a6 e_u along it, e_u = e.d) lies within a4 + a5 of it, over u in [-wt - a6 e_u,
    wt - a6 e_u]. Flipping d flips F.d and e_u. Rounding apart, the same answer as
    ``_line_window``'s (tested), without its trigonometry. True for a vertical e, whose L
    may take any azimuth.
    """
    hn = math.sqrt(ex * ex + ey * ey)
    en = math.sqrt(hn * hn + ez * ez)
    if hn < VERTICAL_EPS * en * (1.0 + 1e-9):
        return True  # vertical for the solver (its e normalised), or a hair from it: no test
    dx, dy = ex / hn, ey / hn
    fd = p[0] * dx + p[1] * dy
    nx, ny = p[0] - fd * dx, p[1] - fd * dy
    rb = a[1] + a[2]
    wb2 = rb * rb - (nx * nx + ny * ny)
    t6v = p[2] - a[6] * ez / en
    rt = a[4] + a[5]
    wt2 = rt * rt - t6v * t6v
    if wb2 <= 0.0 or wt2 <= 0.0:
        return False
    wb, wt = math.sqrt(wb2), math.sqrt(wt2)
    for s in range(2):
        sgn = 1.0 if s == 0 else -1.0
        base = a[3] - sgn * fd  # u at tau_B = 0
        tip = -a[6] * sgn * hn / en  # u at the tip's chord middle
        if max(base - wb, tip - wt) < min(base + wb, tip + wt):
            return True
    return False


@nb.njit(**JIT)
def reaching_rows(p, dirs, a, out):
    """``out[i]``: ``may_reach`` of the direction ``dirs[i]`` at p."""
    for i in range(dirs.shape[0]):
        out[i] = may_reach(p, dirs[i, 0], dirs[i, 1], dirs[i, 2], a)


@nb.njit(**JIT)
def _solve_target(p, e, psi_vertical, a, out_q, out_br, out_iv, work, mdl, first):
    lb, lt, iv_b, iv_t, cnt_b, cnt_t, allowed, q, fr, buf, tags, ws, sub, sure, sc = work
    paper = mdl[0]
    min_width = mdl[-1]
    cap = out_q.shape[0]
    mask = _near_groups(p, e, a, mdl[8])
    hx, hy = e[0], e[1]
    hn = horizontal(hx, hy)
    if hn < VERTICAL_EPS:
        hx, hy, hn = math.cos(psi_vertical), math.sin(psi_vertical), 1.0
    total = 0
    overflow = False
    for s in range(2):
        sgn = 1.0 if s == 0 else -1.0
        dx, dy = sgn * hx / hn, sgn * hy / hn
        u_lo, u_hi = _line_window(p, e, dx, dy, a, fr)
        if u_lo >= u_hi:
            continue
        ok1 = canonical_intervals(
            fr[0],
            fr[1],
            dx,
            dy,
            a[0],
            a[1],
            a[2],
            a[3],
            lb,
            u_lo - fr[2],
            u_hi - fr[2],
            allowed,
            -1,
            iv_b,
            cnt_b,
            buf,
            tags,
            ws,
            paper,
        )
        if cnt_b[0] + cnt_b[1] == 0:
            continue
        # where the base has a solution (either elbow), in tau_E, ascending
        n_al = _union_to_tip(iv_b, cnt_b, fr[2], fr[7], allowed)
        ok2 = canonical_intervals(
            fr[3],
            fr[4],
            fr[5],
            fr[6],
            a[6],
            a[5],
            a[4],
            a[3],
            lt,
            -u_hi - fr[7],
            -u_lo - fr[7],
            allowed,
            n_al,
            iv_t,
            cnt_t,
            buf,
            tags,
            ws,
            paper,
        )
        overflow = overflow or not (ok1 and ok2)
        for eb in range(2):
            for ee in range(2):
                # tip canonical elbow index ee: 0 is qb_c >= 0 (q5 <= 0), so the tip
                # branch sign is -1 for ee == 0.
                elbow_e = -1.0 if ee == 0 else 1.0
                i = 0
                j = 0
                while i < cnt_b[eb] and j < cnt_t[ee]:
                    b_lo = iv_b[eb, i, 0] + fr[2]
                    b_hi = iv_b[eb, i, 1] + fr[2]
                    t_lo = -(iv_t[ee, cnt_t[ee] - 1 - j, 1] + fr[7])
                    t_hi = -(iv_t[ee, cnt_t[ee] - 1 - j, 0] + fr[7])
                    lo = max(b_lo, t_lo)
                    hi = min(b_hi, t_hi)
                    if hi < lo <= hi + POINT_GAP:
                        # the base's range ends where the tip's starts (a joint of each at
                        # its limit at once): one configuration, which rounding of the two
                        # sub-problems' events put a hair to either side
                        lo = hi = 0.5 * (lo + hi)
                    if lo <= hi:
                        elbow_b = 1.0 if eb == 0 else -1.0
                        if first and not paper and min_width == 0.0:
                            # whether, not how many: a valid configuration at the middle
                            # settles it without certifying the stretch
                            um = 0.5 * (lo + hi)
                            if _valid_middle(
                                fr, dx, dy, um, elbow_b, elbow_e, a, lb, lt, q, mdl, sc
                            ):
                                return 1  # (``_has_range``, the one caller, keeps no row)
                        if paper:
                            sub[0, 0], sub[0, 1] = lo, hi
                            sure[0] = True
                            n_sub = 1
                        else:
                            n_sub = printed_ranges(
                                fr, dx, dy, lo, hi, elbow_b, elbow_e, a, mdl, sc, sub, 0, sure,
                                mask, first and min_width == 0.0,
                            )  # fmt: skip
                            if n_sub < 0:
                                overflow = True
                                n_sub = 0
                        for k_sub in range(n_sub):
                            r_lo, r_hi = sub[k_sub, 0], sub[k_sub, 1]
                            if r_hi - r_lo < min_width or not _representative(
                                fr,
                                dx,
                                dy,
                                r_lo,
                                r_hi,
                                elbow_b,
                                elbow_e,
                                a,
                                lb,
                                lt,
                                q,
                                mdl,
                                sc,
                                sure[k_sub],
                            ):
                                continue
                            if total < cap:
                                for k in range(6):
                                    out_q[total, k] = q[k]
                                out_br[total, 0] = int(sgn)
                                out_br[total, 1] = int(elbow_b)
                                out_br[total, 2] = int(elbow_e)
                                out_iv[total, 0] = r_lo
                                out_iv[total, 1] = r_hi
                            total += 1
                            if first:
                                return total
                    if b_hi < t_hi:
                        i += 1
                    else:
                        j += 1
    if overflow:
        return -1
    return total


@nb.njit(parallel=True, **JIT)
def solve_many(P, E, psi_vertical, a, lower, upper, out_q, out_br, out_iv, counts, psi_used, mdl):
    """solve_target over rows, in parallel; rows beyond capacity are counted, not stored.

    Rows go in blocks so that each block allocates its scratch space once.
    """
    n = P.shape[0]
    block = 256
    n_blocks = (n + block - 1) // block
    for b in nb.prange(n_blocks):
        work = _workspace(lower, upper, mdl[1].shape[0])
        for i in range(b * block, min(n, (b + 1) * block)):
            counts[i] = _solve_any_azimuth(
                P[i],
                E[i],
                psi_vertical[i],
                a,
                out_q[i],
                out_br[i],
                out_iv[i],
                psi_used[i : i + 1],
                work,
                mdl,
                False,
            )
            for r in range(min(max(counts[i], 0), out_q.shape[1])):
                snap_to_limits(out_q[i, r], lower, upper)
            # pad the unused rows here: the caller's arrays are left uninitialised
            for r in range(max(counts[i], 0), out_q.shape[1]):
                for c in range(6):
                    out_q[i, r, c] = np.nan
                for c in range(3):
                    out_br[i, r, c] = 0
                out_iv[i, r, 0] = np.nan
                out_iv[i, r, 1] = np.nan


@nb.njit(**JIT)
def configurations_along_u(p, e, dx, dy, us, elbow_b, elbow_e, a, out, ok):
    """configuration_at_u for many u of one branch."""
    fr = np.empty(FRAMES_SIZE)
    _frames(p, e, dx, dy, a, fr)
    for i in range(us.shape[0]):
        ok[i] = _configuration(fr, dx, dy, us[i], elbow_b, elbow_e, a, out[i])


@nb.njit(**JIT)
def _distance2(q, current):
    d = 0.0
    for j in range(6):
        d += (q[j] - current[j]) ** 2
    return d


@nb.njit(**JIT)
def nearest_along_u(p, e, dx, dy, lo, hi, elbow_b, elbow_e, a, current, samples, refine, out):
    """Four candidates for the point of the range [lo, hi] nearest to ``current``.

    The squared joint-space distance is sampled at ``samples`` points a hair inside the
    ends; the best sample is refined by ``refine`` golden-section steps between its
    neighbours (out to the end itself from an end sample). ``out[0]`` gets the best sample,
    ``out[1]`` the refined point, ``out[2]`` and ``out[3]`` the exact ends lo and hi (a
    joint at its limit, where a range ridden to its end stops); returns their squared
    distances (inf where unreachable).
    """
    fr = np.empty(FRAMES_SIZE)
    _frames(p, e, dx, dy, a, fr)
    q = np.empty(6)
    end_lo, end_hi = np.inf, np.inf
    if _configuration(fr, dx, dy, lo, elbow_b, elbow_e, a, out[2]):
        end_lo = _distance2(out[2], current)
    if _configuration(fr, dx, dy, hi, elbow_b, elbow_e, a, out[3]):
        end_hi = _distance2(out[3], current)
    margin = min(1e-7, 0.25 * (hi - lo))
    u0, u1 = lo + margin, hi - margin
    step = (u1 - u0) / (samples - 1) if samples > 1 else 0.0
    best, k = np.inf, -1
    for i in range(samples):
        if _configuration(fr, dx, dy, u0 + i * step, elbow_b, elbow_e, a, q):
            d = _distance2(q, current)
            if d < best:
                best, k = d, i
                out[0, :] = q
    if k < 0:
        return np.inf, np.inf, end_lo, end_hi
    # between the best sample's neighbours, out to the exact end for an end sample: near a
    # reach circle (a straight elbow) an angle grows like the root of the distance to the
    # end, so the hair the samples keep off it is a visible turn
    x0 = u0 + (k - 1) * step if k > 0 else lo
    x1 = u0 + (k + 1) * step if k < samples - 1 else hi
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    c, d = x1 - g * (x1 - x0), x0 + g * (x1 - x0)
    fc = _distance2(q, current) if _configuration(fr, dx, dy, c, elbow_b, elbow_e, a, q) else np.inf
    fd = _distance2(q, current) if _configuration(fr, dx, dy, d, elbow_b, elbow_e, a, q) else np.inf
    for _ in range(refine):
        if fc <= fd:
            x1, d, fd = d, c, fc
            c = x1 - g * (x1 - x0)
            ok = _configuration(fr, dx, dy, c, elbow_b, elbow_e, a, q)
            fc = _distance2(q, current) if ok else np.inf
        else:
            x0, c, fc = c, d, fd
            d = x0 + g * (x1 - x0)
            ok = _configuration(fr, dx, dy, d, elbow_b, elbow_e, a, q)
            fd = _distance2(q, current) if ok else np.inf
    if not _configuration(fr, dx, dy, c, elbow_b, elbow_e, a, out[1]):
        return best, np.inf, end_lo, end_hi
    return best, _distance2(out[1], current), end_lo, end_hi


@nb.njit(**JIT)
def nearest_in_ranges(p, e, dxs, dys, branches, intervals, a, current, samples, refine, out, dists):
    """``nearest_along_u`` of every range of a target, in one call (not one per range).

    Row i: line direction (dxs[i], dys[i]), branch signs ``branches[i]``, range
    ``intervals[i]``; its candidates go to rows 4i..4i+3 of ``out`` and their squared
    distances from ``current`` to ``dists``.
    """
    for i in range(dxs.shape[0]):
        d0, d1, d2, d3 = nearest_along_u(
            p, e, dxs[i], dys[i], intervals[i, 0], intervals[i, 1], float(branches[i, 1]),
            float(branches[i, 2]), a, current, samples, refine, out[4 * i : 4 * i + 4],
        )  # fmt: skip
        dists[4 * i], dists[4 * i + 1], dists[4 * i + 2], dists[4 * i + 3] = d0, d1, d2, d3


#: Targets per parallel task of ``count_many``.
COUNT_BLOCK = 256
_COUNT_CAP = 1  # the counts keep no solution rows; the count is exact regardless


@nb.njit(**JIT)
def _count_rows(P, E, psi_vertical, a, lower, upper, counts, mdl, start, stop):
    """Number of solution ranges of targets ``start..stop``, on this thread."""
    work = _workspace(lower, upper, mdl[1].shape[0])
    q = np.empty((_COUNT_CAP, 6))
    br = np.empty((_COUNT_CAP, 3), np.int8)
    iv = np.empty((_COUNT_CAP, 2))
    used = np.empty(1)
    for i in range(start, stop):
        counts[i] = _solve_any_azimuth(
            P[i], E[i], psi_vertical[i], a, q, br, iv, used, work, mdl, False
        )


@nb.njit(parallel=True, **JIT)
def count_many(P, E, psi_vertical, a, lower, upper, counts, mdl):
    """Number of solution ranges of each target, without storing them (workspace maps)."""
    n = P.shape[0]
    block = COUNT_BLOCK
    n_blocks = (n + block - 1) // block
    for b in nb.prange(n_blocks):
        _count_rows(
            P, E, psi_vertical, a, lower, upper, counts, mdl, b * block, min(n, (b + 1) * block)
        )


@nb.njit(**JIT)
def count_many_serial(P, E, psi_vertical, a, lower, upper, counts, mdl):
    """``count_many`` on the calling thread, for batches of one block.

    They gain nothing from the thread pool, whose wake-up costs milliseconds on a busy
    machine. (A function of its own: compiled from ``count_many``'s Python function, it
    shared that kernel's cache entry, and in every later process the parallel kernel loaded
    this serial code, so counts and workspace maps ran on one core.)
    """
    _count_rows(P, E, psi_vertical, a, lower, upper, counts, mdl, 0, P.shape[0])


@nb.njit(**JIT)
def sub_problems_solvable(p, e, psi_vertical, a, lower, upper, mdl):
    """Whether the base problem and the tip problem each have a valid stretch on their own.

    For either sign of L's direction, each sub-problem's joint limits and reach within its
    own reach chord (the paper's segments too under the paper's model), as ``_solve_target``
    classifies them before combining. The base problem depends on p and L's azimuth alone,
    the tip problem on p_z and e's elevation alone; so a circle of directions of one
    azimuth (the other elevation) has no solution anywhere when this says False for the
    base (the tip). Returns (base, tip).
    """
    work = _workspace(lower, upper, mdl[1].shape[0])
    lb, lt, iv_b, iv_t, cnt_b, cnt_t, allowed, q, fr, buf, tags, ws, sub, sure, sc = work
    hx, hy = e[0], e[1]
    hn = horizontal(hx, hy)
    if hn < VERTICAL_EPS:
        hx, hy, hn = math.cos(psi_vertical), math.sin(psi_vertical), 1.0
    base, tip = False, False
    for s in range(2):
        sgn = 1.0 if s == 0 else -1.0
        dx, dy = sgn * hx / hn, sgn * hy / hn
        _frames(p, e, dx, dy, a, fr)
        wb = reach_half_width(fr[0], fr[1], a[1], a[2])
        if wb >= 0.0 and not base:
            canonical_intervals(
                fr[0], fr[1], dx, dy, a[0], a[1], a[2], a[3], lb, -wb, wb,
                allowed, -1, iv_b, cnt_b, buf, tags, ws, mdl[0],
            )  # fmt: skip
            base = cnt_b[0] + cnt_b[1] > 0
        wt = reach_half_width(fr[3], fr[4], a[5], a[4])
        if wt >= 0.0 and not tip:
            canonical_intervals(
                fr[3], fr[4], fr[5], fr[6], a[6], a[5], a[4], a[3], lt, -wt, wt,
                allowed, -1, iv_t, cnt_t, buf, tags, ws, mdl[0],
            )  # fmt: skip
            tip = cnt_t[0] + cnt_t[1] > 0
    return base, tip


@nb.njit(**JIT)
def _first_scratch(lower, upper, mdl):
    """Scratch space of the calling thread for ``_has_range``."""
    work = _workspace(lower, upper, mdl[1].shape[0])
    return (
        work,
        np.empty((_COUNT_CAP, 6)),
        np.empty((_COUNT_CAP, 3), np.int8),
        np.empty((_COUNT_CAP, 2)),
        np.empty(1),
    )


@nb.njit(**INLINE)
def _has_range(p, e, psi_vertical, a, mdl, sc):
    """1 if the target has a solution range, 0 if not, -1 if a buffer overflowed.

    It stops at the first range (``_solve_any_azimuth(..., first=True)``): whether a
    direction is solvable costs a fraction of counting its ranges. Its callers' loops test
    ``may_reach`` first.
    """
    work, q, br, iv, used = sc
    return _solve_any_azimuth(p, e, psi_vertical, a, q, br, iv, used, work, mdl, True)


@nb.njit(**JIT)
def first_solvable(P, E, psi_vertical, a, lower, upper, mdl, out):
    """Indices of the first ``len(out)`` targets (in order) that have a solution range.

    Into ``out``; returns how many were found, or ``-1 - i`` if a buffer overflowed at
    target i. On the calling thread: the searches of degradation ask whether, in order
    along a circle or out from a direction, not how many.
    """
    sc = _first_scratch(lower, upper, mdl)
    m = 0
    for i in range(P.shape[0]):
        if m == out.shape[0]:
            break
        if not may_reach(P[i], E[i, 0], E[i, 1], E[i, 2], a):
            continue
        n = _has_range(P[i], E[i], psi_vertical[i], a, mdl, sc)
        if n < 0:
            return -1 - i
        if n > 0:
            out[m] = i
            m += 1
    return m


@nb.njit(**JIT)
def solvable_rows(P, E, psi_vertical, a, lower, upper, mdl, out):
    """``out[i]``: ``_has_range`` of target i, on the calling thread."""
    sc = _first_scratch(lower, upper, mdl)
    for i in range(P.shape[0]):
        out[i] = 0
        if may_reach(P[i], E[i, 0], E[i, 1], E[i, 2], a):
            out[i] = _has_range(P[i], E[i], psi_vertical[i], a, mdl, sc)
