"""The exact 5-DoF IK core (paper section III): every solution range, no degradation.

A target is a tool point ``p`` and a tool direction ``e``. Link l3 lies on the line
L = {F + u d}, F = (p_x, p_y, 0), d = +-h/|h| with h the horizontal part of e; u is the
coordinate of joint 4 along L. For each branch (sign of d, elbow of B, elbow of E) the
valid u form a union of intervals, found exactly (the numba kernels ``_solve``,
``_classify``, ``_events``); every interval is a *solution range* and its midpoint the
representative solution.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from handarm._checks import check_array, check_design, check_joints, check_number, real_array
from handarm.collision import kernel_coefficients, kernel_env, kernel_far, kernel_tables
from handarm.design import ArmDesign
from handarm.ik import _solve as K
from handarm.ik._common import VERTICAL_EPS, horizontal_length, horizontal_lengths, wrap
from handarm.ik.results import MAX_SOLUTIONS, BatchResult, IKResult
from handarm.kinematics import forward, is_valid, joint_positions

__all__ = [
    "solve_exact",
    "solve_batch",
    "solve_batch_iter",
    "count_solutions",
    "branch_of",
    "configuration_at",
    "configurations_along",
    "follow_configuration",
    "check_target",
]

_SINGLE_CAPACITY = 256
_BATCH_CHUNK = 65536


def branch_of(design: ArmDesign, q) -> tuple[np.ndarray, np.ndarray]:
    """Branch signs and u of configurations, relative to the pose they reach.

    Parameters
    ----------
    design : ArmDesign
    q : array-like, shape (..., 6)

    Returns
    -------
    branch : ndarray of int, shape (..., 3)
        (sign of d, elbow of B, elbow of E) as in ``IKResult.branches``; d is l3's direction
        and its sign compares it with the horizontal part of the tool direction.
    u : ndarray, shape (...,)
        Coordinate of joint 4 along L from F = (p_x, p_y, 0) (m).
    """
    check_design(design)
    q = check_joints(q)
    p, e = forward(design, q)
    return branch_from_pose(q, p, e, joint_positions(design, q)[..., 4, :2])


def branch_from_pose(q, p, e, j4) -> tuple[np.ndarray, np.ndarray]:
    """``branch_of`` from the pose q reaches: tool point p, direction e, joint 4's (x, y)."""
    psi = q[..., 0] + q[..., 1] + q[..., 2]
    d = np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    along = np.sum(d * e[..., :2], axis=-1)
    sign = np.where(along >= 0.0, 1, -1)
    u = np.sum((j4 - p[..., :2]) * d, axis=-1)
    branch = np.stack(
        [sign, np.where(q[..., 1] >= 0.0, 1, -1), np.where(q[..., 4] >= 0.0, 1, -1)], axis=-1
    )
    return branch, u


