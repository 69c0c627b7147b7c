"""Obstacles along L: the stretches of a solution range that keep clear of a scene (numba).

The certification of ``_printed`` applied to the gaps of ``handarm._scene``: over a stretch
of u every envelope piece moves at most ``grow`` (its motion coefficients times the stretch's
motion), so a gap larger than ``grow`` at the middle proves the pair clear on the whole
stretch, a gap below ``-grow`` proves it blocked, and otherwise the stretch is halved down to
``TOL``, where the middle decides. Pairs proven clear are not tested again inside a stretch.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm._collide import N_FRAMES, place_frames
from handarm._scene import gap, gaps_at, piece_capsule
from handarm.ik._common import JIT, VERTICAL_EPS, horizontal
from handarm.ik._printed import (
    _MAX_BREAKS,
    _STACK,
    TOL,
    add_free,
    pose_frames,
    split_stretch,
    stretch_motion,
    stretch_setup,
)
from handarm.ik._printed import configuration as _configuration
from handarm.ik._solve import FRAMES_SIZE, _frames, _solve_any_azimuth, _workspace


@nb.njit(**JIT)
def obstacle_scratch(n_pairs):
    """Scratch arrays of ``clear_ranges``."""
    return (
        np.empty((_STACK, 2)),
        np.empty((_STACK, 2, 8)),
        np.empty((_STACK, n_pairs), np.bool_),  # pairs still unsure
        np.zeros((N_FRAMES, 4)),
        np.empty(5),
        np.empty((_MAX_BREAKS, 8)),
        np.empty(_MAX_BREAKS),
    )


@nb.njit(**JIT)
def _status(frames, pi, pf, coef, n_pieces, obs, c, motion, moving, mask, out_mask):
    """(blocked, any unsure) over the unsure pairs in ``mask``; fills ``out_mask``."""
    n_obs = obs.shape[0]
    unsure = False
    for k in range(n_pieces):
        todo = False
        for o in range(n_obs):
            if mask[k * n_obs + o]:
                todo = True
                break
        if not todo:
            for o in range(n_obs):
                out_mask[k * n_obs + o] = False
            continue
        ax, ay, az, bx, by, bz, rho = piece_capsule(k, frames, pi, pf)
        grow = 0.0
        if moving:
            g0 = 0.0
            g1 = 0.0
            for j in range(5):
                g0 += coef[k, 0, j] * motion[j]
                g1 += coef[k, 1, j] * motion[j]
            grow = min(g0, g1)
        for o in range(n_obs):
            r = k * n_obs + o
            out_mask[r] = False
            if not mask[r]:
                continue
            g = gap(ax, ay, az, bx, by, bz, rho, obs[o], c)
            if g + grow < 0.0 or (not moving and g < 0.0):
                return True, False
            if g - grow <= 0.0 and moving:
                out_mask[r] = True
                unsure = True
    return False, unsure


@nb.njit(**JIT)
def clear_ranges(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, pi, pf, coef, n_pieces, obs, c, sc, out):
    """The maximal stretches of [lo, hi] (a solution range) that keep clear of ``obs``.

    Returns their number in ``out``, or -1 if ``out`` or the stack is full. Stretches closer
    than MERGE_GAP are one.
    """
    st_u, st_v, st_mask, frames, motion, bv, breaks = sc
    nbk = stretch_setup(fr, dx, dy, lo, hi, elbow_b, elbow_e, a, frames, st_v, bv, breaks)
    if nbk < 0:
        return -1 if nbk < -1 else 0
    st_u[0, 0], st_u[0, 1] = lo, hi
    st_mask[0, :] = True
    top = 1
    n_out = 0
    child = np.empty(st_mask.shape[1], np.bool_)
    while top > 0:
        top -= 1
        ua, ub = st_u[top, 0], st_u[top, 1]
        um = 0.5 * (ua + ub)
        ok, m0, m1, m2, m3, m4, m5, m6, m7 = pose_frames(
            fr, dx, dy, um, elbow_b, elbow_e, a, frames
        )
        if not ok:
            continue
        narrow = ub - ua <= TOL
        if not narrow:
            stretch_motion(
                st_v, top, ua, ub, m0, m1, m2, m3, m4, m5, m6, m7, breaks, bv, nbk, motion
            )
        blocked, unsure = _status(
            frames, pi, pf, coef, n_pieces, obs, c, motion, not narrow, st_mask[top], child
        )
        if blocked:
            continue
        if not unsure:
            n_out = add_free(out, 0, n_out, ua, ub)
            if n_out < 0:
                return -1
            continue
        if top + 2 > st_u.shape[0]:
            return -1
        split_stretch(st_u, st_v, top, ua, um, ub, m0, m1, m2, m3, m4, m5, m6, m7)
        st_mask[top + 1, :] = child
        st_mask[top, :] = child
        top += 2
    return n_out


_SCENE_CAP = 64  # free ranges of one target held for the scene; more falls back to Python
SPLIT_CAP = 64  # clear stretches of one range (as ``solve_in_scene``)
SAMPLES = 65  # points inside each clear stretch (``solve_in_scene`` keeps one if any is clear)


@nb.njit(**JIT)
def _count_target(p, e, psi, a, work, mdl, pi, pf, coef, n_pieces, obs, c, min_width, bufs):
    """Clear stretches of one target's solution ranges, as ``solve_in_scene`` counts them.

    A stretch counts when it is at least ``min_width`` wide and one of its ``SAMPLES``
    interior points keeps ``c`` from every obstacle (checked with ``gaps_at`` on the
    placed configuration, exactly as ``scene_gaps`` does). Returns -1 on a full buffer.
    """
    q, br, iv, used, fr, sub, sc, qs, frames, gaps = bufs
    n = _solve_any_azimuth(p, e, psi, a, q, br, iv, used, work, mdl, False)
    if n < 0 or n > q.shape[0]:
        return -1
    h = horizontal(e[0], e[1])
    count = 0
    for k in range(n):
        sign = float(br[k, 0])
        if h >= VERTICAL_EPS:
            dx, dy = sign * e[0] / h, sign * e[1] / h
        else:
            dx, dy = sign * math.cos(used[0]), sign * math.sin(used[0])
        elbow_b, elbow_e = float(br[k, 1]), float(br[k, 2])
        _frames(p, e, dx, dy, a, fr)
        m = clear_ranges(
            fr, dx, dy, iv[k, 0], iv[k, 1], elbow_b, elbow_e, a,
            pi, pf, coef, n_pieces, obs, c, sc, sub,
        )  # fmt: skip
        if m < 0:
            return -1
        for j in range(m):
            lo, hi = sub[j, 0], sub[j, 1]
            if hi - lo < min_width:
                continue
            for i in range(SAMPLES):
                u = lo + (hi - lo) * (i + 0.5) / SAMPLES
                if not _configuration(fr, dx, dy, u, elbow_b, elbow_e, a, qs):
                    continue
                place_frames(qs, a, 0.0, frames)
                gaps_at(frames, pi, pf, n_pieces, obs, c, gaps)
                if np.min(gaps) + c >= c:
                    count += 1
                    break
    return count


@nb.njit(**JIT)
def count_scratch(n_pieces, n_obs):
    """The buffers of ``_count_target`` for one thread (at least one obstacle's worth)."""
    return (
        np.empty((_SCENE_CAP, 6)),
        np.empty((_SCENE_CAP, 3), np.int8),
        np.empty((_SCENE_CAP, 2)),
        np.empty(1),
        np.empty(FRAMES_SIZE),
        np.empty((SPLIT_CAP, 2)),
        obstacle_scratch(n_pieces * max(n_obs, 1)),
        np.empty(6),
        np.zeros((N_FRAMES, 4)),
        np.empty(max(n_obs, 1)),
    )


@nb.njit(parallel=True, **JIT)
def count_many_in_scene(P, E, psi, a, lower, upper, counts, mdl, pi, pf, coef, n_pieces, obs, c):
    """``count_many`` with a scene: clear stretches of every target's ranges, in parallel."""
    n = P.shape[0]
    block = 64
    n_blocks = (n + block - 1) // block
    min_width = mdl[-1]
    for b in nb.prange(n_blocks):
        work = _workspace(lower, upper, mdl[1].shape[0])
        bufs = count_scratch(n_pieces, obs.shape[0])
        for i in range(b * block, min(n, (b + 1) * block)):
            counts[i] = _count_target(
                P[i], E[i], psi[i], a, work, mdl, pi, pf, coef, n_pieces, obs, c, min_width, bufs
            )
