"""Obstacles along L: the stretches of a solution range that keep clear of a scene (numba).

The certification of ``_printed`` applied to the gaps of ``handarm._scene``: over a stretch
of u every envelope piece moves at most ``grow`` (its motion coefficients times the stretch's
motion), so a gap larger than ``grow`` at the middle proves the pair clear on the whole
stretch, a gap below ``-grow`` proves it blocked, and otherwise the stretch is halved down to
``TOL``, where the middle decides. Pairs proven clear are not tested again inside a stretch.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from handarm._collide import N_FRAMES
from handarm._scene import gap, piece_capsule
from handarm.ik._common import JIT
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