def check_target(
    p, e, p_name: str = "p", e_name: str = "e", first: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Checked float arrays (..., 3) of points and unit directions; ValueError naming them.

    ``first``: the row number of the first row (a chunk of a larger batch names its rows as
    the batch numbers them).
    """
    p = check_array(p, p_name, 3)
    e = check_array(e, e_name, 3)
    # scale by the largest component first: neither 1e154 (whose square overflows) nor
    # 1e-13 (a tiny but perfectly good direction) is a problem then
    big = np.max(np.abs(e), axis=-1, keepdims=True)
    bad = big[..., 0] == 0.0
    if np.any(bad):
        where = "" if e.ndim == 1 else f"[{first + int(np.flatnonzero(bad.reshape(-1))[0])}]"
        raise ValueError(f"{e_name}{where}: direction has zero length")
    e = e / big
    return p, e / np.linalg.norm(e, axis=-1, keepdims=True)


#: A position farther than this many times the arm's reach (sum of link lengths) from joint 1
#: is taken for a unit mistake (millimetres for metres) and rejected.
REACH_FACTOR = 100.0
#: Joint angles beyond this (rad) are taken for degrees passed as radians and rejected.
MAX_JOINT_ANGLE = 2.0 * math.pi


def check_scale(design: ArmDesign, p: np.ndarray, name: str = "p", first: int = 0) -> None:
    """ValueError naming ``name`` if a point lies beyond REACH_FACTOR x the arm's reach.

    ``first``: the row number of p's first row (as in ``check_target``).
    """
    reach = float(np.sum(design.lengths))
    # norm as big x norm(p / big): no overflow inside the norm; a distance past the float
    # maximum is inf (and far), without a warning
    big = np.abs(p).max(axis=-1, keepdims=True)
    unit = np.divide(p, big, out=np.zeros_like(p), where=big > 0)
    with np.errstate(over="ignore"):
        dist = big[..., 0] / max(reach, 1e-300) * np.linalg.norm(unit, axis=-1)
    far = dist > REACH_FACTOR
    if np.any(far):
        where = "" if p.ndim == 1 else f"[{first + int(np.flatnonzero(far.reshape(-1))[0])}]"
        raise ValueError(
            f"{name}{where}: {float(np.max(dist)):.3g} x the arm's reach ({reach:g} m) away; "
            f"positions are metres and must lie within {REACH_FACTOR:g} x the reach"
        )


def check_clearance(clearance, scene) -> float:
    """``clearance`` (m) as a float: a distance in [0, 1] m, kept from ``scene``'s obstacles.

    Without a scene there is nothing to keep it from: any value but 0 is a mistake (a
    clearance meant for the links, say), refused as the CLI refuses ``--clearance`` without
    ``--scene``.
    """
    if isinstance(clearance, (bool, np.bool_)) or not isinstance(
        clearance, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"clearance: expected a distance in metres, got {clearance!r}")
    if not (math.isfinite(clearance) and 0.0 <= clearance <= 1.0):
        raise ValueError(f"clearance: expected a distance in [0, 1] m, got {clearance!r}")
    if scene is None and clearance != 0.0:
        raise ValueError(
            f"clearance: the distance kept from a scene's obstacles; got {clearance!r} "
            "without a scene"
        )
    return float(clearance)


def check_current(current, name: str = "current", rows: bool = False) -> np.ndarray:
    """Joint angles (6,) in radians within +-MAX_JOINT_ANGLE; ValueError naming ``name``.

    ``rows``: any number of configurations, shape (6,) or (k, 6), returned as (k, 6).
    """
    current = check_joints(current, name)
    if rows and current.ndim <= 2:
        current = current.reshape(-1, 6)
    elif current.shape != (6,):
        want = "(6,) or (k, 6)" if rows else "(6,)"
        raise ValueError(f"{name}: expected shape {want}, got {current.shape}")
    if np.any(np.abs(current) > MAX_JOINT_ANGLE):
        raise ValueError(
            f"{name}: joint angles are radians within +-2 pi; got "
            f"{float(np.max(np.abs(current))):.4g} (degrees passed as radians?)"
        )
    return current


def _azimuth(p: np.ndarray, e: np.ndarray, current: np.ndarray | None) -> tuple[bool, float]:
    """Whether e is vertical, and the azimuth of d = +1 (fixed rule when vertical)."""
    h = horizontal_length(e[0], e[1])
    if h >= VERTICAL_EPS:
        return False, math.atan2(e[1], e[0])
    if current is not None:
        return True, float(wrap(current[0] + current[1] + current[2]))
    return True, _default_vertical_azimuth(p)


def _default_vertical_azimuth(p: np.ndarray) -> float:
    """The documented azimuth for a vertical direction: from joint 1 towards the target."""
    if math.hypot(p[0], p[1]) < 1e-12:
        return 0.0
    return math.atan2(p[1], p[0])


def _order(solutions, branches, intervals, current):
    if current is None or len(solutions) == 0:
        return solutions, branches, intervals
    idx = np.argsort(np.sum((solutions - current) ** 2, axis=-1), kind="stable")
    return solutions[idx], branches[idx], intervals[idx]


def _vector(value, size: int):
    """The (float array, its floats) of ``value`` when it is ``size`` finite numbers, else None."""
    arr = real_array(value)
    if arr is None or arr.shape != (size,):
        return None
    xs = arr.tolist()
    if not all(map(math.isfinite, xs)):
        return None
    return arr, xs


def _check_one(design: ArmDesign, p, e, current):
    """check_inputs for the common case, in scalar arithmetic (a control loop calls it).

    The same numbers as ``check_target`` and ``check_scale`` (the same operations in the
    same order); None when an input is not plain finite numbers of the right size, for the
    general checks to name the fault.
    """
    pv, ev = _vector(p, 3), _vector(e, 3)
    cv = None if current is None else _vector(current, 6)
    if pv is None or ev is None or (current is not None and cv is None):
        return None
    x, y, z = ev[1]
    big = max(abs(x), abs(y), abs(z))
    if big == 0.0:
        raise ValueError("e: direction has zero length")
    x, y, z = x / big, y / big, z / big
    n = math.sqrt(x * x + y * y + z * z)
    e = np.array([x / n, y / n, z / n])
    px, py, pz = pv[1]
    big = max(abs(px), abs(py), abs(pz))
    if big > 0.0:
        reach = _reach(design)
        dist = big / max(reach, 1e-300) * math.hypot(px / big, py / big, pz / big)
        if dist > REACH_FACTOR:
            check_scale(design, pv[0])  # raises, with the message
    if cv is not None:
        if max(map(abs, cv[1])) > MAX_JOINT_ANGLE:
            check_current(cv[0])  # raises, with the message
        current = cv[0]
    return pv[0], e, current


def check_inputs(design, p, e, current):
    """Checked (p, e, current) of one target; ValueError naming the argument."""
    check_design(design)
    fast = _check_one(design, p, e, current)
    if fast is not None:
        return fast
    p, e = check_target(p, e)
    if p.shape != (3,):
        raise ValueError(f"p: expected shape (3,), got {p.shape}")
    if e.shape != (3,):
        raise ValueError(f"e: expected shape (3,), got {e.shape}")
    check_scale(design, p)
    if current is not None:
        current = check_current(current)
    return p, e, current


def solve_exact(design: ArmDesign, p, e, current=None) -> IKResult:
    """Every 5-DoF solution range of the target (p, e); empty when there is none.

    Parameters and result as ``handarm.ik.solve`` with ``degrade=False``.
    """
    p, e, current = check_inputs(design, p, e, current)
    return _exact(design, p, e, current)


def _exact(design: ArmDesign, p: np.ndarray, e: np.ndarray, current) -> IKResult:
    """solve_exact on checked inputs."""
    vertical, azimuth = _azimuth(p, e, current)
    sols, br, iv, azimuth = _solve_raw(design, p, e, azimuth)
    sols, br, iv = _order(sols, br, iv, current)
    follow = None
    if current is not None and len(sols):
        follow = follow_configuration(design, p, e, sols, br, iv, current, azimuth)
    return IKResult(sols, br, iv, 5, 0.0, 0.0, vertical, azimuth, p.copy(), e.copy(), follow)


#: Samples of u per range in the search for the configuration nearest ``current``; the best
#: sample's neighbourhood is then refined by golden-section search.
_FOLLOW_SAMPLES = 33
_FOLLOW_REFINE = 40


def follow_configuration(
    design, p, e, solutions, branches, intervals, current, azimuth
) -> np.ndarray:
    """The configuration inside the given ranges nearest to ``current``, shape (6,).

    Distance is Euclidean in joint space (rad). Along each range the joint angles are a
    smooth function of u: the distance is sampled at ``_FOLLOW_SAMPLES`` points (a hair
    inside the ends) and the best sample refined by golden-section search between its
    neighbours; the range midpoints ``solutions`` and the ranges' exact ends (a joint at
    its limit, where a range that ``current`` rode to its end stops) are candidates too.
    Only configurations passing ``is_valid`` are returned.
    """
    current = np.ascontiguousarray(current, dtype=float)
    # nearest_solution's arithmetic, current being checked already
    best = solutions[int(np.argmin(np.sum((solutions - current) ** 2, axis=-1)))]
    best_dist = float(np.sum((best - current) ** 2))
    n = len(branches)
    candidates = np.empty((4 * n, 6))
    dists = np.empty(4 * n)
    dxs, dys = _line_directions(p, e, branches[:, 0], azimuth)
    K.nearest_in_ranges(
        p, e, dxs, dys, branches, np.ascontiguousarray(intervals, dtype=float), design.lengths,
        current, _FOLLOW_SAMPLES, _FOLLOW_REFINE, candidates, dists,
    )  # fmt: skip
    # the midpoint is valid: only nearer candidates are checked, all in one batched call
    near = np.flatnonzero(dists < best_dist)
    for k in near:  # a range's end at a joint limit: on it, not an ulp beyond
        K.snap_to_limits(candidates[k], design.lower, design.upper)
    if len(near):
        near = near[is_valid(design, candidates[near])]
    if len(near):
        best = candidates[near[np.argmin(dists[near])]].copy()
    return best


#: (design, its model, its reach) of the last design ``_model`` or ``_reach`` was asked
#: for: a control loop asks for one design, and finding it by identity costs 0.05 us where
#: hashing the frozen design for the lru_cache costs 1.3 us (of a 50 us solve)
_LAST: tuple = (None, None, 0.0)


def _model(design: ArmDesign, min_width: float = 0.0) -> tuple:
    """The collision model as the kernels take it (see ``_solve.solve_target``).

    Under the paper's model the envelope arrays are not read; the default design's are
    passed so that both models share one compiled kernel.
    """
    global _LAST
    last = _LAST  # one read: another thread may replace it
    if min_width == 0.0 and last[0] is design:
        return last[1]
    model = _model_cached(design, float(min_width))
    if min_width == 0.0:
        _LAST = (design, model, float(np.sum(design.lengths)))
    return model


def _reach(design: ArmDesign) -> float:
    """a0 + .. + a6 (m), as ``check_scale`` computes it."""
    last = _LAST  # one read: another thread may replace it
    return last[2] if last[0] is design else float(np.sum(design.lengths))


@functools.lru_cache(maxsize=64)
def _model_cached(design: ArmDesign, min_width: float) -> tuple:
    paper = design.collision_model == "paper"
    source = _DEFAULT_SHAPES if paper else design
    return (
        paper,
        *kernel_env(source),
        kernel_coefficients(source),
        kernel_far(source),
        *kernel_tables(source),
        float(min_width),
    )


_DEFAULT_SHAPES = ArmDesign()


def _solve_raw(design: ArmDesign, p: np.ndarray, e: np.ndarray, azimuth: float):
    cap = _SINGLE_CAPACITY
    q = np.empty((cap, 6))
    br = np.empty((cap, 3), np.int8)
    iv = np.empty((cap, 2))
    used = np.empty(1)
    n = K.solve_target(
        p, e, azimuth, design.lengths, design.lower, design.upper, q, br, iv, used, _model(design)
    )
    if n < 0 or n > cap:
        raise RuntimeError("IK: more solution ranges than the internal buffers hold")
    return q[:n].copy(), br[:n].astype(int), iv[:n].copy(), float(used[0])


def _check_batch(design: ArmDesign, P, E):
    """Checked (N, 3) targets and the azimuth each uses if its direction is vertical."""
    check_design(design)
    P, E = check_target(P, E, "P", "E")
    if P.ndim != 2 or E.ndim != 2 or P.shape != E.shape:
        raise ValueError(f"P, E: expected two arrays of shape (N, 3), got {P.shape} and {E.shape}")
    check_scale(design, P, "P")
    return P, E, vertical_azimuth(P)


def vertical_azimuth(P: np.ndarray) -> np.ndarray:
    """The azimuth (N,) that targets at points P (N, 3) use if their direction is vertical."""
    return np.where(np.hypot(P[:, 0], P[:, 1]) < 1e-12, 0.0, np.arctan2(P[:, 1], P[:, 0]))


def _check_chunk(chunk) -> None:
    if not (isinstance(chunk, (int, np.integer)) and not isinstance(chunk, bool) and chunk >= 1):
        raise ValueError(f"chunk: expected an integer >= 1, got {chunk!r}")


def solve_batch(
    design: ArmDesign,
    P,
    E,
    *,
    chunk: int = _BATCH_CHUNK,
    scene=None,
    clearance: float = 0.0,
) -> BatchResult:
    """5-DoF solutions of N targets, in parallel, in chunks of bounded memory.

    Parameters
    ----------
    design : ArmDesign
    P, E : array-like, shape (N, 3)
        Tool points (m) and directions (normalised here).
    chunk : int
        Targets per parallel call; memory use is O(N) for the outputs only.
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame): each row then holds what ``solve(..., scene=scene,
        clearance=clearance)`` returns (``handarm.ik.obstacles.solve_batch_in_scene``).
    clearance : float
        Distance (m) kept from the scene's obstacles.

    Returns
    -------
    BatchResult
        Vertical directions are handled as in ``solve`` without ``current``. No
        degradation: a target without a 5-DoF solution has count 0. The arrays have
        ``MAX_SOLUTIONS`` rows per target, more when some target has more ranges (never
        truncated: ``counts`` equals ``count_solutions``).

    Raises
    ------
    ValueError
        If the targets are malformed, ``chunk`` is not an integer >= 1 or ``clearance`` is
        not a distance in [0, 1] m (or not 0 without a scene).
    """
    _check_chunk(chunk)
    check_clearance(clearance, scene)
    if scene is not None:
        from handarm.ik.obstacles import solve_batch_in_scene

        return solve_batch_in_scene(design, P, E, scene, clearance)
    P, E, psi = _check_batch(design, P, E)
    counts, sols, br, iv, used = _batch_rows(design, P, E, psi, chunk, MAX_SOLUTIONS)
    over = np.flatnonzero(counts > MAX_SOLUTIONS)
    if len(over):
        # a few targets of some designs have more ranges than the usual width: solve those
        # again with room for all, so that no range is dropped (counts agree with
        # count_solutions)
        width = int(counts[over].max())
        c2, s2, b2, i2, _ = _batch_rows(design, P[over], E[over], psi[over], chunk, width)
        pad = width - MAX_SOLUTIONS
        sols = np.concatenate([sols, np.full((len(P), pad, 6), np.nan)], axis=1)
        br = np.concatenate([br, np.zeros((len(P), pad, 3), np.int8)], axis=1)
        iv = np.concatenate([iv, np.full((len(P), pad, 2), np.nan)], axis=1)
        sols[over], br[over], iv[over], counts[over] = s2, b2, i2, c2
    h = horizontal_lengths(E)
    truncated = np.zeros(len(P), bool)
    return BatchResult(counts, sols, br, iv, truncated, h < VERTICAL_EPS, used)


def _batch_rows(design: ArmDesign, P, E, psi, chunk: int, width: int):
    """The kernel's rows for checked targets, ``width`` ranges stored per target."""
    model = _model(design)
    n = len(P)
    counts = np.zeros(n, np.int64)
    # the kernel fills every row (solutions, then NaN padding): no second pass over memory
    sols = np.empty((n, width, 6))
    br = np.empty((n, width, 3), np.int8)
    iv = np.empty((n, width, 2))
    a, lo, hi = design.lengths, design.lower, design.upper
    used = np.empty(n)
    for s in range(0, n, chunk):
        sl = slice(s, min(n, s + chunk))
        K.solve_many(
            np.ascontiguousarray(P[sl]),
            np.ascontiguousarray(E[sl]),
            psi[sl],
            a,
            lo,
            hi,
            sols[sl],
            br[sl],
            iv[sl],
            counts[sl],
            used[sl],
            model,
        )
    if np.any(counts < 0):
        raise RuntimeError("IK: more solution ranges than the internal buffers hold")
    return counts, sols, br, iv, used


