"""Numba kernels of degradation's direction searches (``handarm.ik.degrade``).

The level-3 search moves each starting direction to the boundary of the solvable set by
bisection along the great-circle arc towards e0, then along the boundary by rings of trial
directions. Each step asks whether one direction has an exact solution at p: here that
question and the search's own geometry run in one compiled call per search, where the
Python version spent more time around each question than answering it.

"Solvable" is the exact solver's (a solution range of at least the model's ``min_width``),
or, in a scene (``obs`` with rows), a range with a stretch that keeps ``c`` from every
obstacle, exactly as ``count_solutions(..., scene=)`` counts it.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm.ik._common import INLINE, JIT, wrap
from handarm.ik._obstacles import _count_target, count_scratch
from handarm.ik._solve import _first_scratch, _has_range, may_reach


@nb.njit(**JIT)
def angle3(ax, ay, az, bx, by, bz):
    """Angle between two unit vectors (rad), robust near 0 and pi."""
    dx, dy, dz = ax - bx, ay - by, az - bz
    sx, sy, sz = ax + bx, ay + by, az + bz
    return 2.0 * math.atan2(
        math.sqrt(dx * dx + dy * dy + dz * dz), math.sqrt(sx * sx + sy * sy + sz * sz)
    )


@nb.njit(**JIT)
def tangents(x, y, z):
    """Two unit vectors making a right-handed orthonormal frame with the unit vector (x, y, z)."""
    if abs(z) < 0.9:  # v x (0, 0, 1)
        n = math.hypot(x, y)
        t1x, t1y, t1z = y / n, -x / n, 0.0
    else:  # v x (1, 0, 0)
        n = math.hypot(y, z)
        t1x, t1y, t1z = 0.0, z / n, -y / n
    return t1x, t1y, t1z, y * t1z - z * t1y, z * t1x - x * t1z, x * t1y - y * t1x


@nb.njit(**JIT)
def slerp(a, b, t, out):
    """The unit vector a fraction t of the way from a to b on their great circle, into out.

    Antipodal a and b: the great circle through a helper axis.
    """
    omega = angle3(a[0], a[1], a[2], b[0], b[1], b[2])
    if omega < 1e-15:
        out[0], out[1], out[2] = b[0], b[1], b[2]
        return
    if omega > math.pi - 1e-9:
        hx, hy, hz = (0.0, 0.0, 1.0) if abs(a[2]) < 0.9 else (1.0, 0.0, 0.0)
        ox, oy, oz = a[1] * hz - a[2] * hy, a[2] * hx - a[0] * hz, a[0] * hy - a[1] * hx
        n = math.sqrt(ox * ox + oy * oy + oz * oz)
        th = t * omega
        c, s = math.cos(th), math.sin(th)
        out[0], out[1], out[2] = c * a[0] + s * ox / n, c * a[1] + s * oy / n, c * a[2] + s * oz / n
        return
    wa, wb, den = math.sin((1.0 - t) * omega), math.sin(t * omega), math.sin(omega)
    vx, vy, vz = (
        (wa * a[0] + wb * b[0]) / den,
        (wa * a[1] + wb * b[1]) / den,
        (wa * a[2] + wb * b[2]) / den,
    )
    n = math.sqrt(vx * vx + vy * vy + vz * vz)
    out[0], out[1], out[2] = vx / n, vy / n, vz / n


@nb.njit(**JIT)
def search_scratch(lower, upper, mdl, n_pieces, n_obs):
    """Scratch space of the searches on this thread (free and scene solvability)."""
    scene_bufs = count_scratch(n_pieces, n_obs)
    return _first_scratch(lower, upper, mdl), scene_bufs, np.empty(3)


@nb.njit(**INLINE)
def solvable(p, ex, ey, ez, psi, a, mdl, sc, scene):
    """Whether the direction (ex, ey, ez) (normalised here) has a solution at p.

    ``scene``: (pi, pf, coef, n_pieces, obs, c); with no obstacle rows, the free solver.
    """
    first, scene_bufs, e = sc
    n = math.sqrt(ex * ex + ey * ey + ez * ez)
    e[0], e[1], e[2] = ex / n, ey / n, ez / n
    pi, pf, coef, n_pieces, obs, c = scene
    if obs.shape[0] == 0:
        k = _has_range(p, e, psi, a, mdl, first)
    else:
        k = _count_target(
            p, e, psi, a, first[0], mdl, pi, pf, coef, n_pieces, obs, c, mdl[-1], scene_bufs
        )
    if k < 0:
        raise RuntimeError("IK: more solution ranges than the internal buffers hold")
    return k > 0


@nb.njit(**JIT)
def to_boundary(p, psi, e0, good, tol, a, mdl, sc, scene, out):
    """Bisect the arc from e0 to the solvable ``good`` to its solvable end nearest e0.

    The bracket [0, 1] (fraction of the arc) shrinks to ``tol`` rad of arc; ``out`` gets the
    solvable end.
    """
    arc = max(angle3(e0[0], e0[1], e0[2], good[0], good[1], good[2]), tol)
    lo, hi = 0.0, 1.0  # hi: solvable
    trial = np.empty(3)
    while abs(hi - lo) > tol / arc:
        mid = 0.5 * (lo + hi)
        slerp(e0, good, mid, trial)
        if may_reach(p, trial[0], trial[1], trial[2], a) and solvable(
            p, trial[0], trial[1], trial[2], psi, a, mdl, sc, scene
        ):
            hi = mid
        else:
            lo = mid
    slerp(e0, good, hi, out)


#: Turns (rad) off the tangent of the circle round e0, towards e0, of the extra trials of a
#: pattern search (both sides). Where the boundary of the solvable set meets that circle at
#: an angle narrower than the ring's spacing (7.5 degrees), no ring direction lies in the
#: wedge between them that is both solvable and closer; stopping there cost 0.011 degrees
#: on one of the first 100 targets of the slow sphere-oracle test (the loss grows with the
#: square of the wedge's angle, so below 0.5 degrees it is about 1e-4 of that).
TANGENT_TURNS = (
    math.radians(0.5), math.radians(1.0), math.radians(2.0), math.radians(4.0)
)  # fmt: skip


#: The pattern searches of ``refine_directions`` first stop at this ring (rad) ...
COARSE = 1e-3
#: ... and one that comes within this angle (rad) of where an earlier one stopped, no
#: closer to e0, is that one's search: only the first goes on to ``tol``. Searches from
#: different starts mostly end at one or two places (of 31 level-3 targets of
#: benchmarks/bench_degrade.py's kind, 6 starts each: one place on 24, two on 7), and
#: those that met there ended within 9e-6 rad of each other's angle to e0 when all went on.
SAME_END = 3e-3


@nb.njit(**JIT)
def _meets(gx, gy, gz, angle, ends, e0):
    """The row of ``ends`` a search at (gx, gy, gz) has met, or -1.

    The first within ``SAME_END`` of it and no farther from e0 than ``angle``, the search's
    own angle to e0.
    """
    for j in range(ends.shape[0]):
        if angle3(gx, gy, gz, ends[j, 0], ends[j, 1], ends[j, 2]) <= SAME_END and (
            angle3(ends[j, 0], ends[j, 1], ends[j, 2], e0[0], e0[1], e0[2]) <= angle
        ):
            return j
    return -1


#: A trial direction whose cosine with e0 is this much below the present one's is farther
#: from e0 (its angle larger by at least as much, far beyond rounding): its angle is not
#: computed (half of each ring; the angles are most of a ring's own cost).
_FARTHER = 1e-9


@nb.njit(**JIT)
def pattern_search(
    p, psi, e0, good, cos_ring, sin_ring, top, step, tol, rounds, a, mdl, sc, scene, ends, out
):
    """Move the solvable direction ``good`` towards e0 by rings of trial directions, into out.

    A ring of ``len(cos_ring)`` directions at angle ``step`` around the present one, and
    the directions at that angle turned by ``TANGENT_TURNS`` from either tangent of the
    circle round e0 towards e0; of those closer to e0, the closest solvable is taken. The
    step (``step`` at first) doubles after a move (up to ``top``) and halves after a miss,
    down to ``tol``; at most ``rounds`` rings. Returns (step, rings left, -1): a search stopped
    at a coarser ``tol`` goes on from there exactly as one run would have.

    ``ends`` (k, 3): where earlier searches stopped. A move to within ``SAME_END`` of one of
    them, no closer to e0 than it, ends the search there, returning that row's index.
    """
    gx, gy, gz = good[0], good[1], good[2]
    m = cos_ring.shape[0] + 2 * len(TANGENT_TURNS)
    tx, ty, tz, ang = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    order = np.empty(m, np.int64)
    while rounds > 0:
        if step <= tol:
            break
        rounds -= 1
        a0 = angle3(gx, gy, gz, e0[0], e0[1], e0[2])
        t1x, t1y, t1z, t2x, t2y, t2z = tangents(gx, gy, gz)
        cs, ss = math.cos(step), math.sin(step)
        # towards e0 in the tangent plane (w), and across (v = g x w)
        c0 = gx * e0[0] + gy * e0[1] + gz * e0[2]
        wx, wy, wz = e0[0] - c0 * gx, e0[1] - c0 * gy, e0[2] - c0 * gz
        wn = math.sqrt(wx * wx + wy * wy + wz * wz)
        n_trials = cos_ring.shape[0]
        vx = vy = vz = 0.0
        if wn > 1e-12:
            wx, wy, wz = wx / wn, wy / wn, wz / wn
            vx, vy, vz = gy * wz - gz * wy, gz * wx - gx * wz, gx * wy - gy * wx
            n_trials = m
        n = 0
        for k in range(n_trials):
            if k < cos_ring.shape[0]:
                ux = cos_ring[k] * t1x + sin_ring[k] * t2x
                uy = cos_ring[k] * t1y + sin_ring[k] * t2y
                uz = cos_ring[k] * t1z + sin_ring[k] * t2z
            else:
                j = k - cos_ring.shape[0]
                turn = TANGENT_TURNS[j // 2]
                side = 1.0 if j % 2 == 0 else -1.0
                cb, sb = math.sin(turn), side * math.cos(turn)  # bearing 90 deg - turn
                ux, uy, uz = cb * wx + sb * vx, cb * wy + sb * vy, cb * wz + sb * vz
            x, y, z = cs * gx + ss * ux, cs * gy + ss * uy, cs * gz + ss * uz
            tx[k], ty[k], tz[k] = x, y, z
            if x * e0[0] + y * e0[1] + z * e0[2] < c0 - _FARTHER:
                continue  # farther from e0 for sure (|cos a - cos b| <= |a - b|): no angle
            w = angle3(x, y, z, e0[0], e0[1], e0[2])
            ang[k] = w
            if w < a0:  # closer trials, by angle (stable: ties keep trial order)
                j = n
                while j > 0 and ang[order[j - 1]] > w:
                    order[j] = order[j - 1]
                    j -= 1
                order[j] = k
                n += 1
        moved = False
        for i in range(n):
            k = order[i]
            if may_reach(p, tx[k], ty[k], tz[k], a) and solvable(
                p, tx[k], ty[k], tz[k], psi, a, mdl, sc, scene
            ):
                gx, gy, gz = tx[k], ty[k], tz[k]
                moved = True
                break
        if moved:
            j = _meets(gx, gy, gz, ang[k], ends, e0)
            if j >= 0:
                out[0], out[1], out[2] = gx, gy, gz
                return step, rounds, j
        step = min(2.0 * step, top) if moved else 0.5 * step
    out[0], out[1], out[2] = gx, gy, gz
    return step, rounds, -1


@nb.njit(**JIT)
def refine_directions(
    p, psi, e0, starts, cos_ring, sin_ring, top, tol, rounds, a, lower, upper, mdl, scene, out
):
    """Each solvable start (k, 3) moved to the boundary and along it towards e0, into out.

    Every search runs to the ring ``COARSE``, and one that comes near where an earlier one
    stopped (``SAME_END``) ends there; then only the searches that stopped on their own go
    on to ``tol``, and the others take the answer of the one they met.
    """
    pi, pf, coef, n_pieces, obs, c = scene
    sc = search_scratch(lower, upper, mdl, n_pieces, obs.shape[0])
    edge = np.empty(3)
    k = starts.shape[0]
    coarse = np.empty((k, 3))  # rows 0..n_own - 1: the searches that stopped on their own
    steps = np.empty(k)
    left = np.empty(k, np.int64)
    same = np.empty(k, np.int64)  # start i's search: row same[i] of coarse
    n_own = 0
    for i in range(k):
        to_boundary(p, psi, e0, starts[i], tol, a, mdl, sc, scene, edge)
        step, rings, met = pattern_search(
            p, psi, e0, edge, cos_ring, sin_ring, top, top, max(tol, COARSE), rounds, a, mdl,
            sc, scene, coarse[:n_own], coarse[n_own],
        )  # fmt: skip
        if met < 0:
            # stopped on its own, maybe next to where an earlier one did
            x, y, z = coarse[n_own, 0], coarse[n_own, 1], coarse[n_own, 2]
            met = _meets(x, y, z, angle3(x, y, z, e0[0], e0[1], e0[2]), coarse[:n_own], e0)
        if met >= 0:
            same[i] = met
        else:
            same[i] = n_own
            steps[n_own], left[n_own] = step, rings
            n_own += 1
    fine = np.empty((max(n_own, 1), 3))
    for j in range(n_own):
        pattern_search(
            p, psi, e0, coarse[j], cos_ring, sin_ring, top, steps[j], tol, left[j], a, mdl, sc,
            scene, coarse[:0], fine[j],
        )  # fmt: skip
    for i in range(k):
        out[i, 0], out[i, 1], out[i, 2] = fine[same[i], 0], fine[same[i], 1], fine[same[i], 2]


#: Circles of level 4 (``handarm.ik.degrade``): directions of e's yaw at every pitch (a
#: vertical great circle, the tip plane kept), and of e's pitch at every yaw.
PITCH_CIRCLE, YAW_CIRCLE = 0, 1


@nb.njit(**JIT)
def circle_direction(kind, yaw, pitch, pole, th, out):
    """The unit direction at angle ``th`` of a level-4 circle, into out.

    PITCH_CIRCLE: (cos th cos yaw, cos th sin yaw, sin th), with |cos th| kept at least
    ``pole`` so that a point on the pole keeps L's azimuth (the circle's, not the free one of
    a vertical direction); YAW_CIRCLE: (cos pitch cos th, cos pitch sin th, sin pitch).
    """
    if kind == PITCH_CIRCLE:
        c = math.cos(th)
        if abs(c) < pole:
            c = pole if c >= 0.0 else -pole
        st = math.sin(th)
        sign = 1.0 if st > 0.0 else (-1.0 if st < 0.0 else 0.0)
        out[0], out[1], out[2] = c * math.cos(yaw), c * math.sin(yaw), sign * math.sqrt(1.0 - c * c)
    else:
        cp = math.cos(pitch)
        out[0], out[1], out[2] = cp * math.cos(th), cp * math.sin(th), math.sin(pitch)


@nb.njit(**JIT)
def circle_cost(kind, x, cos_pitch):
    """Angle (rad) from the circle's start of the direction |x| away along it."""
    if kind == PITCH_CIRCLE:
        return x
    return 2.0 * math.asin(min(1.0, cos_pitch * math.sin(0.5 * x)))


