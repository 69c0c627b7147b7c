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
def segment_box(ax, ay, az, bx, by, bz, ob):
    """Distance from a segment to a solid box (``ob``: a packed box row, see module doc).

    In the box frame the squared distance of p(t) is sum_i max(|p_i(t)| - h_i, 0)^2, a convex
    quadratic between the t where some |p_i| crosses h_i; each piece is minimised exactly.
    """
    pa = np.empty(3)
    pb = np.empty(3)
    for i in range(3):
        r0, r1, r2 = ob[4 + 3 * 0 + i], ob[4 + 3 * 1 + i], ob[4 + 3 * 2 + i]  # column i
        pa[i] = r0 * (ax - ob[1]) + r1 * (ay - ob[2]) + r2 * (az - ob[3])
        pb[i] = r0 * (bx - ob[1]) + r1 * (by - ob[2]) + r2 * (bz - ob[3])
    ts = np.empty(8)
    n = 0
    ts[n] = 0.0
    n += 1
    for i in range(3):
        du = pb[i] - pa[i]
        if du != 0.0:
            for h in (-ob[13 + i], ob[13 + i]):
                t = (h - pa[i]) / du
                if 0.0 < t < 1.0:
                    ts[n] = t
                    n += 1
    ts[n] = 1.0
    n += 1
    ts[:n].sort()
    best = math.inf
    for k in range(n - 1):
        t0, t1 = ts[k], ts[k + 1]
        tm = 0.5 * (t0 + t1)
        # on (t0, t1) each coordinate is below, inside or above its slab: a quadratic
        qa = 0.0
        qb = 0.0
        qc = 0.0
        for i in range(3):
            du = pb[i] - pa[i]
            x = pa[i] + tm * du
            h = ob[13 + i]
            if x > h:
                c0 = pa[i] - h
            elif x < -h:
                c0 = pa[i] + h
            else:
                continue
            qa += du * du
            qb += 2.0 * du * c0
            qc += c0 * c0
        t = t0
        if qa > 0.0:
            t = min(t1, max(t0, -qb / (2.0 * qa)))
        for tt in (t, t0, t1):
            best = min(best, qa * tt * tt + qb * tt + qc)
    return math.sqrt(max(best, 0.0))


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
