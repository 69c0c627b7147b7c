"""Numba kernels of the analytical IK: exact boundary events, gap classification, merging.

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

from handarm.kinematics import COLLINEAR_TOL

PI = math.pi
TWO_PI = 2.0 * math.pi
MAX_CAND = 96  # candidate events per canonical problem (at most 74 are generated)
MAX_IV = 40  # intervals per canonical problem and elbow
VERTICAL_EPS = 1e-12  # |horizontal part of e| below this: the direction is vertical
# Ranges closer than this (m) are one range: a constraint that only touches its bound inside a
# range leaves a hole of a single point, which rounding turns into ~1e-9 m or nothing.
MERGE_GAP = 2e-9

_JIT = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}


@nb.njit(**_JIT)
def wrap(x):
    """Angle to (-pi, pi]."""
    y = x - TWO_PI * math.floor((x + PI) / TWO_PI)
    if y <= -PI:
        y += TWO_PI
    return y


# -- polynomials (ascending coefficients) -----------------------------------------------------


@nb.njit(**_JIT)
def _horner(c, n, x):
    y = c[n]
    for k in range(n - 1, -1, -1):
        y = y * x + c[k]
    return y


@nb.njit(**_JIT)
def _bracketed_root(c, n, dc, x0, x1, f0):
    """Root of the polynomial (degree n, derivative dc) on [x0, x1] where it changes sign once.

    Newton steps kept inside a shrinking bracket, bisection when Newton misbehaves.
    """
    lo, hi = x0, x1
    flo = f0
    x = 0.5 * (lo + hi)
    for _ in range(100):
        f = _horner(c, n, x)
        if f == 0.0:
            return x
        if (f < 0.0) == (flo < 0.0):
            lo, flo = x, f
        else:
            hi = x
        df = _horner(dc, n - 1, x)
        step_ok = False
        if df != 0.0:
            xn = x - f / df
            if lo < xn < hi:
                step_ok = True
        if not step_ok:
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 4e-16 * (1.0 + abs(x)) or hi - lo <= 4e-16 * (1.0 + abs(x)):
            return xn
        x = xn
    return x


@nb.njit(**_JIT)
def poly_real_roots(c, n, lo, hi, out, ws):
    """All real roots in [lo, hi] of the degree-n polynomial c (ascending); returns the count.

    Exact up to rounding: the roots of the k-th derivative split [lo, hi] into pieces on
    which the (k-1)-th derivative is monotone, so each piece holds at most one of its
    roots, found by a bracketed Newton iteration. Starting from the (n-1)-th derivative
    (linear) and going down to the polynomial itself isolates every real root.
    """
    # ws holds the derivatives (row k: the k-th, degree n - k), then break points and roots.
    w = n + 1
    derivs = ws[: w * w].reshape((w, w))
    for i in range(n + 1):
        derivs[0, i] = c[i]
    for k in range(1, n + 1):
        for i in range(n - k + 1):
            derivs[k, i] = derivs[k - 1, i + 1] * (i + 1)
    breaks = ws[w * w : w * w + n + 2]
    roots = ws[w * w + n + 2 : w * w + 2 * n + 3]
    n_roots = 0  # roots of derivs[k + 1] found so far (none for the constant)
    for k in range(n - 1, -1, -1):
        deg = n - k
        nb_ = 0
        breaks[nb_] = lo
        nb_ += 1
        for i in range(n_roots):
            if lo < roots[i] < hi:
                breaks[nb_] = roots[i]
                nb_ += 1
        breaks[nb_] = hi
        nb_ += 1
        new = 0
        ck = derivs[k]
        dk = derivs[k + 1]
        f0 = _horner(ck, deg, breaks[0])
        for i in range(nb_ - 1):
            x0, x1 = breaks[i], breaks[i + 1]
            f1 = _horner(ck, deg, x1)
            if f0 == 0.0:
                if new == 0 or roots[new - 1] != x0:
                    out[new] = x0
                    new += 1
            elif f1 != 0.0 and (f0 < 0.0) != (f1 < 0.0):
                out[new] = _bracketed_root(ck, deg, dk, x0, x1, f0)
                new += 1
            f0 = f1
        if f0 == 0.0:
            out[new] = breaks[nb_ - 1]
            new += 1
        for i in range(new):
            roots[i] = out[i]
        n_roots = new
    return n_roots


@nb.njit(**_JIT)
def _pmul(a, na, b, nb_, out):
    for i in range(na + nb_ + 1):
        out[i] = 0.0
    for i in range(na + 1):
        for j in range(nb_ + 1):
            out[i + j] += a[i] * b[j]


@nb.njit(**_JIT)
def _sextic(r2, s, t, w, out, s2, t2):
    """Set out = r2 * s^2 - w * t^2 for quadratics r2, s, t (ascending) and scalar w."""
    _pmul(s, 2, s, 2, s2)
    _pmul(t, 2, t, 2, t2)
    _pmul(r2, 2, s2, 4, out)
    for i in range(5):
        out[i] -= w * t2[i]


# -- candidate events -------------------------------------------------------------------------


# Elbow tags of candidate events: an event whose configuration has a definite elbow point A
# only changes validity on that elbow (qb >= 0 is elbow index 0).
BOTH = 0
ELBOW_POS = 1
ELBOW_NEG = 2


@nb.njit(**_JIT)
def _push(buf, tags, n, x, lo, hi, tag):
    if lo < x < hi and n < buf.shape[0]:
        buf[n] = x
        tags[n] = tag
        n += 1
    return n


@nb.njit(**_JIT)
def _elbow_tag(ax, ay, px, py):
    """Tag of the configuration with elbow point A and chain end P: sign of qb."""
    c = ax * (py - ay) - ay * (px - ax)
    scale = (ax * ax + ay * ay) + (px - ax) ** 2 + (py - ay) ** 2
    if abs(c) <= 1e-12 * scale:
        return BOTH
    return ELBOW_POS if c > 0.0 else ELBOW_NEG


@nb.njit(**_JIT)
def _push_quadratic(buf, tags, n, b, c, lo, hi, kind, ax, ay, b2, nx, ny, dx, dy):
    """Roots of tau^2 + 2 b tau + c = 0 inside (lo, hi), tagged by their elbow.

    kind 0: A = (ax, ay) is fixed; kind 1: A = P - b2 * (ax, ay) (l2's direction fixed).
    """
    disc = b * b - c
    if disc < 0.0:
        return n
    sq = math.sqrt(disc)
    s = -b - sq if b >= 0.0 else -b + sq
    r1 = s
    r2 = c / s if s != 0.0 else -2.0 * b
    for t in (r1, r2):
        px, py = nx + t * dx, ny + t * dy
        if kind == 0:
            tag = _elbow_tag(ax, ay, px, py)
        else:
            tag = _elbow_tag(px - b2 * ax, py - b2 * ay, px, py)
        n = _push(buf, tags, n, t, lo, hi, tag)
    return n


@nb.njit(**_JIT)
def reach_half_width(nx, ny, b1, b2):
    """Half-length of the chord of L where |P| <= b1 + b2 (centred on tau = 0); -1 if none."""
    m2 = nx * nx + ny * ny
    reach2 = (b1 + b2) * (b1 + b2)
    if m2 >= reach2:
        return -1.0
    return math.sqrt(reach2 - m2)


@nb.njit(**_JIT)
def canonical_events(nx, ny, dx, dy, b0, b1, b2, b3, lim, lo, hi, buf, tags, ws):
    """Sorted candidate events in tau within [lo, hi] for one canonical problem.

    ``lim`` is (alo, ahi, blo, bhi, clo, chi); [lo, hi] must lie inside the reach chord.
    The ends lo and hi are the first and last entries; returns the count. ``tags`` gets
    the elbow each event belongs to (BOTH, ELBOW_POS, ELBOW_NEG). ``ws`` is scratch space
    of WS_SIZE floats.
    """
    m2 = nx * nx + ny * ny
    n = 0
    buf[n] = lo
    tags[n] = BOTH
    n += 1
    # (i) qb at a limit, folded (pi): |P|^2 = b1^2 + b2^2 + 2 b1 b2 cos(qb)
    for k in range(3):
        beta = PI if k == 2 else lim[2 + k]
        tag = BOTH if k == 2 else (ELBOW_POS if beta >= 0.0 else ELBOW_NEG)
        r2 = b1 * b1 + b2 * b2 + 2.0 * b1 * b2 * math.cos(beta)
        if r2 >= m2:
            t = math.sqrt(r2 - m2)
            n = _push(buf, tags, n, t, lo, hi, tag)
            n = _push(buf, tags, n, -t, lo, hi, tag)
    # (ii) qa at a limit or wrapping through pi: |P - A(qa)| = b2
    for k in range(3):
        alpha = PI if k == 2 else lim[k]
        ax, ay = b1 * math.cos(alpha), b1 * math.sin(alpha)
        kx, ky = nx - ax, ny - ay
        n = _push_quadratic(
            buf,
            tags,
            n,
            kx * dx + ky * dy,
            kx * kx + ky * ky - b2 * b2,
            lo,
            hi,
            0,
            ax,
            ay,
            b2,
            nx,
            ny,
            dx,
            dy,
        )
    # (iii) qc at a limit or wrapping: the direction of l2 is fixed, |P - b2 w| = b1
    psi = math.atan2(dy, dx)
    for k in range(3):
        qc = PI if k == 2 else lim[4 + k]
        wx, wy = math.cos(psi - qc), math.sin(psi - qc)
        kx, ky = nx - b2 * wx, ny - b2 * wy
        n = _push_quadratic(
            buf,
            tags,
            n,
            kx * dx + ky * dy,
            kx * kx + ky * ky - b1 * b1,
            lo,
            hi,
            1,
            wx,
            wy,
            b2,
            nx,
            ny,
            dx,
            dy,
        )
    # Contact events below only matter where the touching point lies on the touched
    # segment; `slack` keeps candidates that miss it by rounding only.
    slack = 1e-9 * (b0 + b1 + b2 + b3)
    # (iv) P or Q on l0 (the x axis from -b0 to 0)
    if dy != 0.0:
        t = -ny / dy
        x = nx + t * dx
        if -b0 - slack <= x <= slack:
            n = _push(buf, tags, n, t, lo, hi, BOTH)
            n = _push(buf, tags, n, t - b3, lo, hi, BOTH)
    # (v) O or H on l3: only when L passes through the point; then P or Q is at it
    for xh in (0.0, -b0):
        if abs((xh - nx) * dy + ny * dx) <= slack:
            t = xh * dx
            n = _push(buf, tags, n, t, lo, hi, BOTH)
            n = _push(buf, tags, n, t - b3, lo, hi, BOTH)
    # (vi) A on l3: A on L ahead of P, A = P + b2 d, which needs b2 <= b3
    if b1 * b1 >= m2 and b2 <= b3 + slack:
        s = math.sqrt(b1 * b1 - m2)
        for root in (s, -s):
            ax, ay = nx + root * dx, ny + root * dy
            tag = _elbow_tag(ax, ay, ax - b2 * dx, ay - b2 * dy)
            n = _push(buf, tags, n, root - b2, lo, hi, tag)
    # (vii) H on l2 (segment AP): r C = -2 b2 (P.g), g = H - P, r = |g|.
    poly, r2p, sp, tp = ws[0:7], ws[7:10], ws[10:13], ws[13:16]
    s2, t2, roots, rws = ws[16:21], ws[21:26], ws[26:33], ws[33:]
    kx, ky = -b0 - nx, -ny
    kd = kx * dx + ky * dy
    r2p[0], r2p[1], r2p[2] = kx * kx + ky * ky, -2.0 * kd, 1.0
    sp[0], sp[1], sp[2] = m2 + b2 * b2 - b1 * b1, 0.0, 1.0
    tp[0], tp[1], tp[2] = -b0 * nx - m2, -b0 * dx, -1.0
    # only where |P - H| <= b2 can H lie on l2
    w2 = b2 * b2 - (kx * dy - ky * dx) ** 2
    if w2 >= 0.0:
        w = math.sqrt(w2)
        s_lo, s_hi = max(lo, kd - w), min(hi, kd + w)
        if s_lo < s_hi:
            _sextic(r2p, sp, tp, 4.0 * b2 * b2, poly, s2, t2)
            k = poly_real_roots(poly, 6, s_lo, s_hi, roots, rws)
            for i in range(k):
                t = roots[i]
                px, py = nx + t * dx, ny + t * dy
                gx, gy = -b0 - px, -py
                r = math.sqrt(gx * gx + gy * gy)
                tag = BOTH
                if r > 0.0:
                    tag = _elbow_tag(px + b2 * gx / r, py + b2 * gy / r, px, py)
                n = _push(buf, tags, n, t, lo, hi, tag)
    # (viii) Q on l1 (segment OA), the paper's case 7: |Q| D = 2 b1 (Q.P), D = b1^2 + |P|^2 - b2^2.
    r2p[0], r2p[1], r2p[2] = b3 * b3 + m2, 2.0 * b3, 1.0
    sp[0], sp[1], sp[2] = b1 * b1 + m2 - b2 * b2, 0.0, 1.0
    tp[0], tp[1], tp[2] = m2, b3, 1.0
    # only where |Q| <= b1 can Q lie on l1
    if b1 * b1 >= m2:
        w = math.sqrt(b1 * b1 - m2)
        s_lo, s_hi = max(lo, -w - b3), min(hi, w - b3)
        if s_lo < s_hi:
            _sextic(r2p, sp, tp, 4.0 * b1 * b1, poly, s2, t2)
            k = poly_real_roots(poly, 6, s_lo, s_hi, roots, rws)
            for i in range(k):
                t = roots[i]
                px, py = nx + t * dx, ny + t * dy
                qx, qy = px + b3 * dx, py + b3 * dy
                rho = math.sqrt(qx * qx + qy * qy)
                tag = BOTH
                if rho > 0.0:
                    tag = _elbow_tag(b1 * qx / rho, b1 * qy / rho, px, py)
                n = _push(buf, tags, n, t, lo, hi, tag)
    if n < buf.shape[0]:
        buf[n] = hi
        tags[n] = BOTH
        n += 1
    # insertion sort (n is small)
    for i in range(1, n):
        x = buf[i]
        g = tags[i]
        j = i - 1
        while j >= 0 and buf[j] > x:
            buf[j + 1] = buf[j]
            tags[j + 1] = tags[j]
            j -= 1
        buf[j + 1] = x
        tags[j + 1] = g
    return n


# -- classification ---------------------------------------------------------------------------


@nb.njit(**_JIT)
def _cross(ox, oy, ax, ay, bx, by):
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


@nb.njit(**_JIT)
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


@nb.njit(**_JIT)
def _snap(x, tol):
    return 0.0 if abs(x) <= tol else x


@nb.njit(**_JIT)
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


@nb.njit(**_JIT)
def canonical_valid(nx, ny, dx, dy, tau, elbow, b0, b1, b2, b3, lim, psi):
    """Whether the canonical configuration at tau on ``elbow`` is valid (psi = angle of d)."""
    ok, qa, qb, qc = _angles(nx, ny, dx, dy, tau, elbow, b1, b2, psi)
    if not ok:
        return False
    if qa < lim[0] or qa > lim[1] or qb < lim[2] or qb > lim[3] or qc < lim[4] or qc > lim[5]:
        return False
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


@nb.njit(**_JIT)
def canonical_intervals(
    nx, ny, dx, dy, b0, b1, b2, b3, lim, lo, hi, allowed, n_allowed, iv, counts, buf, tags, ws
):
    """Valid tau intervals of a canonical problem within [lo, hi], per elbow.

    Fills ``iv[e, k] = (lo, hi)`` for elbow index e (0: qb >= 0, 1: qb < 0) and sets
    ``counts[e]``. Gaps that miss every interval of ``allowed[:n_allowed]`` (sorted, in
    tau; ``n_allowed < 0`` allows everything) are not classified: the other sub-problem
    has no solution there. Returns False if an elbow had more than MAX_IV intervals.
    """
    n = canonical_events(nx, ny, dx, dy, b0, b1, b2, b3, lim, lo, hi, buf, tags, ws)
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
            if t1 <= t0:
                continue
            if n_allowed >= 0:
                while j < n_allowed and allowed[j, 1] <= t0:
                    j += 1
                if j >= n_allowed or allowed[j, 0] >= t1:
                    open_ = False
                    continue
            ok = canonical_valid(nx, ny, dx, dy, 0.5 * (t0 + t1), elbow, b0, b1, b2, b3, lim, psi)
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


# -- the full 5-DoF problem -------------------------------------------------------------------


@nb.njit(**_JIT)
def _frames(p, e, dx, dy, a, out):
    """Canonical frames of both sub-problems for the line direction (dx, dy).

    Returns (base N, base offset, tip N, tip direction, tip offset) packed in an array::

        [bnx, bny, bofs, tnx, tny, tdx, tdy, tofs]

    with u = tau_B + bofs for the base and u = -(tau_E + tofs) for the tip.
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


@nb.njit(**_JIT)
def _limits(lower, upper, lb, lt):
    for k in range(3):
        lb[2 * k], lb[2 * k + 1] = lower[k], upper[k]
        # tip: (qa, qb, qc) = (-q6, -q5, -q4)
        lt[2 * k], lt[2 * k + 1] = -upper[5 - k], -lower[5 - k]


@nb.njit(**_JIT)
def configuration_at_u(p, e, dx, dy, u, elbow_b, elbow_e, a, out):
    """Joint angles at u on the branch (elbows as +1/-1); returns False if unreachable."""
    fr = np.empty(8)
    _frames(p, e, dx, dy, a, fr)
    return _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, out)


