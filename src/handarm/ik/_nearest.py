"""Numba kernels of degradation's nearest-point search (``handarm.ik.degrade``, level 2).

Valid configurations whose tool point comes nearest a point: seeds (the straight arm aimed
at it, ``current``, the nearest configurations of a cloud of valid ones) are polished
towards it within the limits (``handarm.ik._polish.polish_to_point``); where a polished
configuration collides under the printed-link model, the last valid point of the
joint-space segment from the start is kept and the polish restarted from there. One
compiled call for every seed: the Python loop spent more around each step than in it.

The nearest reachable point usually lies on a collision boundary, and a polish stops where
its step first meets one. Level 2 then *slides* (``slide``): a pattern search over valid
configurations that polls directions along the boundary as well as towards the point.
Every polished seed slides a little; the best few slide to the end (``slide_best``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm._collide import collides, scratch
from handarm.ik._common import INLINE, JIT
from handarm.ik._polish import polish_to_point, tool_point_and_jacobian, tool_pose

#: Restarts of one seed's polish after it ran into a collision.
RESTARTS = 4
#: Bisection steps for the last valid point of a segment.
BISECTIONS = 40
#: Cloud configurations tested for validity first, per one wanted: about 3 in 4 are valid.
#: The caller finds them with the cloud's k-d tree (``handarm.ik.degrade._cloud_tree``),
#: and where fewer are valid, the next nearest, ``NEAR_MORE`` times as many each time
#: (sorting the whole cloud instead took 3 ms where 19 of the 128 nearest a point were valid).
NEAR_FIRST = 4
NEAR_MORE = 4
#: Sliding: iterations for every polished seed, then (at most) for the best few of them.
SLIDE_FIRST = 60
SLIDE_BEST = 3
SLIDE_MAX = 10000
#: Joint-space step (rad) a slide starts with, its largest, and the one it ends below.
SLIDE_STEP, SLIDE_STEP_MAX, SLIDE_STEP_MIN = 0.05, 0.2, 1e-9
#: A slide ends when this many iterations brought the tool point less than SLIDE_GAIN (m) nearer.
#: Along a contact a slide can crawl for hundreds of iterations and then find its way on: with
#: 100 and 1e-10 m (and at most 3,000 iterations), 11 of an oracle's 20 level-2 misses on
#: random designs stayed farther, by up to 0.083 mm; with these, 9, by up to 0.081 mm, for the
#: same median time. ``bench_level2.py`` on the paper's arm was unchanged.
SLIDE_PATIENCE, SLIDE_GAIN = 1000, 1e-12
#: Turns (rad) of the steepest descent towards each null-space direction of the Jacobian.
_TILTS = (0.5, 1.0, 1.3, 1.5)
#: Random poll directions per iteration, besides the steered ones.
_RANDOM_POLLS = 8
#: Pattern moves (Hooke and Jeeves): the direction of the slide's net displacement over its
#: last 2, 4 and 8 moves is polled first. Along a curved contact single moves zig-zag and the
#: step shrinks; the net displacement points along the valley. Measured against an oracle's
#: configurations (bench_level2.py's three misses near the base axis, and 20 misses of a
#: second oracle on four designs): 3 -> 0 and 9 -> 3 remain farther, the worst 0.047 -> 0
#: and 0.081 -> 0.011 mm, and a level-2 answer is quicker (median 116 -> 92 ms there).
_TRENDS = (2, 4, 8)
_HISTORY = max(_TRENDS)  # moves remembered
#: Grazing polls: the steepest descent turned by these angles (rad: 89.9 and 89.99 deg)
#: towards ``_GRAZE_DIRS`` random directions across it. Where a contact blocks the descent
#: nearly head-on, the directions that stay valid and still descend form a wedge a few
#: hundredths of a degree wide around the contact's tangent plane, which no other poll
#: finds (one oracle case: a valid straight path to a point 5 um nearer, at 89.92 deg from
#: the descent). Turned that far, a random direction across the descent lands in the wedge
#: about as often as it points the contact's way along it. Measured on the second
#: oracle's 20 misses on four designs: 3 -> 0 remain farther (worst 0.011 mm -> 0).
_GRAZES = (1.569, 1.5706)
_GRAZE_DIRS = 8
_POLLS = 2 + len(_TRENDS) + 2 * 3 * len(_TILTS) + 12 + _RANDOM_POLLS + len(_GRAZES) * _GRAZE_DIRS


@nb.njit(**JIT)
def valid_one(q, a, lower, upper, pi, pf, groups, rows, c, sc):
    """Joint limits and the printed-link model at one configuration (``is_valid``)."""
    for j in range(6):
        if not lower[j] <= q[j] <= upper[j]:
            return False
    frames, xy, stamp, coef, motion = sc
    hit, _ = collides(q, a, pi, pf, groups, rows, c, frames, xy, stamp, coef, motion, 0)
    return not hit


@nb.njit(**JIT)
def _distance(q, target, a, p, jac):
    """|tool point of q - target|; p and jac get the tool point and its Jacobian."""
    tool_point_and_jacobian(q, a, p, jac)
    return math.sqrt((p[0] - target[0]) ** 2 + (p[1] - target[1]) ** 2 + (p[2] - target[2]) ** 2)


@nb.njit(**JIT)
def polish_valid(q0, target, a, lower, upper, steps, pi, pf, groups, rows, c, sc, out):
    """A valid configuration near the valid q0 whose tool point is nearer target, into out.

    As ``handarm.ik.degrade._polish``: returns (|tool point - target| (m), whether a
    collision cut the polish short).
    """
    q = q0.copy()
    x = np.empty(6)
    trial = np.empty(6)
    blocked = False
    for _ in range(RESTARTS):
        polish_to_point(q, target, a, lower, upper, steps, x)
        if valid_one(x, a, lower, upper, pi, pf, groups, rows, c, sc):
            q[:] = x
            break
        blocked = True
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
    return _distance(q, target, a, np.empty(3), np.empty((3, 6))), blocked


@nb.njit(**INLINE)
def _first_move(q, f, step, polls, start, stop, target, a, lower, upper, pi, pf, groups, rows,
                c, sc, trial, trial_p, trial_jac, hint):  # fmt: skip
    """The first of ``polls[start:stop]`` whose step from q stays valid and nears target.

    Returns (its index or -1, its distance from target or f, the collision group that
    blocked the last poll tested); its configuration is left in ``trial`` (tool point and
    Jacobian in trial_p, trial_jac). ``hint``: the group that blocked the poll before,
    tested first (``handarm._collide.collides``). The steps are clamped to the limits, so
    only collisions are tested.
    """
    frames, xy, stamp, coef, motion = sc
    for k in range(start, stop):
        for j in range(6):
            trial[j] = min(upper[j], max(lower[j], q[j] + step * polls[k, j]))
        ft = _distance(trial, target, a, trial_p, trial_jac)
        if ft < f - 1e-13:
            hit, which = collides(
                trial, a, pi, pf, groups, rows, c, frames, xy, stamp, coef, motion, hint
            )
            if not hit:
                return k, ft, hint
            hint = which
    return -1, f, hint


@nb.njit(**JIT)
def slide(q, target, a, lower, upper, pi, pf, groups, rows, c, sc, iters, step):
    """Pattern search from the valid q (changed in place) to valid configurations nearer target.

    Each iteration polls directions in joint space at the present step and moves along the
    first that stays valid and brings the tool point nearer: the net displacement of the
    last 2, 4 and 8 moves (``_TRENDS``, pattern moves), the last successful one, the
    steepest descent, the descent turned by each of ``_TILTS`` towards either side of each
    direction of the Jacobian's null space (along it the tool point stays put, so these
    creep along a collision boundary the descent runs into), each joint alone either way
    (the others held, so that a joint at its limit stays there: near the base axis the
    nearest point often has the wrist straight, sometimes joints 1 and 3 at their limits),
    ``_RANDOM_POLLS`` random directions, and the descent turned nearly square to random
    directions across it (``_GRAZES``: along a contact that blocks it). A move doubles the
    step (up to SLIDE_STEP_MAX), a miss halves it. It ends when the step falls below
    SLIDE_STEP_MIN, after ``iters`` iterations, or when SLIDE_PATIENCE iterations gained
    less than SLIDE_GAIN. Returns (distance, step).
    """
    p, trial_p = np.empty(3), np.empty(3)
    jac, trial_jac = np.empty((3, 6)), np.empty((3, 6))
    trial = np.empty(6)
    polls = np.empty((_POLLS, 6))
    last = np.zeros(6)
    has_last = False
    history = np.empty((_HISTORY, 6))  # the configurations before the last moves, a ring
    g, down = np.empty(6), np.empty(6)
    draws = np.empty((_RANDOM_POLLS + _GRAZE_DIRS, 6))
    hint = 0  # the collision group that blocked the last poll
    n_moves = 0
    f = _distance(q, target, a, p, jac)
    mark, mark_it = f, 0
    for it in range(iters):
        if step < SLIDE_STEP_MIN or f == 0.0:
            break
        if it - mark_it >= SLIDE_PATIENCE:
            if mark - f < SLIDE_GAIN:
                break
            mark, mark_it = f, it
        g[:] = 0.0
        for j in range(6):
            for k in range(3):
                g[j] += jac[k, j] * (p[k] - target[k])
        gn = math.sqrt(np.sum(g * g))
        n = 0
        for back in _TRENDS:
            if n_moves < back:
                continue
            before = history[(n_moves - back) % _HISTORY]
            norm = 0.0
            for j in range(6):
                polls[n, j] = q[j] - before[j]
                norm += polls[n, j] ** 2
            if norm > 0.0:
                polls[n] /= math.sqrt(norm)
                n += 1
        if has_last:
            polls[n] = last
            n += 1
        descent = -1
        if gn > 0.0:
            for j in range(6):
                down[j] = -g[j] / gn
            polls[n] = down
            descent = n
            n += 1
        # this iteration's random draws, in the order of the polls they make: drawn whether
        # or not those polls are reached, so the sequence is the same either way
        n_draws = _RANDOM_POLLS + (_GRAZE_DIRS if gn > 0.0 else 0)
        for r in range(n_draws):
            for j in range(6):
                draws[r, j] = np.random.standard_normal()  # noqa: NPY002
        # the polls that need no more than the gradient first: a move among them (a
        # pattern move along a contact, mostly) spares the rest, the null space's SVD
        # among them
        k_move, ft, hint = _first_move(
            q, f, step, polls, 0, n, target, a, lower, upper, pi, pf, groups, rows, c, sc, trial,
            trial_p, trial_jac, hint,
        )  # fmt: skip
        if k_move < 0:
            start = n
            if gn > 0.0:
                null = np.linalg.svd(jac)[2]  # rows 3..5 span the null space
                for k in range(3, 6):
                    for tilt in _TILTS:
                        for side in (-1.0, 1.0):
                            polls[n] = (
                                math.cos(tilt) * polls[descent] + side * math.sin(tilt) * null[k]
                            )
                            n += 1
            for j in range(12):  # single joints: a joint at its limit stays there
                polls[n] = 0.0
                polls[n, j % 6] = 1.0 if j < 6 else -1.0
                n += 1
            for r in range(_RANDOM_POLLS):
                v = draws[r]
                polls[n] = v / math.sqrt(np.sum(v * v))
                n += 1
            if gn > 0.0:
                for r in range(_GRAZE_DIRS):  # grazing the contact that blocks the descent
                    v = draws[_RANDOM_POLLS + r].copy()
                    v -= np.sum(v * down) * down
                    v /= math.sqrt(np.sum(v * v))
                    for tilt in _GRAZES:
                        polls[n] = math.cos(tilt) * down + math.sin(tilt) * v
                        n += 1
            k_move, ft, hint = _first_move(
                q, f, step, polls, start, n, target, a, lower, upper, pi, pf, groups, rows, c, sc,
                trial, trial_p, trial_jac, hint,
            )  # fmt: skip
        moved = k_move >= 0
        if moved:
            history[n_moves % _HISTORY] = q
            n_moves += 1
            q[:] = trial
            p[:], jac[:] = trial_p, trial_jac
            f = ft
            last[:] = polls[k_move]
            has_last = True
        step = min(2.0 * step, SLIDE_STEP_MAX) if moved else 0.5 * step
    return f, step


@nb.njit(**JIT)
def slide_best(target, a, lower, upper, pi, pf, groups, rows, c, out_q, out_err, blocked, n):
    """Rows of ``out_q[:n]`` whose polish a collision cut short slide; the best slide on.

    Each such row (``blocked``) slides SLIDE_FIRST iterations, then the SLIDE_BEST nearest
    of them slide on to the end. A polish no collision stopped ended where the limits and the
    distance allow no further step, and a slide (which polls within the same limits) would
    find none either. Rows and their distances ``out_err`` are updated in place. The
    random polls are seeded here, so that an answer does not depend on earlier calls.
    """
    if not blocked[:n].any():
        return
    np.random.seed(20261127)  # noqa: NPY002 (seeds numba's state on this thread only)
    sc = scratch(pi.shape[0])
    steps = np.full(n, SLIDE_STEP)
    for i in range(n):
        if out_err[i] < np.inf and blocked[i]:
            out_err[i], steps[i] = slide(
                out_q[i], target, a, lower, upper, pi, pf, groups, rows, c, sc, SLIDE_FIRST,
                SLIDE_STEP,
            )  # fmt: skip
    order = np.argsort(np.where(blocked[:n], out_err[:n], np.inf))
    for i in order[:SLIDE_BEST]:
        if out_err[i] < np.inf and blocked[i]:
            out_err[i], _ = slide(
                out_q[i], target, a, lower, upper, pi, pf, groups, rows, c, sc, SLIDE_MAX,
                max(steps[i], SLIDE_STEP_MIN),
            )  # fmt: skip


@nb.njit(**JIT)
def tool_poses(q, a):
    """``tool_pose`` of each configuration of q (n, 6): rows (n, 8) of point, direction, joint 4."""
    out = np.empty((q.shape[0], 8))
    for i in range(q.shape[0]):
        tool_pose(q[i], a, out[i])
    return out


@nb.njit(**JIT)
def polish_each(
    seeds, cloud_q, known, near, n_cloud, target, a, lower, upper, steps, pi, pf, groups, rows,
    c, out_q, out_err, out_blocked,
):  # fmt: skip
    """Every seed polished towards target: the seeds, then valid cloud configurations.

    ``seeds`` (m, 6): starting configurations, each used if valid; then the first
    ``n_cloud`` valid configurations of ``cloud_q[near]`` (within the limits, tested here in
    that order, so the cloud needs no validity test of its own; the caller passes the
    indices of those nearest target, nearest first). ``known`` (int8, one per cloud row):
    the cloud's validity as far as tested, -1 where not yet; filled in here, so that the
    next target near this one (a control loop) tests none of them again. Row i of
    ``out_q`` / ``out_err`` / ``out_blocked`` gets the polished configuration, its distance
    from target (inf for an invalid seed) and whether a collision cut its polish short.
    Returns the number of rows filled (m + at most n_cloud): fewer than that, and the
    caller passes the next nearest.
    """
    sc = scratch(pi.shape[0])
    n = 0
    for i in range(seeds.shape[0]):
        out_err[n] = np.inf
        out_blocked[n] = False
        if valid_one(seeds[i], a, lower, upper, pi, pf, groups, rows, c, sc):
            out_err[n], out_blocked[n] = polish_valid(
                seeds[i], target, a, lower, upper, steps, pi, pf, groups, rows, c, sc, out_q[n]
            )
        n += 1
    found = 0
    for i in near:
        if found == n_cloud:
            break
        if known[i] < 0:
            known[i] = valid_one(cloud_q[i], a, lower, upper, pi, pf, groups, rows, c, sc)
        if known[i] == 0:
            continue
        out_err[n + found], out_blocked[n + found] = polish_valid(
            cloud_q[i], target, a, lower, upper, steps, pi, pf, groups, rows, c, sc,
            out_q[n + found],
        )  # fmt: skip
        found += 1
    return n + found