def solve_batch_iter(design: ArmDesign, P, E, *, chunk: int = _BATCH_CHUNK):
    """``solve_batch`` chunk by chunk: yields (start, BatchResult) for rows start..start+len.

    Memory stays bounded by the chunk whatever N is (1e7 targets at 1.6 kB of padded
    output each would need 16 GB at once); ``P`` and ``E`` may be memory-mapped arrays.
    Every chunk is checked before the first is solved, and an error names the row as ``P``
    and ``E`` number it: nothing is yielded for a batch with a bad row.
    """
    _check_chunk(chunk)
    check_design(design)
    try:
        shapes = np.shape(P), np.shape(E)
    except ValueError:  # ragged nested lists
        shapes = None
    if shapes is None or len(shapes[0]) != 2 or shapes[0] != shapes[1] or shapes[0][1] != 3:
        got = "ragged lists" if shapes is None else f"{shapes[0]} and {shapes[1]}"
        raise ValueError(f"P, E: expected two arrays of shape (N, 3), got {got}")
    n = len(P)
    for start in range(0, n, chunk):
        Pc, _ = check_target(P[start : start + chunk], E[start : start + chunk], "P", "E", start)
        check_scale(design, Pc, "P", start)
    return _solve_chunks(design, P, E, chunk)


def _solve_chunks(design: ArmDesign, P, E, chunk: int):
    """``solve_batch_iter``'s generator, on checked targets."""
    n = len(P)
    for start in range(0, n, chunk):
        yield (
            start,
            solve_batch(
                design,
                np.asarray(P[start : start + chunk]),
                np.asarray(E[start : start + chunk]),
                chunk=chunk,
            ),
        )


