"""Numba kernels of the obstacle model (see ``handarm.scene``).

Each envelope piece (a slab stadium, ``handarm.collision``) is covered by a capsule: the
segment at the middle of its slab, with radius sqrt(r^2 + h^2) for stadium radius r and slab
half-height h. Obstacles are spheres and capsules (a core segment and a radius) and boxes (a
centre, a rotation and half extents). The gap of a piece and an obstacle is the distance
between the capsule's segment and the obstacle's core, less both radii and the clearance:
the arm meets the obstacle where some gap is negative. Distances are exact (segment-box
distance by minimising its convex piecewise quadratic square exactly).

Obstacles, packed (m, 16) float: column 0 the kind (0 sphere, 1 capsule, 2 box); sphere:
centre (1:4), radius 4; capsule: ends (1:4), (4:7), radius 7; box: centre (1:4), rotation
world-from-box row-major (4:13), half extents (13:16).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm._collide import JIT, _placed, place_frames

SPHERE, CAPSULE, BOX = 0, 1, 2


@nb.njit(**JIT)
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@nb.njit(**JIT)
def point_segment(px, py, pz, ax, ay, az, bx, by, bz):
    """Distance from a point to a closed segment (3D)."""
    ux, uy, uz = bx - ax, by - ay, bz - az
    den = _dot(ux, uy, uz, ux, uy, uz)
    t = 0.0
    if den > 0.0:
        t = min(1.0, max(0.0, _dot(px - ax, py - ay, pz - az, ux, uy, uz) / den))
    ex, ey, ez = px - ax - t * ux, py - ay - t * uy, pz - az - t * uz
    return math.sqrt(_dot(ex, ey, ez, ex, ey, ez))


@nb.njit(**JIT)
def segment_segment(p0x, p0y, p0z, p1x, p1y, p1z, q0x, q0y, q0z, q1x, q1y, q1z):
    """Distance between two closed segments (3D).

    The minimum over the square of parameters is either interior (where the segments'
    common normal meets both) or on the square's edge (a segment end against the other).
    """
    d = point_segment(p0x, p0y, p0z, q0x, q0y, q0z, q1x, q1y, q1z)
    d = min(d, point_segment(p1x, p1y, p1z, q0x, q0y, q0z, q1x, q1y, q1z))
    d = min(d, point_segment(q0x, q0y, q0z, p0x, p0y, p0z, p1x, p1y, p1z))
    d = min(d, point_segment(q1x, q1y, q1z, p0x, p0y, p0z, p1x, p1y, p1z))
    ux, uy, uz = p1x - p0x, p1y - p0y, p1z - p0z
    vx, vy, vz = q1x - q0x, q1y - q0y, q1z - q0z
    wx, wy, wz = p0x - q0x, p0y - q0y, p0z - q0z
    a = _dot(ux, uy, uz, ux, uy, uz)
    b = _dot(ux, uy, uz, vx, vy, vz)
    c = _dot(vx, vy, vz, vx, vy, vz)
    dd = _dot(ux, uy, uz, wx, wy, wz)
    e = _dot(vx, vy, vz, wx, wy, wz)
    den = a * c - b * b
    if den > 1e-12 * a * c and a > 0.0 and c > 0.0:
        s = (b * e - c * dd) / den
        t = (a * e - b * dd) / den
        if 0.0 < s < 1.0 and 0.0 < t < 1.0:
            ex = wx + s * ux - t * vx
            ey = wy + s * uy - t * vy
            ez = wz + s * uz - t * vz
            d = min(d, math.sqrt(_dot(ex, ey, ez, ex, ey, ez)))
    return d


@nb.njit(**JIT)
def _excess(x, h):
    return x - h if x > h else (x + h if x < -h else 0.0)


@nb.njit(**JIT)
def _box_f(t, a0, a1, a2, d0, d1, d2, h0, h1, h2):
    """Squared distance from a(t) = a + t d to the box |x_i| <= h_i, and its derivative."""
    e0 = _excess(a0 + t * d0, h0)
    e1 = _excess(a1 + t * d1, h1)
    e2 = _excess(a2 + t * d2, h2)
    return e0 * e0 + e1 * e1 + e2 * e2, 2.0 * (e0 * d0 + e1 * d1 + e2 * d2)


@nb.njit(**JIT)
def segment_box(ax, ay, az, bx, by, bz, ob):
    """Distance from a segment to a solid box (``ob``: a packed box row, see module doc).

    In the box frame the squared distance f(t) of p(t) is sum_i max(|p_i(t)| - h_i, 0)^2:
    convex, with a piecewise linear, non-decreasing derivative whose kinks are where some
    |p_i| crosses h_i. The kinks on either side of the derivative's zero bound a stretch on
    which it is linear; its root there is the exact minimiser.
    """
    # box-frame coordinates: p_box[i] = sum_r R[r][i] (p - c)[r], R row-major in ob[4:13]
    px, py, pz = ax - ob[1], ay - ob[2], az - ob[3]
    qx, qy, qz = bx - ob[1], by - ob[2], bz - ob[3]
    a0 = ob[4] * px + ob[7] * py + ob[10] * pz
    a1 = ob[5] * px + ob[8] * py + ob[11] * pz
    a2 = ob[6] * px + ob[9] * py + ob[12] * pz
    d0 = ob[4] * qx + ob[7] * qy + ob[10] * qz - a0
    d1 = ob[5] * qx + ob[8] * qy + ob[11] * qz - a1
    d2 = ob[6] * qx + ob[9] * qy + ob[12] * qz - a2
    h0, h1, h2 = ob[13], ob[14], ob[15]
    f0, g0 = _box_f(0.0, a0, a1, a2, d0, d1, d2, h0, h1, h2)
    if g0 >= 0.0:
        return math.sqrt(f0)
    f1, g1 = _box_f(1.0, a0, a1, a2, d0, d1, d2, h0, h1, h2)
    if g1 <= 0.0:
        return math.sqrt(f1)
    lo, glo, hi, ghi = 0.0, g0, 1.0, g1
    for i in range(3):
        ai = a0 if i == 0 else (a1 if i == 1 else a2)
        di = d0 if i == 0 else (d1 if i == 1 else d2)
        hh = h0 if i == 0 else (h1 if i == 1 else h2)
        if di == 0.0:
            continue
        for h in (-hh, hh):
            t = (h - ai) / di
            if lo < t < hi:
                _, g = _box_f(t, a0, a1, a2, d0, d1, d2, h0, h1, h2)
                if g <= 0.0:
                    lo, glo = t, g
                else:
                    hi, ghi = t, g
    t = lo - glo * (hi - lo) / (ghi - glo)
    t = min(hi, max(lo, t))
    f, _ = _box_f(t, a0, a1, a2, d0, d1, d2, h0, h1, h2)
    return math.sqrt(max(f, 0.0))


@nb.njit(**JIT)
def piece_capsule(k, frames, pi, pf):
    """World ends of piece k's capsule segment (mid-slab) and its radius."""
    slot = 12 if pi[k, 0] == 6 else 2 * pi[k, 0] + pi[k, 1]
    dx, dy, fx, fy = frames[13, 0], frames[13, 1], frames[13, 2], frames[13, 3]
    x0, y0, x1, y1, _, _, _ = _placed(
        frames[slot, 0], frames[slot, 1], frames[slot, 2], frames[slot, 3],
        pf[k, 0], pf[k, 1], pf[k, 2], pf[k, 3], pf[k, 5], pf[k, 6], pi[k, 2],
        dx, dy, fx, fy,
    )  # fmt: skip
    zm = 0.5 * (pf[k, 5] + pf[k, 6])
    hz = 0.5 * (pf[k, 6] - pf[k, 5])
    rho = math.sqrt(pf[k, 4] * pf[k, 4] + hz * hz)
    if pi[k, 2] == 0:
        return x0, y0, zm, x1, y1, zm, rho
    # tip plane: (sigma, v) with the slab along -n = (dy, -dx)
    return (
        fx + x0 * dx + zm * dy,
        fy + x0 * dy - zm * dx,
        y0,
        fx + x1 * dx + zm * dy,
        fy + x1 * dy - zm * dx,
        y1,
        rho,
    )


