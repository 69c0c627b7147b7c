"""Numba kernels of degradation's nearest-point search (``handarm.ik.degrade``, level 2).

Valid configurations whose tool point comes nearest a point: seeds (the straight arm aimed
at it, ``current``, the nearest configurations of a cloud of valid ones) are polished
towards it within the limits (``handarm.ik._polish.polish_to_point``); where a polished
configuration collides under the printed-link model, the last valid point of the
joint-space segment from the start is kept and the polish restarted from there. One
compiled call for every seed: the Python loop spent more around each step than in it.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm._collide import collides, scratch
from handarm.ik._common import JIT
from handarm.ik._polish import polish_to_point, tool_pose

#: Restarts of one seed's polish after it ran into a collision.
RESTARTS = 4
#: Bisection steps for the last valid point of a segment.
BISECTIONS = 40
#: Cloud configurations tested for validity first, per one wanted: about 3 in 4 are valid.
NEAR_FIRST = 40


@nb.njit(**JIT)
def valid_one(q, a, lower, upper, pi, pf, groups, rows, c, sc):
    """Joint limits and the printed-link model at one configuration (``is_valid``)."""
    for j in range(6):
        if not lower[j] <= q[j] <= upper[j]:
            return False
    frames, xy, stamp, coef, motion = sc
    return not collides(q, a, pi, pf, groups, rows, c, frames, xy, stamp, coef, motion)


@nb.njit(**JIT)
def polish_valid(q0, target, a, lower, upper, steps, pi, pf, groups, rows, c, sc, out):
    """A valid configuration near the valid q0 whose tool point is nearer target, into out.

    As ``handarm.ik.degrade._polish``: returns |tool point - target| (m).
    """
    q = q0.copy()
    x = np.empty(6)
    trial = np.empty(6)
    for _ in range(RESTARTS):
        polish_to_point(q, target, a, lower, upper, steps, x)
        if valid_one(x, a, lower, upper, pi, pf, groups, rows, c, sc):
            q[:] = x
            break
        lo, hi = 0.0, 1.0
        for _ in range(BISECTIONS):
            mid = 0.5 * (lo + hi)
            for j in range(6):
                trial[j] = q[j] + mid * (x[j] - q[j])
            if valid_one(trial, a, lower, upper, pi, pf, groups, rows, c, sc):
                lo = mid
            else:
                hi = mid
        if lo < 1e-9:
            break
        for j in range(6):
            q[j] = q[j] + lo * (x[j] - q[j])
    out[:] = q
    pose = np.empty(8)
    tool_pose(q, a, pose)
    return math.sqrt(
        (pose[0] - target[0]) ** 2 + (pose[1] - target[1]) ** 2 + (pose[2] - target[2]) ** 2
    )


@nb.njit(**JIT)
def tool_points(q, a):
    """Tool points (n, 3) of the configurations q (n, 6) (``forward``'s, one at a time)."""
    out = np.empty((q.shape[0], 3))
    pose = np.empty(8)
    for i in range(q.shape[0]):
        tool_pose(q[i], a, pose)
        out[i, 0], out[i, 1], out[i, 2] = pose[0], pose[1], pose[2]
    return out


@nb.njit(**JIT)
def nearest_cloud(cloud_p, target, k, out):
    """Indices (into ``out``) of the k points of ``cloud_p`` (n, 3) nearest target, nearest first.

    Returns how many were found (min(k, n)).
    """
    n = cloud_p.shape[0]
    dist = np.full(k, np.inf)
    m = 0
    for i in range(n):
        d = (
            (cloud_p[i, 0] - target[0]) ** 2
            + (cloud_p[i, 1] - target[1]) ** 2
            + (cloud_p[i, 2] - target[2]) ** 2
        )
        if m < k or d < dist[m - 1]:
            j = min(m, k - 1)
            while j > 0 and dist[j - 1] > d:
                dist[j] = dist[j - 1]
                out[j] = out[j - 1]
                j -= 1
            dist[j] = d
            out[j] = i
            m = min(m + 1, k)
    return m


@nb.njit(**JIT)
def polish_each(
    seeds, cloud_q, cloud_p, n_cloud, target, a, lower, upper, steps, pi, pf, groups, rows, c,
    out_q, out_err,
):  # fmt: skip
    """Every seed polished towards target: the seeds, then the nearest cloud configurations.

    ``seeds`` (m, 6): starting configurations, each used if valid; then the ``n_cloud``
    valid configurations of ``cloud_q`` (within the limits, tested here nearest first, so
    the cloud needs no validity test of its own) whose points ``cloud_p`` lie nearest
    target, nearest first. Row i of ``out_q`` / ``out_err`` gets the polished configuration
    and its distance from target (inf for an invalid seed). Returns the number of rows
    filled (m + at most n_cloud).
    """
    sc = scratch(pi.shape[0])
    n = 0
    for i in range(seeds.shape[0]):
        out_err[n] = np.inf
        if valid_one(seeds[i], a, lower, upper, pi, pf, groups, rows, c, sc):
            out_err[n] = polish_valid(
                seeds[i], target, a, lower, upper, steps, pi, pf, groups, rows, c, sc, out_q[n]
            )
        n += 1
    if n_cloud <= 0:
        return n
    # the nearest NEAR_FIRST * n_cloud first; all of them, in order, if too few are valid
    k = min(NEAR_FIRST * n_cloud, cloud_p.shape[0])
    idx = np.empty(k, np.int64)
    m = nearest_cloud(cloud_p, target, k, idx)
    env = (pi, pf, groups, rows, c, sc)
    found = _polish_valid_of(idx[:m], cloud_q, n_cloud, target, a, lower, upper, steps, env,
                             out_q, out_err, n)  # fmt: skip
    if found < n_cloud and m < cloud_p.shape[0]:
        order = np.argsort(np.sum((cloud_p - target) ** 2, axis=1), kind="mergesort")
        found = _polish_valid_of(order, cloud_q, n_cloud, target, a, lower, upper, steps, env,
                                 out_q, out_err, n)  # fmt: skip
    return n + found


@nb.njit(**JIT)
def _polish_valid_of(order, cloud_q, n_cloud, target, a, lower, upper, steps, env, out_q, out_err,
                     n):  # fmt: skip
    """The first ``n_cloud`` valid of ``cloud_q[order]`` polished into rows n.. (their count)."""
    pi, pf, groups, rows, c, sc = env
    found = 0
    for i in order:
        if found == n_cloud:
            break
        if not valid_one(cloud_q[i], a, lower, upper, pi, pf, groups, rows, c, sc):
            continue
        out_err[n + found] = polish_valid(
            cloud_q[i], target, a, lower, upper, steps, pi, pf, groups, rows, c, sc,
            out_q[n + found],
        )  # fmt: skip
        found += 1
    return found