def count_solutions(
    design: ArmDesign,
    P,
    E,
    *,
    chunk: int = 1 << 20,
    min_width: float = 0.0,
    scene=None,
    clearance: float = 0.0,
) -> np.ndarray:
    """Number of 5-DoF solution ranges of each of N targets, shape (N,).

    The same answer as ``solve_batch(...).counts`` without storing any solution, so that
    millions of targets (workspace maps) run in little memory.

    Parameters
    ----------
    design : ArmDesign
    P, E : array-like, shape (N, 3)
        Tool points (m) and directions.
    chunk : int
        Targets per parallel call (>= 1).
    min_width : float
        Ranges narrower than this (m of u) are not counted: a printed arm cannot hold a
        range a few nanometres wide (a stretched tip pointing straight up, say).
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame): count the ranges that keep ``clearance`` (m) from them,
        as ``solve(..., scene=scene, clearance=clearance)`` returns them
        (``handarm.ik.obstacles.count_in_scene``, in parallel).
    clearance : float

    Returns
    -------
    ndarray of int, shape (N,)

    Raises
    ------
    ValueError
        If the targets are malformed, ``chunk < 1``, ``min_width`` is not a number >= 0 or
        ``clearance`` not a distance in [0, 1] m (or not 0 without a scene).
    """
    _check_chunk(chunk)
    min_width = check_number(min_width, "min_width", low=0.0, unit="m")
    check_clearance(clearance, scene)
    if scene is not None:
        from handarm.ik.obstacles import count_in_scene

        P, E, _ = _check_batch(design, P, E)
        parts = [
            count_in_scene(
                design, P[s : s + chunk], E[s : s + chunk], scene, clearance, min_width=min_width
            )
            for s in range(0, len(P), chunk)
        ]
        return np.concatenate([np.zeros(0, np.int64), *parts])
    P, E, psi = _check_batch(design, P, E)
    return count_checked(design, P, E, psi, min_width, chunk)