@nb.njit(**JIT)
def gap(ax, ay, az, bx, by, bz, rho, ob, c):
    """Gap between a capsule (segment a-b, radius rho) and one obstacle, less clearance c."""
    kind = int(ob[0])
    if kind == SPHERE:
        return point_segment(ob[1], ob[2], ob[3], ax, ay, az, bx, by, bz) - rho - ob[4] - c
    if kind == CAPSULE:
        d = segment_segment(ax, ay, az, bx, by, bz, ob[1], ob[2], ob[3], ob[4], ob[5], ob[6])
        return d - rho - ob[7] - c
    return segment_box(ax, ay, az, bx, by, bz, ob) - rho - c


@nb.njit(**JIT)
def gaps_at(frames, pi, pf, n_pieces, obs, c, out):
    """Smallest gap of each obstacle to any piece, for the pose set in ``frames``."""
    for o in range(obs.shape[0]):
        out[o] = math.inf
    for k in range(n_pieces):
        ax, ay, az, bx, by, bz, rho = piece_capsule(k, frames, pi, pf)
        for o in range(obs.shape[0]):
            out[o] = min(out[o], gap(ax, ay, az, bx, by, bz, rho, obs[o], c))


@nb.njit(**JIT)
def gaps_many(Q, a, pi, pf, n_pieces, obs, c, out):
    """``gaps_at`` for many configurations (joint 4 placed at sigma 0 along L)."""
    frames = np.zeros((14, 4))
    for i in range(Q.shape[0]):
        place_frames(Q[i], a, 0.0, frames)
        gaps_at(frames, pi, pf, n_pieces, obs, c, out[i])