@nb.njit(**_JIT)
def _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, out):
    ok, q1, q2, q3 = _angles(
        fr[0], fr[1], dx, dy, u - fr[2], elbow_b, a[1], a[2], math.atan2(dy, dx)
    )
    if not ok:
        return False
    # the tip elbow is +1 when q5 >= 0, i.e. qb_canonical <= 0
    ok, qa, qb, qc = _angles(
        fr[3], fr[4], fr[5], fr[6], -u - fr[7], -elbow_e, a[5], a[4], math.atan2(fr[6], fr[5])
    )
    if not ok:
        return False
    out[0], out[1], out[2] = q1, q2, q3
    out[3], out[4], out[5] = -qc, -qb, -qa
    return True


@nb.njit(**_JIT)
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


WS_SIZE = 128
VERTICAL_STEP = math.radians(0.5)


@nb.njit(**_JIT)
def _workspace(lower, upper):
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
        np.empty(8),
        np.empty(MAX_CAND),
        np.empty(MAX_CAND, np.int8),
        np.empty(WS_SIZE),
    )


@nb.njit(**_JIT)
def solve_target(p, e, psi_vertical, a, lower, upper, out_q, out_br, out_iv, psi_used):
    """Every 5-DoF solution range of one target.

    Returns the number of ranges found (rows beyond ``out_q.shape[0]`` are not stored),
    or -1 if an internal interval buffer overflowed. When ``e`` is vertical, L may take
    any azimuth: the first azimuth with a solution, going out from ``psi_vertical`` in
    steps of VERTICAL_STEP, is used. The azimuth of d = +1 goes to ``psi_used[0]``.
    """
    work = _workspace(lower, upper)
    return _solve_any_azimuth(p, e, psi_vertical, a, out_q, out_br, out_iv, psi_used, work)