def count_checked(
    design: ArmDesign, P, E, psi, min_width: float = 0.0, chunk: int = 1 << 20
) -> np.ndarray:
    """``count_solutions`` of targets that are already checked.

    ``P`` and ``E`` are float arrays (N, 3) of points within reach and unit directions,
    ``psi`` (N,) the azimuth each uses if its direction is vertical. For callers that make
    many small batches of their own targets: degradation counts a few directions at a time,
    hundreds of times per target, and the checks cost more than the kernel there.
    """
    model = _model(design, min_width)
    n = len(P)
    counts = np.zeros(n, np.int64)
    for s in range(0, n, chunk):
        sl = slice(s, min(n, s + chunk))
        kernel = K.count_many if sl.stop - s > K.COUNT_BLOCK else K.count_many_serial
        kernel(
            np.ascontiguousarray(P[sl]),
            np.ascontiguousarray(E[sl]),
            psi[sl],
            design.lengths,
            design.lower,
            design.upper,
            counts[sl],
            model,
        )
    if np.any(counts < 0):
        raise RuntimeError("IK: more solution ranges than the internal buffers hold")
    return counts


def _targets_args(design: ArmDesign, P, E, psi, min_width: float) -> tuple:
    """Checked targets and the design as the kernels take them."""
    P, E = np.ascontiguousarray(P), np.ascontiguousarray(E)
    return P, E, psi, design.lengths, design.lower, design.upper, _model(design, min_width)