@nb.njit(**JIT)
def _circle_side(kinds, s, yaw, pitch):
    """Side s of the circles ``kinds`` (two per circle, + then -): (kind, sign, start angle)."""
    kind = kinds[s // 2]
    return kind, 1.0 if s % 2 == 0 else -1.0, pitch if kind == PITCH_CIRCLE else yaw


@nb.njit(**JIT)
def _circle_bisect(kind, yaw, pitch, pole, th0, good, bad, tol, p, psi, a, mdl, sc, scene):
    """Bisect the offsets [bad, good] along a circle (good solvable) to ``tol``: the good end."""
    d = np.empty(3)
    while abs(good - bad) > tol:
        mid = 0.5 * (good + bad)
        circle_direction(kind, yaw, pitch, pole, th0 + mid, d)
        if may_reach(p, d[0], d[1], d[2], a) and solvable(
            p, d[0], d[1], d[2], psi, a, mdl, sc, scene
        ):
            good = mid
        else:
            bad = mid
    return good


@nb.njit(**JIT)
def nearest_on_circles(
    p, psi, kinds, yaw, pitch, pole, prune, offsets, block_ends, fine, tol, a, lower, upper,
    lower_r, upper_r, sub, mdl, scene, out_dir, stats,
):  # fmt: skip
    """The nearest solvable direction on each side of each level-4 circle (one call).

    ``kinds`` (n,): the circles searched, in order (``PITCH_CIRCLE`` starts at e's pitch,
    ``YAW_CIRCLE`` at its yaw). Every side goes out from its start over ``offsets`` (the
    grid, rad) in blocks ending at ``block_ends``, all sides in turn, each block tested until
    its first solvable direction (the rest of the side is farther). With ``prune`` a side
    stops as soon as nothing it could still find costs less than the cheapest grid direction
    found so far on any side (bisection moves it by less than one grid step, ``fine``), so
    every side pays only for the directions up to the best answer.

    Slivers. A solvable arc narrower than the grid (a joint at its limit, the wrist nearly
    straight) can fall between two grid directions. Every grid direction is tested with the
    limits widened to ``lower_r``, ``upper_r`` first (what that rules out, as most
    directions, the limits rule out too), then as it is: arcs widen with the limits, so a
    grid direction solvable only when widened is a suspect. Each run of neighbouring
    suspects is scanned ``sub`` times finer from the grid step before it to the one after
    it, nearest run first, up to its first solvable direction (a hit like a grid one) or as
    long as it can still beat the best hit. ``stats[1]`` counts the runs scanned.

    The hits are refined by bisection to the boundary (``tol``). Writes the directions to
    ``out_dir``; returns how many. ``stats[0]`` counts the directions tested on the grid.
    """
    sc = search_scratch(lower, upper, mdl, scene[3], scene[4].shape[0])
    sc_r = search_scratch(lower_r, upper_r, mdl, scene[3], scene[4].shape[0])
    cos_pitch = math.cos(pitch)
    n_sides = 2 * kinds.shape[0]
    open_ = np.ones(n_sides, np.bool_)
    cap = out_dir.shape[0]
    hit_s = np.empty(cap, np.int64)
    hit_good = np.empty(cap)
    hit_bad = np.empty(cap)
    n_hits = 0
    n_sus = 0
    sus_s = np.empty(offsets.shape[0], np.int64)
    sus_k = np.empty(offsets.shape[0], np.int64)
    best = math.inf
    d = np.empty(3)
    start = 0
    for b in range(block_ends.shape[0] + 1):
        stop = block_ends[b] if b < block_ends.shape[0] else offsets.shape[0]
        for s in range(n_sides):
            if not open_[s]:
                continue
            kind, side, th0 = _circle_side(kinds, s, yaw, pitch)
            if prune and circle_cost(kind, max(offsets[start] - fine, 0.0), cos_pitch) > best:
                open_[s] = False
                continue
            for k in range(start, stop):
                stats[0] += 1
                circle_direction(kind, yaw, pitch, pole, th0 + side * offsets[k], d)
                # reach, then widened limits first: what they rule out (most directions) the
                # limits rule out too
                if not may_reach(p, d[0], d[1], d[2], a):
                    continue
                if not solvable(p, d[0], d[1], d[2], psi, a, mdl, sc_r, scene):
                    continue
                if solvable(p, d[0], d[1], d[2], psi, a, mdl, sc, scene):
                    hit_s[n_hits] = s
                    hit_good[n_hits] = side * offsets[k]
                    hit_bad[n_hits] = side * (offsets[k] - fine)
                    n_hits += 1
                    best = min(best, circle_cost(kind, offsets[k], cos_pitch))
                    open_[s] = False
                    break
                if n_sus < sus_s.shape[0]:
                    sus_s[n_sus] = s
                    sus_k[n_sus] = k
                    n_sus += 1
        start = stop
        if start >= offsets.shape[0] or not open_.any():
            break
    # the suspects' runs of neighbouring grid directions, nearest first: scan from the grid
    # step before a run to the one after it, until the first solvable direction
    order = np.argsort(sus_s[:n_sus] * (offsets.shape[0] + 2) + sus_k[:n_sus])
    run_s = np.empty(n_sus, np.int64)
    run_a = np.empty(n_sus, np.int64)
    run_b = np.empty(n_sus, np.int64)
    n_runs = 0
    for o in range(n_sus):
        s, k = sus_s[order[o]], sus_k[order[o]]
        if n_runs > 0 and run_s[n_runs - 1] == s and run_b[n_runs - 1] == k - 1:
            run_b[n_runs - 1] = k
        else:
            run_s[n_runs], run_a[n_runs], run_b[n_runs] = s, k, k
            n_runs += 1
    for o in np.argsort(offsets[run_a[:n_runs]]):
        if n_hits >= cap:
            break
        s = run_s[o]
        kind, side, th0 = _circle_side(kinds, s, yaw, pitch)
        x0 = offsets[run_a[o]] - fine  # the grid direction before: not solvable (or e)
        n_fine = (run_b[o] - run_a[o] + 2) * sub
        step = fine / sub
        stats[1] += 1
        for i in range(1, n_fine + 1):
            x = x0 + i * step
            if prune and circle_cost(kind, x - step, cos_pitch) > best:
                break
            circle_direction(kind, yaw, pitch, pole, th0 + side * x, d)
            if may_reach(p, d[0], d[1], d[2], a) and solvable(
                p, d[0], d[1], d[2], psi, a, mdl, sc, scene
            ):
                hit_s[n_hits] = s
                hit_good[n_hits] = side * x
                hit_bad[n_hits] = side * (x - step)
                n_hits += 1
                best = min(best, circle_cost(kind, x, cos_pitch))
                break
    n = 0
    for h in range(n_hits):
        s = hit_s[h]
        kind, side, th0 = _circle_side(kinds, s, yaw, pitch)
        good, bad = hit_good[h], hit_bad[h]
        if prune and circle_cost(kind, max(abs(good) - abs(good - bad), 0.0), cos_pitch) > best:
            continue
        good = _circle_bisect(
            kind, yaw, pitch, pole, th0, good, bad, tol, p, psi, a, mdl, sc, scene
        )
        circle_direction(kind, yaw, pitch, pole, th0 + good, out_dir[n])
        n += 1
    return n


@nb.njit(**JIT)
def circle_projections(
    p, psi, kinds, yaw, pitch, pole, dirs, best, fine, tol, a, lower, upper, mdl, scene,
    out_dir,
):  # fmt: skip
    """Level-4 directions from solvable ones: each of ``dirs`` projected onto each circle.

    Near the reach sphere the directions solvable at p form a small cap, which a circle can
    cross in an arc narrower than the grid, where no widened limit helps (the arm is nearly
    stretched). The directions of valid configurations that reach p lie in such caps; where
    one's projection onto a circle (the point of the circle at its yaw, or at its elevation
    in the plane of e's yaw) is solvable, bisection towards e (offset 0, not solvable)
    pins a boundary (``tol``). Projections whose arc cannot beat ``best`` (rad from e) by
    lying within one grid step ``fine`` of them are left out; ``best`` drops with every
    direction found. Writes the directions to ``out_dir``; returns how many.
    """
    sc = search_scratch(lower, upper, mdl, scene[3], scene[4].shape[0])
    cos_pitch = math.cos(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    d = np.empty(3)
    n = 0
    for s in range(kinds.shape[0]):
        kind = kinds[s]
        th0 = pitch if kind == PITCH_CIRCLE else yaw
        for i in range(dirs.shape[0]):
            if n >= out_dir.shape[0]:
                return n
            vx, vy, vz = dirs[i, 0], dirs[i, 1], dirs[i, 2]
            if kind == PITCH_CIRCLE:
                th = math.atan2(vz, vx * cy + vy * sy)
            else:
                th = math.atan2(vy, vx)
            x = wrap(th - th0)
            if circle_cost(kind, max(abs(x) - fine, 0.0), cos_pitch) > best:
                continue
            circle_direction(kind, yaw, pitch, pole, th0 + x, d)
            if not may_reach(p, d[0], d[1], d[2], a):
                continue
            if not solvable(p, d[0], d[1], d[2], psi, a, mdl, sc, scene):
                continue
            good = _circle_bisect(
                kind, yaw, pitch, pole, th0, x, 0.0, tol, p, psi, a, mdl, sc, scene
            )  # fmt: skip
            circle_direction(kind, yaw, pitch, pole, th0 + good, out_dir[n])
            n += 1
            best = min(best, circle_cost(kind, abs(good), cos_pitch))
    return n