@nb.njit(**_JIT)
def _solve_any_azimuth(p, e, psi_vertical, a, out_q, out_br, out_iv, psi_used, work):
    if e[0] * e[0] + e[1] * e[1] >= VERTICAL_EPS * VERTICAL_EPS:
        psi_used[0] = math.atan2(e[1], e[0])
        return _solve_target(p, e, 0.0, a, out_q, out_br, out_iv, work)
    # d = +-(cos psi, sin psi) covers psi and psi + pi: a quarter turn each way suffices
    n_steps = int(math.ceil(0.5 * PI / VERTICAL_STEP))
    for k in range(2 * n_steps + 1):
        off = ((k + 1) // 2) * VERTICAL_STEP * (1.0 if k % 2 == 1 else -1.0)
        psi = wrap(psi_vertical + off)
        n = _solve_target(p, e, psi, a, out_q, out_br, out_iv, work)
        if n != 0:
            psi_used[0] = psi
            return n
    psi_used[0] = psi_vertical
    return 0


@nb.njit(**_JIT)
def _valid_at(fr, dx, dy, u, elbow_b, elbow_e, a, lb, lt):
    """Both sub-problems valid at u (the classification's own predicate)."""
    return canonical_valid(
        fr[0], fr[1], dx, dy, u - fr[2], elbow_b, a[0], a[1], a[2], a[3], lb, math.atan2(dy, dx)
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
    )


@nb.njit(**_JIT)
def _representative(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, lb, lt, q):
    """Configuration at the range's midpoint into q; returns False if none is usable.

    Where a constraint only touches its bound inside a range (a tangency: valid on both
    sides), the midpoint can sit on it and fail by one rounding step; then the nearest of
    the points at 1/4, 3/4, 1/8, 7/8, ... of the range that passes is used.
    """
    frac = 0.5
    step = 0.25
    for attempt in range(13):
        u = lo + frac * (hi - lo)
        if _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, q) and _valid_at(
            fr, dx, dy, u, elbow_b, elbow_e, a, lb, lt
        ):
            return True
        # 0.5, 0.25, 0.75, 0.125, 0.875, ...
        if attempt % 2 == 0:
            frac = 0.5 - step
        else:
            frac = 0.5 + step
            step *= 0.5
    return False