def solvable_checked(design: ArmDesign, P, E, psi, min_width: float = 0.0) -> np.ndarray:
    """Whether each checked target (see ``count_checked``) has a solution range, shape (N,).

    The same as ``count_checked(...) > 0``, at the cost of finding one range, not all.
    """
    out = np.zeros(len(P), np.int64)
    K.solvable_rows(*_targets_args(design, P, E, psi, min_width), out)
    if np.any(out < 0):
        raise RuntimeError("IK: more solution ranges than the internal buffers hold")
    return out > 0


def sub_problems_solvable(design: ArmDesign, p, e, azimuth: float) -> tuple[bool, bool]:
    """Whether the base and the tip problem of a checked target each have a valid stretch.

    ``e`` a unit vector; ``azimuth`` L's azimuth if e is vertical. Each is taken alone
    (limits and reach, within its own reach; ``_solve.sub_problems_solvable``): False for
    either means no direction sharing e's azimuth (base) or e's elevation (tip) is solvable
    at p.
    """
    base, tip = K.sub_problems_solvable(
        np.ascontiguousarray(p, dtype=float),
        np.ascontiguousarray(e, dtype=float),
        float(azimuth),
        design.lengths,
        design.lower,
        design.upper,
        _model(design),
    )
    return bool(base), bool(tip)


