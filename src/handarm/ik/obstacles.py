"""Solution ranges that keep clear of a scene's obstacles.

``solve_in_scene`` takes the exact solution ranges of a target (joint limits and the
design's collision model) and removes from each every stretch of u where a printed link's
envelope comes within ``clearance`` of an obstacle (``handarm.scene``), certified as the
printed-link model is (``_obstacles``): no change of clearance sign wider than 5e-10 m of u
is missed. What remains is returned with, per range, the smallest and largest clearance found
at 65 evenly spaced points inside it and the u of the largest.

Rules: each range's representative (``solutions``) is its sampled configuration of greatest
clearance; ``follow`` (with ``current``) is the configuration inside the ranges nearest to
``current`` in joint space, as without a scene, so that a control loop moves smoothly.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from handarm.design import ArmDesign
from handarm.ik import _solve as K
from handarm.ik._common import VERTICAL_EPS, horizontal_lengths
from handarm.ik._obstacles import (
    SAMPLES,
    SPLIT_CAP,
    clear_ranges,
    count_many_in_scene,
    obstacle_scratch,
)
from handarm.ik.exact import (
    _check_batch,
    _exact,
    _line_direction,
    _model,
    check_clearance,
    check_inputs,
    follow_configuration,
)
from handarm.ik.results import MAX_SOLUTIONS, BatchResult, IKResult
from handarm.scene import Scene, _check_scene, _kernel_args, scene_gaps

__all__ = ["count_in_scene", "solve_batch_in_scene", "solve_in_scene"]


def solve_in_scene(
    design: ArmDesign, p, e, scene: Scene, clearance: float = 0.0, current=None
) -> IKResult:
    """Every solution range of (p, e) that keeps ``clearance`` from the scene.

    Parameters
    ----------
    design : ArmDesign
    p, e : array-like, shape (3,)
        Tool point (m) and direction, in the handle frame.
    scene : Scene
        Obstacles in the handle frame.
    clearance : float
        Distance (m) the printed links keep from every obstacle.
    current : array-like, shape (6,), optional
        As in ``solve``.

    Returns
    -------
    IKResult
        With ``clearances`` (k, 2): smallest and largest sampled clearance (m) of each range,
        and ``clearest`` (k,): the u of the largest. Empty when every solution meets an
        obstacle (``blocked_by`` then names the obstacles that block the exact solutions).

    Raises
    ------
    ValueError, TypeError
        For bad targets, a scene that is not in the handle frame, or a bad clearance.
    """
    p, e, current = check_inputs(design, p, e, current)
    scene = _check_scene(scene)
    c = check_clearance(clearance, scene)
    free = _exact(design, p, e, current)
    if len(scene) == 0 or free.count == 0:
        return dataclasses.replace(
            free,
            clearances=np.full((free.count, 2), np.inf),
            clearest=0.5 * free.intervals.sum(axis=1) if free.count else np.zeros(0),
        )
    pi, pf, n_pieces, coef = _kernel_args(design)
    obs = scene.obstacles
    a = design.lengths
    sc = obstacle_scratch(n_pieces * len(obs))
    fr = np.empty(K.FRAMES_SIZE)
    sub = np.empty((SPLIT_CAP, 2))
    q = np.empty(6)
    sols, brs, ivs, cls, best_u = [], [], [], [], []
    blocked = np.zeros(len(obs), bool)
    for br, (lo, hi) in zip(free.branches, free.intervals, strict=True):
        dx, dy = _line_direction(p, e, br[0], free.azimuth)
        K._frames(p, e, dx, dy, a, fr)
        n = clear_ranges(
            fr,
            dx,
            dy,
            lo,
            hi,
            float(br[1]),
            float(br[2]),
            a,
            pi,
            pf,
            coef,
            n_pieces,
            obs,
            c,
            sc,
            sub,
        )
        if n < 0:
            raise RuntimeError("solve_in_scene: a range split into more pieces than supported")
        for r_lo, r_hi in sub[:n]:
            # inside the range: its ends are exact to 5e-10 m, not on the valid side
            us = r_lo + (r_hi - r_lo) * (np.arange(SAMPLES) + 0.5) / SAMPLES
            qs = np.empty((SAMPLES, 6))
            ok = np.empty(SAMPLES, np.bool_)
            K.configurations_along_u(p, e, dx, dy, us, float(br[1]), float(br[2]), a, qs, ok)
            if not ok.any():
                continue
            gaps = np.full(SAMPLES, -np.inf)
            gaps[ok] = scene_gaps(design, qs[ok], scene, c).min(axis=-1) + c
            good = ok & (gaps >= c)  # inside an exact range: valid
            if not good.any():
                continue  # a merged hair of a range: nothing usable inside
            k = int(np.argmax(np.where(good, gaps, -np.inf)))
            sol = qs[k].copy()
            K.snap_to_limits(sol, design.lower, design.upper)  # a range ending at a limit
            sols.append(sol)
            brs.append(br)
            ivs.append((r_lo, r_hi))
            cls.append((gaps[ok].min(), gaps[ok].max()))
            best_u.append(us[k])
    if not sols:
        # which obstacles block the exact ranges at their middles, for the message
        for br, (lo, hi) in zip(free.branches, free.intervals, strict=True):
            dx, dy = _line_direction(p, e, br[0], free.azimuth)
            u = 0.5 * (lo + hi)
            if K.configuration_at_u(p, e, dx, dy, u, float(br[1]), float(br[2]), a, q):
                blocked |= scene_gaps(design, q, scene, c) < 0
        return IKResult(
            np.zeros((0, 6)), np.zeros((0, 3), int), np.zeros((0, 2)), 5, 0.0, 0.0,
            free.vertical, free.azimuth, p.copy(), e.copy(), None,
            clearances=np.zeros((0, 2)), clearest=np.zeros(0),
            blocked_by=tuple(name for name, b in zip(scene.names, blocked, strict=True) if b),
        )  # fmt: skip
    sols, brs, ivs = np.array(sols), np.array(brs, int), np.array(ivs)
    cls, best_u = np.array(cls), np.array(best_u)
    order = np.lexsort((ivs[:, 0], brs[:, 2], brs[:, 1], brs[:, 0]))
    if current is not None:
        order = np.argsort(np.sum((sols - current) ** 2, axis=1), kind="stable")
    sols, brs, ivs, cls, best_u = sols[order], brs[order], ivs[order], cls[order], best_u[order]
    follow = None
    if current is not None:
        follow = follow_configuration(design, p, e, sols, brs, ivs, current, free.azimuth)
    return IKResult(
        sols, brs, ivs, 5, 0.0, 0.0, free.vertical, free.azimuth, p.copy(), e.copy(), follow,
        clearances=cls, clearest=best_u,
    )  # fmt: skip


def count_in_scene(
    design: ArmDesign, P, E, scene: Scene, clearance: float = 0.0, *, min_width: float = 0.0
) -> np.ndarray:
    """Number of solution ranges of each of N targets that keep ``clearance`` from the scene.

    The count ``solve_in_scene`` returns for each target (without ``current``), computed in
    parallel without storing any range, so that workspace maps can be made in a scene.
    Ranges narrower than ``min_width`` (m of u) are not counted. Shape (N,), int.
    """
    scene = _check_scene(scene)
    c = check_clearance(clearance, scene)
    if len(scene) == 0:
        from handarm.ik.exact import count_solutions

        return count_solutions(design, P, E, min_width=min_width)
    P, E, psi = _check_batch(design, P, E)
    counts = np.zeros(len(P), np.int64)
    if len(P) == 0:
        return counts
    pi, pf, n_pieces, coef = _kernel_args(design)
    count_many_in_scene(
        np.ascontiguousarray(P), np.ascontiguousarray(E), psi, design.lengths,
        design.lower, design.upper, counts, _model(design, min_width),
        pi, pf, coef, n_pieces, scene.obstacles, c,
    )  # fmt: skip
    for i in np.flatnonzero(counts < 0):  # more ranges than the kernel's buffers hold
        r = solve_in_scene(design, P[i], E[i], scene, c)
        counts[i] = int(np.sum(r.intervals[:, 1] - r.intervals[:, 0] >= min_width))
    return counts


def solve_batch_in_scene(
    design: ArmDesign, P, E, scene: Scene, clearance: float = 0.0
) -> BatchResult:
    """``solve_batch`` in a scene: each row holds what ``solve_in_scene`` returns.

    Targets are counted in parallel first (``count_in_scene``); only those with a clear
    range are then solved one by one, so a batch mostly blocked or out of reach costs
    little. Representatives are each range's clearest sampled configuration.
    """
    counts = count_in_scene(design, P, E, scene, clearance)
    P, E, psi = _check_batch(design, P, E)
    vertical = horizontal_lengths(E) < VERTICAL_EPS
    # the azimuth of L: e's own, or for a vertical e the one its solve used (else psi's)
    azimuth = np.where(vertical, psi, np.arctan2(E[:, 1], E[:, 0]))
    width = max(MAX_SOLUTIONS, int(counts.max(initial=0)))
    sols = np.full((len(P), width, 6), np.nan)
    br = np.zeros((len(P), width, 3), np.int8)
    iv = np.full((len(P), width, 2), np.nan)
    for i in np.flatnonzero(counts):
        r = solve_in_scene(design, P[i], E[i], scene, clearance)
        counts[i], azimuth[i] = r.count, r.azimuth
        sols[i, : r.count], br[i, : r.count], iv[i, : r.count] = (
            r.solutions,
            r.branches,
            r.intervals,
        )
    return BatchResult(counts, sols, br, iv, np.zeros(len(P), bool), vertical, azimuth)