@nb.njit(**_JIT)
def _solve_target(p, e, psi_vertical, a, out_q, out_br, out_iv, work):
    lb, lt, iv_b, iv_t, cnt_b, cnt_t, allowed, q, fr, buf, tags, ws = work
    cap = out_q.shape[0]
    hx, hy = e[0], e[1]
    hn = math.sqrt(hx * hx + hy * hy)
    if hn < VERTICAL_EPS:
        hx, hy, hn = math.cos(psi_vertical), math.sin(psi_vertical), 1.0
    total = 0
    overflow = False
    for s in range(2):
        sgn = 1.0 if s == 0 else -1.0
        dx, dy = sgn * hx / hn, sgn * hy / hn
        _frames(p, e, dx, dy, a, fr)
        # u-range where both chains reach L: tau_B = u - fr[2], tau_E = -u - fr[7]
        wb = reach_half_width(fr[0], fr[1], a[1], a[2])
        wt = reach_half_width(fr[3], fr[4], a[5], a[4])
        if wb < 0.0 or wt < 0.0:
            continue
        u_lo = max(-wb + fr[2], -wt - fr[7])
        u_hi = min(wb + fr[2], wt - fr[7])
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
                    if lo < hi:
                        elbow_b = 1.0 if eb == 0 else -1.0
                        if _representative(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, lb, lt, q):
                            if total < cap:
                                for k in range(6):
                                    out_q[total, k] = q[k]
                                out_br[total, 0] = int(sgn)
                                out_br[total, 1] = int(elbow_b)
                                out_br[total, 2] = int(elbow_e)
                                out_iv[total, 0] = lo
                                out_iv[total, 1] = hi
                            total += 1
                    if b_hi < t_hi:
                        i += 1
                    else:
                        j += 1
    if overflow:
        return -1
    return total