def first_solvable_checked(
    design: ArmDesign, P, E, psi, min_width: float = 0.0, k: int = 1
) -> np.ndarray:
    """Indices of the first k checked targets (in order) that have a solution range.

    Fewer if fewer have one; one compiled call, which stops at the k-th.
    """
    out = np.empty(k, np.int64)
    m = int(K.first_solvable(*_targets_args(design, P, E, psi, min_width), out))
    if m < 0:
        raise RuntimeError("IK: more solution ranges than the internal buffers hold")
    return out[:m]


def configurations_along(
    design: ArmDesign, p, e, branch, u, *, azimuth=None
) -> tuple[np.ndarray, np.ndarray]:
    """Joint angles at many u of one branch.

    Parameters
    ----------
    design : ArmDesign
    p, e : array-like, shape (3,)
    branch : sequence of 3 int
        (sign of d, elbow of B, elbow of E).
    u : array-like, shape (n,)
        Coordinates of joint 4 along L (m).
    azimuth : float, optional
        As in ``configuration_at``.

    Returns
    -------
    q : ndarray, shape (n, 6)
        Joint angles; zeros where the branch cannot reach.
    reachable : ndarray of bool, shape (n,)
        Both chains reach that u on this branch (validity is not checked).
    """
    check_design(design)
    p, e = check_target(p, e)
    br = _check_branch(branch)
    u = np.ascontiguousarray(check_array(np.atleast_1d(u)[:, None], "u", 1)[:, 0])
    dx, dy = _line_direction(p, e, br[0], azimuth)
    q = np.zeros((len(u), 6))
    ok = np.zeros(len(u), np.bool_)
    K.configurations_along_u(p, e, dx, dy, u, float(br[1]), float(br[2]), design.lengths, q, ok)
    return q, ok


