"""Candidate events of the canonical planar 3R problem along the line L.

An *event* is a tau where some predicate of the canonical problem can change truth value:
a joint angle meets a limit or wraps through pi, P meets a reach circle, or (the paper's
segment model) an endpoint of one checked segment touches the other. Every event is the root
of a polynomial of degree <= 6 in tau.
"""

from __future__ import annotations

import math

import numba as nb

from handarm.ik._common import JIT, PI
from handarm.ik._poly import _sextic, poly_real_roots

# Elbow tags of candidate events: an event whose configuration has a definite elbow point A
# only changes validity on that elbow (qb >= 0 is elbow index 0).
BOTH = 0
ELBOW_POS = 1
ELBOW_NEG = 2


@nb.njit(**JIT)
def _push(buf, tags, n, x, lo, hi, tag):
    if lo < x < hi and n < buf.shape[0]:
        buf[n] = x
        tags[n] = tag
        n += 1
    return n


@nb.njit(**JIT)
def _elbow_tag(ax, ay, px, py):
    """Tag of the configuration with elbow point A and chain end P: sign of qb."""
    c = ax * (py - ay) - ay * (px - ax)
    scale = (ax * ax + ay * ay) + (px - ax) ** 2 + (py - ay) ** 2
    if abs(c) <= 1e-12 * scale:
        return BOTH
    return ELBOW_POS if c > 0.0 else ELBOW_NEG


@nb.njit(**JIT)
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


@nb.njit(**JIT)
def reach_half_width(nx, ny, b1, b2):
    """Half-length of the chord of L where |P| <= b1 + b2 (centred on tau = 0); -1 if none."""
    m2 = nx * nx + ny * ny
    reach2 = (b1 + b2) * (b1 + b2)
    if m2 >= reach2:
        return -1.0
    return math.sqrt(reach2 - m2)


@nb.njit(**JIT)
def canonical_events(nx, ny, dx, dy, b0, b1, b2, b3, lim, lo, hi, buf, tags, ws, paper):
    """Sorted candidate events in tau within [lo, hi] for one canonical problem.

    ``lim`` is (alo, ahi, blo, bhi, clo, chi); [lo, hi] must lie inside the reach chord.
    The ends lo and hi are the first and last entries; returns the count. ``tags`` gets
    the elbow each event belongs to (BOTH, ELBOW_POS, ELBOW_NEG). ``ws`` is scratch space
    of WS_SIZE floats. The segment-contact events (iv)-(viii) belong to the paper's
    collision model and are generated only when ``paper`` is True; the printed-link model
    is decided on the whole arm (``_printed``).
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
    if paper:
        n = _contact_events(nx, ny, dx, dy, b0, b1, b2, b3, lo, hi, buf, tags, ws, n)
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


@nb.njit(**JIT)
def _contact_events(nx, ny, dx, dy, b0, b1, b2, b3, lo, hi, buf, tags, ws, n):
    """The paper model's segment-contact events (iv)-(viii), appended to buf from n."""
    m2 = nx * nx + ny * ny
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
    return n