@nb.njit(parallel=True, **_JIT)
def solve_many(P, E, psi_vertical, a, lower, upper, out_q, out_br, out_iv, counts, psi_used):
    """solve_target over rows, in parallel; rows beyond capacity are counted, not stored.

    Rows go in blocks so that each block allocates its scratch space once.
    """
    n = P.shape[0]
    block = 256
    n_blocks = (n + block - 1) // block
    for b in nb.prange(n_blocks):
        work = _workspace(lower, upper)
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
            )
            # pad the unused rows here: the caller's arrays are left uninitialised
            for r in range(max(counts[i], 0), out_q.shape[1]):
                for c in range(6):
                    out_q[i, r, c] = np.nan
                for c in range(3):
                    out_br[i, r, c] = 0
                out_iv[i, r, 0] = np.nan
                out_iv[i, r, 1] = np.nan


@nb.njit(**_JIT)
def configurations_along_u(p, e, dx, dy, us, elbow_b, elbow_e, a, out, ok):
    """configuration_at_u for many u of one branch."""
    fr = np.empty(8)
    _frames(p, e, dx, dy, a, fr)
    for i in range(us.shape[0]):
        ok[i] = _configuration(fr, dx, dy, us[i], elbow_b, elbow_e, a, out[i])


@nb.njit(parallel=True, **_JIT)
def count_many(P, E, psi_vertical, a, lower, upper, counts):
    """Number of solution ranges of each target, without storing them (workspace maps)."""
    n = P.shape[0]
    block = 256
    n_blocks = (n + block - 1) // block
    for b in nb.prange(n_blocks):
        work = _workspace(lower, upper)
        q = np.empty((_COUNT_CAP, 6))
        br = np.empty((_COUNT_CAP, 3), np.int8)
        iv = np.empty((_COUNT_CAP, 2))
        used = np.empty(1)
        for i in range(b * block, min(n, (b + 1) * block)):
            counts[i] = _solve_any_azimuth(P[i], E[i], psi_vertical[i], a, q, br, iv, used, work)


_COUNT_CAP = 1  # count_many keeps no solution rows; the count is exact regardless