def _check_branch(branch) -> np.ndarray:
    br = real_array(branch)
    if br is None or br.shape != (3,) or not np.all(np.isin(br, (-1, 1))):
        raise ValueError(f"branch: expected three signs +1/-1, got {branch!r}")
    return br


def _line_directions(p, e, signs, azimuth) -> tuple[np.ndarray, np.ndarray]:
    """D (arrays dx, dy) for each branch sign of ``signs``, computed as the kernel does.

    h / |h| with h the horizontal part of e, or the azimuth for a vertical e.
    """
    signs = np.asarray(signs, dtype=float)
    h = horizontal_length(e[0], e[1])
    if h >= VERTICAL_EPS:
        return signs * float(e[0]) / h, signs * float(e[1]) / h
    psi = _default_vertical_azimuth(p) if azimuth is None else float(azimuth)
    return signs * math.cos(psi), signs * math.sin(psi)


def _line_direction(p, e, sign, azimuth) -> tuple[float, float]:
    """D for one branch sign (``_line_directions``)."""
    dx, dy = _line_directions(p, e, [sign], azimuth)
    return float(dx[0]), float(dy[0])


def configuration_at(
    design: ArmDesign, p, e, branch, u: float, *, azimuth=None, result=None
) -> np.ndarray:
    """Joint angles at any u of a branch, shape (6,).

    Parameters
    ----------
    design : ArmDesign
    p, e : array-like, shape (3,)
        The target.
    branch : sequence of 3 int
        (sign of d, elbow of B, elbow of E), each +1/-1, as in ``IKResult.branches``.
    u : float
        Coordinate of joint 4 along L (m); inside a range of that branch the result is a
        valid configuration reaching the target.
    azimuth : float, optional
        The azimuth of d = +1 for a vertical ``e`` (``IKResult.azimuth``).
    result : IKResult, optional
        The result the branch and u come from: (p, e) must be its ``target`` (for a
        degraded result the relaxed target, not the requested one), and its azimuth is used
        when ``azimuth`` is not given.

    Raises
    ------
    ValueError
        If u is not a finite number or is out of reach of the branch, (p, e) is not
        ``result.target``, ``result`` is not an IKResult, or p lies beyond 100 x the arm's
        reach (units mistaken).
    """
    check_design(design)
    p, e = check_target(p, e)
    if p.shape != (3,) or e.shape != (3,):
        raise ValueError(f"p, e: expected shape (3,) each, got {p.shape} and {e.shape}")
    check_scale(design, p)
    br = _check_branch(branch)
    u = check_number(u, "u", unit="m")
    if azimuth is not None:
        azimuth = check_number(azimuth, "azimuth", unit="rad")
    if result is not None and not isinstance(result, IKResult):
        raise ValueError(
            f"result: expected the IKResult of one target (ik.solve), got {type(result).__name__}"
        )
    if result is not None:
        tp, te = result.target
        if not (np.allclose(p, tp, rtol=0, atol=1e-12) and np.allclose(e, te, rtol=0, atol=1e-12)):
            what = (
                f"the result is degraded (reached_dof={result.reached_dof}): its ranges "
                "belong to the relaxed target result.target"
                if result.reached_dof < 5
                else "they are not the target of the result (result.target)"
            )
            raise ValueError(f"p, e: {what}")
        if azimuth is None and result.vertical:
            azimuth = result.azimuth
    dx, dy = _line_direction(p, e, br[0], azimuth)
    q = np.empty(6)
    ok = K.configuration_at_u(p, e, dx, dy, float(u), float(br[1]), float(br[2]), design.lengths, q)
    if not ok:
        raise ValueError(f"u: {u:g} m is out of reach of branch {tuple(int(b) for b in br)}")
    K.snap_to_limits(q, design.lower, design.upper)  # at a range's end at a limit: on it
    return q
