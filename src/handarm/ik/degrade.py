"""Graceful degradation (paper III-D).

When a target (p, e) has no 5-DoF solution the closest reachable pose is returned. Each level
keeps what its name says:

4 DoF
    p exact and exactly one of e's two angles kept: its yaw (azimuth, so the tip plane stays
    and only the elevation changes) or its pitch (elevation; only the azimuth changes). The
    search runs along the great circle of constant yaw and along the circle of constant
    pitch; straight up/down lies on the first but leaves L's azimuth free, so it counts only
    with L along e's yaw (its neighbours on the circle decide, not the free-azimuth solve).
3 DoF
    p exact; the reachable direction closest to e.
2 DoF
    p out of reach: the nearest reachable tool point, with the tool pointing at p when the
    arm can. A bound on every configuration's reach tells p out of reach before any search,
    and proves the arm stretched towards p the nearest wherever that is within the limits
    and valid (``_reach_bound``).
    Elsewhere valid configurations near p are polished towards it; those a printed-link
    contact stopped then slide along it (``handarm.ik._nearest.slide``), since the nearest
    point usually lies on such a contact.

Order: ``order="paper"`` (the paper's) tries 4, then 3, then 2; a level-4 answer can cost
more angle than the best level-3 one, since keeping pitch or yaw is a constraint.
``order="angle"`` ("smallest angle first") returns the reachable direction closest to e, and
reports level 4 when that direction happens to keep pitch or yaw.

Searches over directions are exact at their final step: a grid finds the solvable region
closest to e and bisection pins its boundary to ``ANGLE_TOL``; the level-3 search also starts
from directions of valid configurations that reach p (so small caps of solvable directions
near the reach sphere are not missed) and slides along the boundary towards e; the searches
run to a coarse ring first, and only those that did not meet an earlier one go on to
``ANGLE_TOL`` (``handarm.ik._search.refine_directions``). Level 4's
grid tests each direction with the joint limits widened by ``_SLIVER_WIDEN`` first, and
scans runs of directions solvable only so 32 times finer (arcs narrower than the grid,
where a joint sits at its limit); it also projects the directions of those configurations
onto its circles (``circle_projections``).

With ``current`` (a control loop), answers within ``HOLD_ANGLE`` (or ``HOLD_DISTANCE`` at
level 2) of the best found are ties, and the one nearest current wins (``_choose``): sensor
noise then keeps the answer where it was.

In a scene (``degrade_target(..., scene=, clearance=)``) every level searches with the
obstacles included: "solvable" means a range that keeps the clearance
(``count_solutions(..., scene=)``), answers come from ``solve_in_scene``, and the
configurations polished towards p must keep the clearance as well as be valid. The scene is
held in a context variable for the duration of the call, which the helpers below read.
"""

from __future__ import annotations

import contextvars
import dataclasses
import functools
import itertools
import math

import numpy as np

from handarm.collision import collision_free, kernel_env
from handarm.design import ArmDesign
from handarm.ik import exact as S
from handarm.ik._above import limit_crossings, members
from handarm.ik._nearest import NEAR_FIRST, NEAR_MORE, polish_each, slide_best, tool_poses
from handarm.ik._polish import polish_to_point, tool_pose
from handarm.ik._search import (
    PITCH_CIRCLE,
    YAW_CIRCLE,
    circle_projections,
    nearest_on_circles,
    refine_directions,
)
from handarm.ik._solve import reaching_rows
from handarm.ik.results import IKResult
from handarm.kinematics import is_valid
from handarm.scene import _kernel_args

__all__ = ["degrade_target", "closest_direction", "ORDERS"]

#: Level orders ``solve(..., order=...)`` accepts.
ORDERS = ("paper", "angle")

_FINE_STEP = math.radians(0.25)
#: Where the level-4 scan's blocks of grid angles end: 1, 2, 4, 8 deg, then 12 deg each.
_BLOCK_ENDS = np.cumsum([4, 8, 16, 32] + [48] * 15)
#: Directions are located to this angle (rad): bisections stop when their bracket is this
#: narrow and pattern searches when their ring is. The levels promise 0.01 deg (1.7e-4 rad).
#: Finer costs dearly where the boundary is a printed-link contact that the solvable ranges
#: shrink to: the collision kernel needs about 1/sqrt(depth) stretches there, and a direction
#: 1e-9 rad inside took 40-80 ms to count where 1e-6 rad takes a few.
ANGLE_TOL = 1e-5
#: A direction within this angle (rad) of straight up/down is moved off the pole along its
#: circle, so that L's azimuth is the circle's and not the free one of a vertical e.
_POLE = 1e-9
_SPHERE = 2000
#: Valid cloud configurations near p polished as seeds: level 2's starts, and the
#: configurations reaching p whose directions start level 3 and are projected onto level 4's
#: circles. The nearest point's basin is often not that of the nearest few configurations
#: (near the base axis, the oracle check's misses, see ``_two_dof``), and nor is a solvable
#: direction's: with 8, level 3 missed one 2.6 deg nearer e on a random design (joint 1 at
#: its limit, the wrist straight); 24 found it. 32 cost level 4 about 0.25 ms more (median).
_SEEDS = 32
#: m: a tool point this near the target is the target (rounding of the kinematics), and a
#: target is out of reach where ``_reach_bound`` puts every tool point farther than this
_AT_TARGET = 1e-12
_STARTS = 3  # level 3 starts from this many sphere samples and as many seed directions
_SAME_DIRECTION = 1e-3  # rad: seed directions closer than this start one search
_PATTERN_ROUNDS = 300  # rings of one pattern search, at most (a narrow sliver can creep on)
_POLISH_STEPS = 500  # Levenberg-Marquardt steps of one polish (they take ~0.1 us each)
#: A relaxed direction keeps e's pitch (or yaw) when it differs by less than this (rad).
KEEP_TOL = 1e-9
#: rad: with ``current``, relaxed directions this much farther from e than the closest one
#: found are ties, and the one nearest current's pose wins (``_choose``). The searches find
#: the closest to about ``ANGLE_TOL`` and the levels promise 0.01 deg (1.7e-4 rad), so a tie
#: costs at most 0.003 deg; without it 1e-6 of sensor noise moved ``follow`` by up to 7e-3
#: rad at levels 3 and 4 (the answer sits where the solution ranges shrink to a point, and
#: the bisections' last step moves it there).
HOLD_ANGLE = 5e-5
#: m: the same at level 2, whose answers are promised to 1e-7 m.
HOLD_DISTANCE = 2e-8
#: At level 2 with ``current``, the pose that points the tool at p is taken only when its
#: follow configuration moves at most this many times as far as the nearest point's own
#: configuration does. The nearest point lies on the edge of the workspace, where the
#: solution ranges of that pose shrink to points: 1e-6 of noise moved ``follow`` by up to
#: 3.2 rad to another range of the same pose, where the polished configuration moves by
#: microradians.
HOLD_RATIO = 10.0


#: (scene, clearance) while ``degrade_target`` runs in a scene, else None.
_SCENE: contextvars.ContextVar = contextvars.ContextVar("degrade_scene", default=None)


def _targets(p: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(P, E, psi) of the directions ``dirs`` at p, as the checked counts take them.

    Small arrays, built by hand: the searches make thousands of these per target.
    """
    dirs = np.atleast_2d(dirs)
    n = len(dirs)
    P = np.empty((n, 3))
    P[:] = p
    E = dirs / np.sqrt(np.einsum("ij,ij->i", dirs, dirs))[:, None]
    return P, E, np.full(n, S._default_vertical_azimuth(p))  # S.vertical_azimuth of P


def _solvable(design: ArmDesign, p: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Which of the unit directions ``dirs`` have an exact solution at p (p checked)."""
    scene = _SCENE.get()
    if scene is None:
        return S.solvable_checked(design, *_targets(p, dirs))
    dirs = np.atleast_2d(dirs)
    P = np.broadcast_to(p, dirs.shape).copy()
    return S.count_solutions(design, P, dirs, scene=scene[0], clearance=scene[1]) > 0


def _first_solvable(design: ArmDesign, p: np.ndarray, dirs: np.ndarray, k: int = 1) -> np.ndarray:
    """Indices of the first k of the unit directions ``dirs`` solvable at p (fewer if not)."""
    if _SCENE.get() is not None:
        return np.flatnonzero(_solvable(design, p, dirs))[:k]
    return S.first_solvable_checked(design, *_targets(p, dirs), k=k)


def _solve_exact(design: ArmDesign, p, e, current) -> IKResult:
    """``solve_exact``, or ``solve_in_scene`` in a scene."""
    scene = _SCENE.get()
    if scene is None:
        return S.solve_exact(design, p, e, current)
    from handarm.ik.obstacles import solve_in_scene

    return solve_in_scene(design, p, e, scene[0], scene[1], current)


def _pose(design: ArmDesign, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tool point and direction of one configuration (``forward`` in scalar arithmetic)."""
    out = np.empty(8)
    tool_pose(np.ascontiguousarray(q, dtype=float), design.lengths, out)
    return out[:3], out[3:6]


def _valid(design: ArmDesign, q) -> bool:
    """Valid under the design's collision model, and clear of the scene if there is one."""
    return bool(_valid_rows(design, np.asarray(q, dtype=float).reshape(1, 6))[0])


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between unit vectors, robust near 0 and pi."""
    if a.ndim == 1 and b.ndim == 1:  # one pair: the searches ask this thousands of times
        d0, d1, d2 = a[0] - b[0], a[1] - b[1], a[2] - b[2]
        s0, s1, s2 = a[0] + b[0], a[1] + b[1], a[2] + b[2]
        return 2.0 * math.atan2(
            math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        )
    # by components: np.sum over a last axis of 3 took 120 us for a 2,000-point sphere
    # against e, these 33 us (the same sums, in the same order)
    d0, d1, d2 = a[..., 0] - b[..., 0], a[..., 1] - b[..., 1], a[..., 2] - b[..., 2]
    s0, s1, s2 = a[..., 0] + b[..., 0], a[..., 1] + b[..., 1], a[..., 2] + b[..., 2]
    return 2.0 * np.arctan2(
        np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    )


def _search_scene(design: ArmDesign) -> tuple:
    """The scene as the compiled searches take it: (pi, pf, coef, n_pieces, obstacles, c).

    With no scene, no obstacle rows: the searches ask the free solver.
    """
    scene = _SCENE.get()
    if scene is None:
        return _free_search_scene(design)
    pi, pf, n_pieces, coef = _kernel_args(design)
    return pi, pf, coef, n_pieces, scene[0].obstacles, float(scene[1])


@functools.lru_cache(maxsize=8)
def _free_search_scene(design: ArmDesign) -> tuple:
    """``_search_scene`` with no scene, once per design (it cost a level-4 answer 4 %)."""
    pi, pf, n_pieces, coef = _kernel_args(design)
    return pi, pf, coef, n_pieces, np.zeros((0, 16)), 0.0


#: The level-4 scan's grid of offsets along a circle (rad), and where its blocks end.
_GRID = _FINE_STEP * np.arange(1, round(math.pi / _FINE_STEP) + 1)
_GRID_BLOCKS = _BLOCK_ENDS[_BLOCK_ENDS < len(_GRID)].astype(np.int64)
#: rad: a level-4 grid direction solvable only with every joint limit widened by this much is
#: a suspect of a solvable arc narrower than the grid (one independent oracle check found an
#: arc of 0.018 deg, q1 at its limit and the wrist nearly straight, 1.28 deg nearer e than
#: the grid's answer; widened by 1 deg that arc is 0.61 deg wide and holds a grid direction).
_SLIVER_WIDEN = math.radians(1.0)
#: A run of suspects is scanned this many times finer than the grid (0.0078 deg apart).
_SLIVER_SUB = 32
#: Hits (grid and suspects) one level-4 circle may hold before refinement.
_CIRCLE_HITS = 16


def _nearest_on_circles(design, p, e_yaw, e_pitch, kinds, prune=True, stats=None):
    """The nearest solvable direction on each side of each level-4 circle (one numba call).

    ``kinds``: which circles (``_search.PITCH_CIRCLE`` through e's yaw at every pitch,
    ``_search.YAW_CIRCLE`` at e's pitch), from e's pitch and yaw. Every side goes out on a
    0.25-degree grid in blocks, all sides in turn; with ``prune`` a side stops as soon as it
    cannot beat the cheapest grid direction found so far. Grid directions solvable only with
    every limit widened by ``_SLIVER_WIDEN`` are suspects of an arc narrower than the grid:
    each run of them is scanned ``_SLIVER_SUB`` times finer. The hits left are bisected to
    the boundary (``ANGLE_TOL``). See ``handarm.ik._search.nearest_on_circles``. ``stats``:
    a list that gets the number of grid directions tested and of suspect runs scanned.
    """
    kinds = np.asarray(kinds, np.int64)
    out_dir = np.empty((_CIRCLE_HITS * len(kinds), 3))
    counts = np.zeros(2, np.int64)
    lower_r, upper_r = _widened_limits(design)
    n = nearest_on_circles(
        np.ascontiguousarray(p, dtype=float), S._default_vertical_azimuth(p), kinds,
        float(e_yaw), float(e_pitch), _POLE, bool(prune), _GRID, _GRID_BLOCKS, _FINE_STEP,
        ANGLE_TOL, design.lengths, design.lower, design.upper, lower_r, upper_r, _SLIVER_SUB,
        S._model(design, 0.0), _search_scene(design), out_dir, counts,
    )  # fmt: skip
    if stats is not None:
        stats.append(int(counts[0]))
        stats.append(int(counts[1]))
    return list(out_dir[:n])


@functools.lru_cache(maxsize=8)
def _widened_limits(design) -> tuple[np.ndarray, np.ndarray]:
    """The joint limits widened by ``_SLIVER_WIDEN``, within +-pi (the level-4 suspects).

    Once per design; the compiled search only reads them.
    """
    return (
        np.maximum(design.lower - _SLIVER_WIDEN, -math.pi),
        np.minimum(design.upper + _SLIVER_WIDEN, math.pi),
    )


@functools.lru_cache(maxsize=2)
def _fibonacci_sphere(n: int) -> np.ndarray:
    """The n directions of a Fibonacci sphere (read-only: cached for every target)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (1.0 + math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    out = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    out.flags.writeable = False
    return out


def closest_direction(design, p, e0, seeds=()):
    """Solvable directions near e0 for the tool point p, closest first (empty if none).

    Solvable samples of a Fibonacci sphere nearest e0, and the solvable ``seeds`` (directions
    of valid configurations reaching p), are each moved to the boundary by bisection along
    the arc towards e0, then along the boundary by a shrinking pattern search.
    """
    sphere_starts = _nearest_solvable(design, p, _sphere_by_angle(design, p, e0), _STARTS)
    # the solvable seeds nearest e0 that are not the same direction twice (seed
    # configurations that reach p often share their direction's neighbourhood); they fill
    # up to 2 x _STARTS, more of them where the sphere found few (near the reach, where caps
    # are small). Tested for solvability nearest first, only as far as needed.
    seeds = np.asarray(seeds, float).reshape(-1, 3)
    seeds = seeds[np.argsort(_angle(seeds, e0), kind="stable")]
    want = 2 * _STARTS - len(sphere_starts)
    seed_starts: list[np.ndarray] = []
    for i in _solvable_in_order(design, p, seeds, lambda: want - len(seed_starts)):
        if all(float(_angle(seeds[i], w)) > _SAME_DIRECTION for w in seed_starts):
            seed_starts.append(seeds[i])
            if len(seed_starts) == want:
                break
    found = _refine(design, p, e0, sphere_starts + seed_starts)
    found.sort(key=lambda v: float(_angle(v, e0)))
    return found


def _sphere_by_angle(design: ArmDesign, p: np.ndarray, e0: np.ndarray) -> np.ndarray:
    """The Fibonacci sphere's directions that may be solvable at p, nearest e0 first.

    Those the reach test rules out (``handarm.ik._solve.may_reach``; none is solvable) are
    left out before the sort, which cost more than testing them (0.14 ms for all 2,000):
    the order of the others is the whole sphere's, as a stable sort keeps ties in order.
    """
    sphere = _fibonacci_sphere(_SPHERE)
    keep = np.empty(len(sphere), np.bool_)
    reaching_rows(np.ascontiguousarray(p, dtype=float), sphere, design.lengths, keep)
    sphere = sphere[keep]
    return sphere[np.argsort(_angle(sphere, e0), kind="stable")]


def _solvable_in_order(design, p, dirs, wanted, block: int = 64):
    """Indices of the solvable of ``dirs`` at p, in their order, tested only as far as needed.

    ``wanted()``: how many more the caller may take, asked before each batch of tests.
    Without a scene one compiled call tests up to the first ``wanted()`` solvable; in a
    scene (whose counts test every direction they are given) ``block`` at a time.
    """
    start = 0
    free = _SCENE.get() is None
    while start < len(dirs):
        if free:
            k = max(int(wanted()), 1)
            hits = _first_solvable(design, p, dirs[start:], k)
            yield from (start + int(i) for i in hits)
            if len(hits) < k:
                return  # none solvable after these
            start += int(hits[-1]) + 1
        else:
            solvable = _solvable(design, p, dirs[start : start + block])
            yield from (start + int(i) for i in np.flatnonzero(solvable))
            start += block


def _nearest_solvable(design, p, dirs, k: int) -> list[np.ndarray]:
    """The first k solvable of ``dirs`` (in their order).

    Tested in order, stopping at the k-th (``_solvable_in_order``): the directions beyond
    it (most of a 2,000-point sphere when e0 is near a solvable region) are never tested.
    """
    out: list[np.ndarray] = []
    for i in _solvable_in_order(design, p, dirs, lambda: k - len(out)):
        out.append(dirs[i])
        if len(out) == k:
            break
    return out


#: The ring of trial directions of the pattern search (cosines and sines of its angles).
#: 48 directions (7.5 degrees apart): with 16, the closer solvable directions of 9 of 155
#: level-3 targets of an independent oracle check lay between two trial directions (in an
#: 18 degree wedge next to straight up on one, 4.7 degrees lost), and none are missed with
#: 48, for about a quarter more time.
_RING = np.linspace(0, 2 * math.pi, 48, endpoint=False)
_COS_RING, _SIN_RING = np.cos(_RING), np.sin(_RING)
_RING_TOP = math.radians(2.0)


def _refine(design, p, e0, starts) -> list[np.ndarray]:
    """Each solvable start moved to the boundary and along it towards e0 (one numba call).

    Bisection along the great-circle arc from e0 to the start pins the solvable end nearest
    e0 (``ANGLE_TOL``); then rings of 48 trial directions move it along the boundary: of the
    ring's directions closer to e0, the closest solvable is taken, the ring's radius doubles
    after a move (up to 2 degrees) and halves after a miss, down to ``ANGLE_TOL``, so that
    sliding along a boundary that nears e0 slowly takes a few long moves, not millions of
    short ones; at most ``_PATTERN_ROUNDS`` rings (``handarm.ik._search``).
    """
    if not starts:
        return []
    starts = np.ascontiguousarray(np.array(starts, dtype=float).reshape(-1, 3))
    out = np.empty_like(starts)
    refine_directions(
        np.ascontiguousarray(p, dtype=float),
        S._default_vertical_azimuth(p),
        np.ascontiguousarray(e0, dtype=float),
        starts,
        _COS_RING,
        _SIN_RING,
        _RING_TOP,
        ANGLE_TOL,
        _PATTERN_ROUNDS,
        design.lengths,
        design.lower,
        design.upper,
        S._model(design, 0.0),
        _search_scene(design),
        out,
    )
    return list(out)


def _pitch_yaw(e: np.ndarray) -> tuple[float, float]:
    return math.asin(max(-1.0, min(1.0, e[2]))), math.atan2(e[1], e[0])


def keeps(e: np.ndarray, v: np.ndarray) -> str | None:
    """What the relaxed direction v keeps of e: "yaw", "pitch" or None (within KEEP_TOL)."""
    h_e, h_v = math.hypot(e[0], e[1]), math.hypot(v[0], v[1])
    if h_e > KEEP_TOL and h_v > KEEP_TOL:
        # same vertical plane (v may point the other way across the pole: same tip plane)
        if abs(e[0] * v[1] - e[1] * v[0]) / (h_e * h_v) < KEEP_TOL:
            return "yaw"
    if abs(v[2] - e[2]) < KEEP_TOL:
        return "pitch"
    return None


def _held(design, e, current, dof) -> list[np.ndarray]:
    """Directions that keep ``current``'s pose (none without current).

    Its tool direction (level 3), or that direction moved onto e's pitch and yaw circles
    (level 4).
    """
    if current is None:
        return []
    v = _pose(design, current)[1]
    if dof == 3:
        return [v]
    pitch, yaw = _pitch_yaw(e)
    el, az = _pitch_yaw(v)
    # the pitch circle keeps e's vertical plane (either way across the pole), the yaw circle
    # e's elevation
    side = 1.0 if math.cos(az - yaw) >= 0.0 else -1.0
    return [
        np.array([side * math.cos(el) * math.cos(yaw), side * math.cos(el) * math.sin(yaw),
                  math.sin(el)]),
        np.array([math.cos(pitch) * math.cos(az), math.cos(pitch) * math.sin(az),
                  math.sin(pitch)]),
    ]  # fmt: skip


def _choose(design, p, e, candidates, dof, current) -> IKResult | None:
    """The relaxed direction closest to e among candidates, as an IKResult at level ``dof``.

    With ``current`` the directions that keep its pose (``_held``) are candidates too, and
    candidates within ``HOLD_ANGLE`` of the closest are ties: the one whose follow
    configuration is nearest ``current`` wins, so that a target moved by sensor noise keeps
    the answer where it was instead of jumping with the searches' last digits.

    Candidates are solved closest first, and only while they can still be the answer or
    tie with it; a direction met twice (searches that ended together) is solved once.
    Either way the answer is the one solving every candidate in turn would give.
    """
    scored = []
    tie = 1e-9 if current is None else HOLD_ANGLE

    def score(v, err) -> None:
        r = _solve_exact(design, p, v, current)
        if r.count:
            motion = 0.0 if current is None else float(np.linalg.norm(r.follow - current))
            scored.append((err, motion, v, r))

    errs = [float(_angle(v, e)) for v in candidates]
    seen = set()
    for k in sorted(range(len(candidates)), key=errs.__getitem__):  # stable: ties keep order
        if scored and errs[k] > scored[0][0] + tie:
            break  # the first scored is the closest; nothing farther can win or tie
        v = np.asarray(candidates[k])
        if v.tobytes() in seen:
            continue  # the same (err, motion) as its twin, which comes first and wins a tie
        seen.add(v.tobytes())
        score(v, errs[k])
    if not scored:
        return None
    for v in _held(design, e, current, dof):
        # the searches' candidates keep pitch or yaw by construction (for a vertical e, L's
        # azimuth stands for its yaw); a held one at level 4 must keep one of e's
        if dof == 3 or keeps(e, v) is not None:
            score(v, float(_angle(v, e)))
    best = min(s[0] for s in scored)
    err, _, v, r = min((s for s in scored if s[0] <= best + tie), key=lambda s: (s[1], s[0]))
    return dataclasses.replace(r, reached_dof=dof, direction_error=err, achieved_direction=v.copy())


def _circle_candidates(design, p, e, current, prune=True, stats=None, seeds=()) -> list[np.ndarray]:
    """Level 4: nearest solvable directions keeping yaw (pitch circle) or pitch (yaw circle).

    With ``prune`` only the candidates that can be the nearest to e (see
    ``_nearest_on_circles``), else the nearest on each side of each circle. ``stats`` gets
    the number of grid directions tested. ``seeds``: directions of valid configurations that
    reach p, projected onto the circles (``handarm.ik._search.circle_projections``: the
    small caps near the reach sphere).
    """
    pitch, yaw = _pitch_yaw(e)
    if math.hypot(e[0], e[1]) < KEEP_TOL:  # vertical e: its "yaw" is L's azimuth
        yaw = S._azimuth(p, e, current)[1]

    # the pitch circle keeps L's azimuth, so its base problem is e's; the yaw circle keeps the
    # elevation, so its tip problem is e's: where that sub-problem alone has no valid
    # stretch, no direction of the circle is solvable and the circle is not searched
    base, tip = S.sub_problems_solvable(design, p, e, yaw)
    kinds = []
    if base:
        kinds.append(PITCH_CIRCLE)  # the vertical great circle through e: the tip plane kept
    if tip and math.cos(pitch) > KEEP_TOL:  # a vertical e has no pitch-keeping circle
        kinds.append(YAW_CIRCLE)
    found = _nearest_on_circles(design, p, yaw, pitch, kinds, prune, stats)
    # called even with no seed or circle (it returns at once): whatever compiled the grid's
    # kernel for a design and scene compiles this one too (``warm_up``)
    seeds = np.asarray(seeds, float).reshape(-1, 3)
    best = min((float(_angle(v, e)) for v in found), default=math.inf)
    out_dir = np.empty((2 * len(seeds), 3))
    n = circle_projections(
        np.ascontiguousarray(p, dtype=float), S._default_vertical_azimuth(p),
        np.asarray(kinds, np.int64), float(yaw), float(pitch), _POLE,
        np.ascontiguousarray(seeds), best, _FINE_STEP, ANGLE_TOL, design.lengths,
        design.lower, design.upper, S._model(design, 0.0), _search_scene(design), out_dir,
    )  # fmt: skip
    return found + list(out_dir[:n])


def degrade_target(
    design: ArmDesign,
    p: np.ndarray,
    e: np.ndarray,
    current=None,
    order: str = "paper",
    *,
    scene=None,
    clearance: float = 0.0,
) -> IKResult:
    """The closest reachable pose to (p, e), which has no 5-DoF solution (see module doc).

    With a ``scene`` (handle frame) every level keeps ``clearance`` (m) from its obstacles.
    """
    if order not in ORDERS:
        raise ValueError(f"order: expected one of {list(ORDERS)}, got {order!r}")
    token = _SCENE.set((scene, clearance) if scene else None)
    try:
        return _degrade(design, p, e, current, order)
    finally:
        _SCENE.reset(token)


def _degrade(design: ArmDesign, p, e, current, order: str) -> IKResult:
    bound, stretched = _reach_bound(design, p, current)
    if bound > _AT_TARGET or stretched is not None:
        # no configuration comes within bound of p (not even a degenerate pose) and no
        # direction is solvable there, so levels 4 and 3 have nothing to find; on the
        # bound's edge (to rounding) the configurations meeting it are all that reach p,
        # and the closed form finds the one nearest current (a polish, another: follow
        # jumped 233 deg where the nearest moved 150, a hostile check of 2026-11-27)
        return _two_dof(design, p, e, current, stretched=stretched)
    # valid configurations that reach p (the stretched arm aimed at p, current and cloud
    # points, polished): one with e's direction is a degenerate exact pose (the straight
    # arm); level 3 starts from their directions, and level 4 projects them onto its circles
    # (small caps of solvable directions near the reach)
    polished = _polished(design, p, current)
    reaching = _configs_reaching(polished)
    seeds = tool_poses(reaching, design.lengths)[:, 3:6]  # (k, 3), not a list: no copies
    exact = np.flatnonzero(_angle(seeds, e) < 1e-9)
    if len(exact):
        return _single_point(design, reaching[exact[0]], p, e, 5, 0.0, current)
    if order == "paper":
        candidates = _circle_candidates(design, p, e, current, seeds=seeds)
        result = _choose(design, p, e, candidates, 4, current)
        if result is not None:
            return result
    if order == "angle":
        seeds = [*seeds, *_circle_candidates(design, p, e, current, prune=False, seeds=seeds)]
    result = _choose(design, p, e, closest_direction(design, p, e, seeds), 3, current)
    if order == "angle" and result is not None and keeps(e, result.achieved_direction):
        result = dataclasses.replace(result, reached_dof=4)
    if result is None:
        result = _two_dof(design, p, e, current, polished)
    return result


#: Cloud configurations the seed by seed path (a scene, the paper's model) tests for
#: validity per one wanted: near an obstacle most of those nearest p may be invalid.
_SCENE_NEAR_FIRST = 40

#: Configurations drawn for a design's cloud of seeds (about 24,000 of them valid), in
#: about 5 ms. The closed-form polish reaches a point from most starts; level 2's 32 seeds
#: are the nearest of enough configurations to hold several basins of the distance.
_CLOUD = 32768


@functools.lru_cache(maxsize=8)
def _position_cloud(design: ArmDesign) -> tuple[np.ndarray, np.ndarray]:
    """Configurations within the limits and their tool points: the nearest-point seeds.

    Their validity is tested where they are used, on the few nearest a point: the cloud of
    a new design costs a few ms, not the 10 that testing every one of them takes.
    """
    rng = np.random.default_rng(12345)
    q = rng.uniform(design.lower, design.upper, (_CLOUD, 6))
    return q, np.ascontiguousarray(tool_poses(q, design.lengths)[:, :3])


@functools.lru_cache(maxsize=8)
def _cloud_validity(design: ArmDesign) -> np.ndarray:
    """The cloud's validity as far as tested (int8: 1, 0, -1 not yet), filled in by the polish.

    A control loop's targets lie near each other and share their nearest cloud points:
    each is tested once (about 1 us each, 48 us of a level-4 answer), not once per target.
    Validity does not change, so threads that test one point at once write the same value.
    """
    return np.full(len(_position_cloud(design)[0]), -1, np.int8)


@functools.lru_cache(maxsize=8)
def _cloud_tree(design: ArmDesign):
    """A k-d tree of the cloud's tool points: the nearest of a point in 30 us, not 90.

    It takes about 6 ms to build, once per design: split at the middle of each cell, not at
    the median (``balanced_tree=False``), which took 8 ms and queried no faster (the same
    neighbours, 38-40 us for the nearest 128, measured on the paper's arm).
    """
    from scipy.spatial import cKDTree  # not at import: most uses of the IK never degrade

    return cKDTree(_position_cloud(design)[1], balanced_tree=False)


def _polish(design: ArmDesign, q0: np.ndarray, p: np.ndarray) -> np.ndarray:
    """A valid configuration near q0 whose tool point is nearer p (q0 itself is valid).

    The bounded search (``polish_to_point``) ignores collisions; where its answer collides,
    the last valid point on the joint-space segment from q0 is kept and the search restarted
    from there.
    """
    q = q0
    x = np.empty(6)
    target = np.ascontiguousarray(p, dtype=float)
    for _ in range(4):
        polish_to_point(q, target, design.lengths, design.lower, design.upper, _POLISH_STEPS, x)
        if _valid(design, x):
            return x
        lo, hi = 0.0, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if _valid(design, q + mid * (x - q)):
                lo = mid
            else:
                hi = mid
        if lo < 1e-9:
            return q
        q = q + lo * (x - q)
    return q


def _start_seeds(design: ArmDesign, p: np.ndarray, current) -> list[np.ndarray]:
    """The stretched arm aimed at p, and current, each clipped to the limits."""
    lo, hi = design.lower, design.upper
    q = (math.atan2(p[1], p[0]), 0.0, 0.0, math.atan2(p[2], math.hypot(p[0], p[1])), 0.0, 0.0)
    # clipped with min and max, not np.clip: a level-4 answer spent 4 % of its time here
    seeds = [np.array([min(max(x, float(lo[k])), float(hi[k])) for k, x in enumerate(q)])]
    if current is not None:
        seeds.append(np.clip(current, lo, hi))
    return seeds


def _seeds(design: ArmDesign, p: np.ndarray, current) -> list:
    """Valid starting configurations: the stretched arm aimed at p, current, cloud points.

    The ``_SEEDS`` nearest p that are valid.
    """
    seeds = [q for q in _start_seeds(design, p, current) if _valid(design, q)]
    cloud_q, cloud_p = _position_cloud(design)
    # the nearest that are valid (in a scene, many near p may meet an obstacle)
    dist = np.linalg.norm(cloud_p - p, axis=1)
    k = min(_SCENE_NEAR_FIRST * _SEEDS, len(dist) - 1)
    closest = np.argpartition(dist, k)[:k]
    near = cloud_q[closest[np.argsort(dist[closest])]]
    # lazily: a validity test costs ~25 us
    seeds.extend(itertools.islice((q for q in near if _valid(design, q)), _SEEDS))
    return seeds


def _polished(design: ArmDesign, p: np.ndarray, current):
    """Each seed (``_seeds``) polished towards p: (configurations (k, 6), distances (k,), cut).

    Invalid seeds have distance inf. Under the printed-link model with no scene one
    compiled call does it all (``handarm.ik._nearest``), and ``cut`` (k,) says which polish
    a collision cut short (see ``_slid``); else seed by seed, and ``cut`` is None.
    """
    target = np.ascontiguousarray(p, dtype=float)
    if design.collision_model == "printed" and _SCENE.get() is None:
        seeds = np.ascontiguousarray(_start_seeds(design, p, current), dtype=float)
        cloud_q = _position_cloud(design)[0]
        n_cloud = min(_SEEDS, len(cloud_q))
        out_q = np.zeros((len(seeds) + n_cloud, 6))
        out_err = np.full(len(seeds) + n_cloud, np.inf)
        blocked = np.zeros(len(seeds) + n_cloud, np.bool_)
        pi, pf, groups, _, rows, c = kernel_env(design)
        env = (target, design.lengths, design.lower, design.upper, _POLISH_STEPS, pi, pf,
               groups, rows, c)  # fmt: skip
        tree = _cloud_tree(design)
        k = min(NEAR_FIRST * n_cloud, len(cloud_q))
        near = np.atleast_1d(tree.query(target, k)[1]).astype(np.int64)
        known = _cloud_validity(design)
        n = polish_each(seeds, cloud_q, known, near, n_cloud, *env, out_q, out_err, blocked)
        while n < len(seeds) + n_cloud and k < len(cloud_q):
            # too few of those valid: the next nearest, NEAR_MORE times as many
            tested, k = k, min(NEAR_MORE * k, len(cloud_q))
            near = np.atleast_1d(tree.query(target, k)[1]).astype(np.int64)[tested:]
            n += polish_each(
                seeds[:0], cloud_q, known, near, len(seeds) + n_cloud - n, *env, out_q[n:],
                out_err[n:], blocked[n:],
            )  # fmt: skip
        return out_q[:n], out_err[:n], blocked[:n]
    qs = [_polish(design, q0, p) for q0 in _seeds(design, p, current)]
    errs = [float(np.linalg.norm(_pose(design, q)[0] - p)) for q in qs]
    return np.array(qs).reshape(-1, 6), np.array(errs), None


def _slid(design: ArmDesign, p: np.ndarray, polished) -> tuple[np.ndarray, np.ndarray]:
    """Level 2's seeds: the ``_polished`` ones, those a collision cut short slid on.

    They slide along the collision boundaries (``handarm.ik._nearest.slide_best``).
    """
    qs, errs, cut = polished
    if cut is None:
        return qs, errs
    qs, errs = qs.copy(), errs.copy()
    pi, pf, groups, _, rows, c = kernel_env(design)
    slide_best(
        np.ascontiguousarray(p, dtype=float), design.lengths, design.lower, design.upper, pi,
        pf, groups, rows, c, qs, errs, cut, len(qs),
    )  # fmt: skip
    return qs, errs


def _configs_reaching(polished) -> np.ndarray:
    """Valid configurations (k, 6) whose tool point is p (to 1e-9 m), of the ``_polished`` seeds."""
    qs, errs, _ = polished
    return np.ascontiguousarray(qs[errs < 1e-9])


def _reach_bound(design: ArmDesign, p: np.ndarray, current) -> tuple[float, np.ndarray | None]:
    """A lower bound on the distance from p of every tool point, and the configuration meeting it.

    Returns (bound, q): bound in m (p may be reached where it is at most ``_AT_TARGET``); q
    the valid configuration meeting it, where the bound proves one nearest, or None. Within
    ``_AT_TARGET`` of the bound's edge (either side) q is given too: there p is reached, if
    at all, only by the configurations that meet the bound.

    Every tool point is j4 + (u cos psi, u sin psi, v) with |(u, v)| <= rt = a4 + a5 + a6
    (``handarm.ik._polish``), and j4 lies in the base-plane disk of radius a2 + a3 about joint
    2, which sits at a1 (cos q1, sin q1). So no configuration comes nearer p than the least,
    over q1 within its limits, of p's distance from that disk less rt; and the disk is
    nearest p where q1 is as near p's azimuth as the limits allow (its distance from p grows
    with the angle between them). Where p lies farther than rt from it and beyond its
    cylinder, the one configuration meeting the bound is the arm stretched from joint 2
    towards p: q = (q1, the azimuth of p from joint 2 less q1, 0, s, 0, 0), s the elevation
    of p seen from the disk's rim (with q1 at p's azimuth, the whole arm stretched at it);
    within the cylinder, those with joint 4 under p and the tip chain vertical
    (``_above_the_disk``). Where one is within the limits and valid (and clear of the scene)
    it is level 2's answer, exactly; else (joint 2 beyond its limits, a contact) q is None,
    and level 2 polishes its seeds.
    """
    a = design.lengths
    lower, upper = design.lower, design.upper
    r2, rt = float(a[2] + a[3]), float(a[4] + a[5] + a[6])
    azimuth = math.atan2(p[1], p[0])
    # joint 1 at p's azimuth (or a turn either way: one pose) if its limits hold it, else at
    # the limit nearest it; of two equally near, the nearest current's (else 0)
    turns = [azimuth + k * 2.0 * math.pi for k in (-1, 0, 1)]
    held = [t for t in turns if lower[0] <= t <= upper[0]]
    if not held:
        held = [float(lower[0]), float(upper[0])]
        nearest = max(math.cos(t - azimuth) for t in held)
        held = [t for t in held if math.cos(t - azimuth) >= nearest - 1e-15]
    near = 0.0 if current is None else float(current[0])
    q1 = min(held, key=lambda t: abs(t - near))
    vx, vy = p[0] - a[1] * math.cos(q1), p[1] - a[1] * math.sin(q1)
    r = math.hypot(vx, vy)
    bound = math.hypot(max(r - r2, 0.0), p[2]) - rt
    if bound <= -_AT_TARGET:
        return bound, None  # p may be reached, and not only at the edge
    if r <= r2:
        above = _above_the_disk(design, p, current)
        if above is not None or r < r2 * (1.0 - 1e-9):
            return bound, above
        # on the disk's rim to rounding, where the family's arcs may be empty by it
    q2 = math.remainder(math.atan2(vy, vx) - q1, 2.0 * math.pi)
    q = np.array([q1, q2, 0.0, math.atan2(p[2], max(r - r2, 0.0)), 0.0, 0.0])
    return bound, (q if _valid(design, q) else None)


#: Tip-plane azimuths tried for a point straight above or below the base's reach, spread
#: over the azimuths where joints 1 and 2 reach joint 3 (``_reach_arcs``; with 72 over the
#: whole turn, a valid window between samples 5.4 deg from current's was missed and follow
#: jumped 208 deg along a circle over the paper's arm, bench_tracking.py; with 720 over the
#: whole turn, a family 0.019 deg wide next to the rim of the base's reach was missed).
#: Members are closed-form and the validity of only the nearest is tested.
_ABOVE_SAMPLES = 720
#: rad: with current, 1,001 azimuths this far either side of current's are tried too.
_ABOVE_NEAR = math.radians(5.0)
#: Azimuths either side of the joint-limit crossings kept (``_above._limit_crossings``).
_ABOVE_CROSSINGS = 256

#: Rounds narrowing the azimuth of the valid member nearest current: each keeps a
#: sixteenth of the window, so 3 take two samples' spacing to about a 2,000th of it.
_ABOVE_ROUNDS = 3
#: rad: more rounds, up to ``_ABOVE_ROUNDS_MAX``, while the members of neighbouring azimuths
#: in the last round lay farther apart than this (a hostile check found answers 3e-5 rad
#: farther than the nearest next to the end of an arc, after three rounds).
_ABOVE_JOINT_TOL = 1e-6
_ABOVE_ROUNDS_MAX = 8


def _reach_arcs(design: ArmDesign, p: np.ndarray) -> list[tuple[float, float]]:
    """The tip-plane azimuths (arcs lo <= psi <= hi) at which the family reaches joint 3.

    Joint 3 lies a3 back from joint 4 (at p_xy) along the tip plane, at distance d from
    joint 1 with d^2 = rho^2 + a3^2 - 2 a3 rho cos(psi - phi) (rho, phi: p_xy's length and
    azimuth); joints 1 and 2 reach it where |a1 - a2| <= d <= a1 + a2, which bounds
    cos(psi - phi) on both sides: at most two arcs, symmetric about phi.
    """
    a = design.lengths
    rho, phi = math.hypot(p[0], p[1]), math.atan2(p[1], p[0])
    near, far = (a[1] - a[2]) ** 2, (a[1] + a[2]) ** 2
    if rho <= 1e-12:  # on the base axis (to rounding): d is a3 at every psi
        return [(-math.pi, math.pi)] if near <= rho * rho + a[3] ** 2 <= far else []
    c_far = (rho * rho + a[3] ** 2 - far) / (2.0 * a[3] * rho)  # cos(psi - phi) >= c_far
    c_near = (rho * rho + a[3] ** 2 - near) / (2.0 * a[3] * rho)  # cos(psi - phi) <= c_near
    if c_far > 1.0 or c_near < -1.0 or c_far > c_near:
        return []
    out, inner = math.acos(max(c_far, -1.0)), math.acos(min(c_near, 1.0))
    if inner == 0.0:
        return [(phi - out, phi + out)]
    if out == math.pi:
        return [(phi + inner, phi + 2.0 * math.pi - inner)]
    return [(phi - out, phi - inner), (phi + inner, phi + out)]


def _above_members(design: ArmDesign, p: np.ndarray, psi: np.ndarray, elbow: float) -> np.ndarray:
    """The configurations (n, 6) reaching (p_x, p_y, +-(a4 + a5 + a6)) at tip-plane azimuths psi.

    Joint 4 at (p_x, p_y), the tip chain vertical, joints 1 and 2 reaching joint 3 (one link
    back from joint 4 along the tip plane) with the given elbow (the sign of q2). Rows are
    NaN where joint 3 is out of their reach (``handarm.ik._above.member``).
    """
    psi = np.ascontiguousarray(psi, dtype=float)
    q = np.empty((len(psi), 6))
    members(np.ascontiguousarray(p, dtype=float), design.lengths, psi, float(elbow), q)
    return q


def _valid_rows(design: ArmDesign, q: np.ndarray) -> np.ndarray:
    """``_valid`` of each row of q (n, 6), in one call per test; False for NaN rows."""
    ok = np.all((q >= design.lower) & (q <= design.upper), axis=1)  # False for NaN
    if not ok.any():
        return ok
    rows = q[ok]
    valid = (
        collision_free(design, rows)
        if design.collision_model == "printed"
        else is_valid(design, rows)
    )
    scene = _SCENE.get()
    if scene is not None and valid.any():
        from handarm.scene import scene_free

        valid[valid] = scene_free(design, rows[valid], scene[0], scene[1])
    ok[ok] = valid
    return ok


def _above_the_disk(design: ArmDesign, p: np.ndarray, current) -> np.ndarray | None:
    """A valid configuration reaching (p_x, p_y, +-(a4 + a5 + a6)), or None.

    p lies above or below the base's reach (within the cylinder of ``_reach_bound``'s disk)
    and out of reach: such a configuration (``_above_members``) meets the bound, so it is
    nearest. They form a family over the tip plane's azimuth psi and the base's elbow.
    Candidates, for both elbows: 720 azimuths spread over the arcs where the family exists
    (``_reach_arcs``: next to the rim of the base's reach they narrow to hundredths of a
    degree); with current, 1,001 within 5 degrees of current's own; and the two sides of
    every place between neighbouring candidates where joint 1, 2 or 3 crosses a limit
    (``_above.limit_crossings``: the valid azimuths there can be a sliver of thousandths
    of a degree). Of these the valid one nearest current (else the zero pose) is narrowed
    down between its neighbouring candidates: a loop following the answer moves with the
    target, along the family's edge (a contact, a limit) too, not a sample's spacing at a
    time.
    """
    arcs = _reach_arcs(design, p)
    if not arcs:
        return None
    total = sum(hi - lo for lo, hi in arcs)
    grid = [
        np.linspace(lo, hi, max(2, round(_ABOVE_SAMPLES * (hi - lo) / total))) for lo, hi in arcs
    ]
    near = np.zeros(6) if current is None else np.asarray(current, dtype=float)
    if current is not None:
        # current's azimuth on the turn of each arc that holds it
        psi0 = float(near[0] + near[1] + near[2])
        local = psi0 + np.linspace(-_ABOVE_NEAR, _ABOVE_NEAR, 1001)
        for lo, hi in arcs:
            middle = 0.5 * (lo + hi)
            shifted = local + 2.0 * math.pi * round((middle - psi0) / (2.0 * math.pi))
            grid.append(shifted[(shifted >= lo) & (shifted <= hi)])
    target = np.ascontiguousarray(p, dtype=float)
    psi = np.unique(np.concatenate(grid))
    rows, crossed = [], {}
    for elbow in (1.0, -1.0):
        members_ = _above_members(design, p, psi, elbow)
        crossings = np.empty(_ABOVE_CROSSINGS)
        n = limit_crossings(
            target, design.lengths, design.lower, design.upper, psi, members_, elbow, crossings
        )
        rows += [members_, _above_members(design, p, crossings[:n], elbow)]
        crossed[elbow] = crossings[:n]
    best = _nearest_valid(design, np.vstack(rows), near)
    if best is None:
        return None
    # the distance is smooth in psi between candidates: the nearest lies between best's
    # neighbours
    elbow = 1.0 if best[1] >= 0.0 else -1.0  # q2 = 0: both elbows' member, one set
    psi = np.sort(np.concatenate([psi, crossed[elbow]]))
    k = int(
        np.argmin(np.abs(np.remainder(psi - _unwrap(best, 0.0) + math.pi, 2.0 * math.pi) - math.pi))
    )
    found = _nearest_member(
        design, p, near, elbow, psi[max(k - 1, 0)], psi[min(k + 1, len(psi) - 1)]
    )
    if found is not None and np.linalg.norm(found - near) < np.linalg.norm(best - near):
        best = found
    return best


def _nearest_member(design, p, near, elbow, lo, hi) -> np.ndarray | None:
    """The valid ``_above_members`` (of one elbow) nearest near with psi in [lo, hi], or None.

    Each round tests 33 azimuths and narrows the window to two of their spacings about the
    nearest valid one: ``_ABOVE_ROUNDS`` rounds, and more (up to ``_ABOVE_ROUNDS_MAX``)
    while neighbouring azimuths' members are more than ``_ABOVE_JOINT_TOL`` apart in joint
    space (next to the end of an arc the joints move hundreds of times as far as psi).
    """
    best = None
    for k in range(_ABOVE_ROUNDS_MAX):
        rows = _above_members(design, p, np.linspace(lo, hi, 33), elbow)
        found = _nearest_valid(design, rows, near)
        if found is None:
            break
        if best is None or np.linalg.norm(found - near) < np.linalg.norm(best - near):
            best = found
        middle, spacing = _unwrap(best, 0.5 * (lo + hi)), (hi - lo) / 32.0
        lo, hi = middle - spacing, middle + spacing
        if k + 1 >= _ABOVE_ROUNDS:
            steps = np.linalg.norm(np.diff(rows, axis=0), axis=1)
            if not np.nanmax(steps, initial=0.0) > _ABOVE_JOINT_TOL:
                break
    return best


def _nearest_valid(design: ArmDesign, q: np.ndarray, near: np.ndarray) -> np.ndarray | None:
    """The row of q (n, 6) nearest near that is within the limits and valid, or None.

    Ties in distance go to the earlier row.
    """
    q = q[np.all((q >= design.lower) & (q <= design.upper), axis=1)]  # drops NaN rows too
    dist = np.linalg.norm(q - near, axis=1)
    # nearest first: most often one of the first 8 is valid, found without sorting all
    first = np.arange(len(q)) if len(q) <= 8 else np.argpartition(dist, 7)[:8]
    first = first[np.lexsort((first, dist[first]))]
    valid = np.flatnonzero(_valid_rows(design, q[first]))
    if len(valid):
        return q[first[valid[0]]]
    rest = np.ones(len(q), bool)
    rest[first] = False
    q = q[rest][np.argsort(dist[rest], kind="stable")]
    # chunks double (16, 32, ...): where none is valid (behind the base) the thousands of
    # members cost a dozen calls, not 400
    start, size = 0, 16
    while start < len(q):
        chunk = q[start : start + size]
        valid = np.flatnonzero(_valid_rows(design, chunk))
        if len(valid):
            return chunk[valid[0]]
        start, size = start + size, 2 * size
    return None


def _unwrap(q: np.ndarray, psi0: float) -> float:
    """The tip-plane azimuth q1 + q2 + q3 of q, the turn nearest psi0."""
    return psi0 + math.remainder(float(q[0] + q[1] + q[2]) - psi0, 2.0 * math.pi)


def _two_dof(design: ArmDesign, p, e, current, polished=None, stretched=None) -> IKResult:
    """Nearest reachable tool point; the tool points at p when the arm can.

    ``polished``: the seeds already polished towards p (``_polished``), if they are;
    ``stretched``: the configuration ``_reach_bound`` proved nearest, if it did.
    """
    best_q, best_err = None, math.inf
    if stretched is not None:
        # the nearest point of all, proven by a bound: no polish can do better
        qs, errs = (
            stretched[None, :],
            np.array([float(np.linalg.norm(_pose(design, stretched)[0] - p))]),
        )
    else:
        if polished is None:
            polished = _polished(design, p, current)
        qs, errs = _slid(design, p, polished)
    for q, err in zip(qs, errs, strict=True):
        if err < best_err - 1e-12:
            best_q, best_err = q, float(err)
    if current is not None and best_q is not None:
        # ties (within HOLD_DISTANCE) go to the configuration nearest current (see _choose);
        # current itself is one, unpolished: where the distance is flat (the nearest point
        # of a contact or a fold), each polish from current gained 2e-9 m and moved it up
        # to 0.9 degrees, so a held target crept
        if _valid(design, current):
            qs = np.vstack([qs, current])
            errs = np.append(errs, float(np.linalg.norm(_pose(design, current)[0] - p)))
        tied = np.flatnonzero(errs <= best_err + HOLD_DISTANCE)
        k = tied[np.argmin(np.linalg.norm(qs[tied] - current, axis=1))]
        best_q, best_err = qs[k], float(errs[k])
    if best_q is None and _SCENE.get() is not None:  # nothing clear of the scene near p
        return IKResult(
            np.zeros((0, 6)), np.zeros((0, 3), int), np.zeros((0, 2)), 0, 0.0, 0.0,
            False, 0.0, p.copy(), e.copy(), None,
        )  # fmt: skip
    if best_q is None:  # no valid seed at all: the zero pose is the fallback
        best_q = np.zeros(6)
        best_err = float(np.linalg.norm(_pose(design, best_q)[0] - p))
    if best_err < _AT_TARGET:
        # p is reached after all: its poses are a set level 3's search cannot see (the
        # stretched arm on the reach sphere has one direction, the radial one), and where
        # that is e's, the pose is exact (the straight arm)
        dof = 5 if _angle(_pose(design, best_q)[1], e) < 1e-9 else 3
        return _single_point(design, best_q, p, e, dof, 0.0, current)
    p_reached, e_reached = _pose(design, best_q)
    # point at the target from there, if that pose has a solution
    aim = p - p_reached
    if np.linalg.norm(aim) > 1e-12:
        aim = aim / np.linalg.norm(aim)
        r = _solve_exact(design, p_reached, aim, best_q if current is None else current)
        # with current, only if its follow stays near (else the polished configuration);
        # where best_q points at p already (the bound's answers: the stretched arm, the
        # tip chain vertical under p) it is a solution of that pose, so no farther than it
        # (a vertical aim's ranges are taken at one azimuth of L, which may not be best_q's)
        ratio = 1.0 if _angle(e_reached, aim) < 1e-9 else HOLD_RATIO
        held = r.count and (
            current is None
            or np.linalg.norm(r.follow - current)
            <= ratio * float(np.linalg.norm(best_q - current)) + 1e-6
        )
        if held:
            return dataclasses.replace(
                r,
                reached_dof=2,
                position_error=best_err,
                direction_error=float(_angle(aim, e)),
                follow=r.follow if current is not None else None,
            )
    return _single_point(design, best_q, p, e, 2, best_err, current)


def _single_point(design, q, p, e, dof, position_error, current) -> IKResult:
    """A solution set of one configuration q: a zero-length range [u, u].

    At level 5 this is a degenerate exact solution (the straight arm, joints pinned at
    their limits) that the range solver, which classifies open gaps between events, cannot
    see; ``achieved_direction`` is then e itself. At levels 5 and 3 q reaches p (to
    rounding), and ``achieved_position`` is p itself.
    """
    pose = np.empty(8)
    tool_pose(np.ascontiguousarray(q, dtype=float), design.lengths, pose)
    p_reached, e_reached = pose[:3].copy(), pose[3:6].copy()
    psi = math.atan2(math.sin(q[0] + q[1] + q[2]), math.cos(q[0] + q[1] + q[2]))
    branch, u = S.branch_from_pose(q, p_reached, e_reached, pose[6:8])
    u = float(u)
    if dof >= 3:
        p_reached = p.copy()
    if dof == 5:
        e_reached = e.copy()
    return IKResult(
        q[None, :],
        branch[None, :],
        np.array([[u, u]]),
        dof,
        position_error,
        0.0 if dof == 5 else float(_angle(e_reached, e)),
        S.horizontal_length(e_reached[0], e_reached[1]) < S.VERTICAL_EPS,
        psi if branch[0] > 0 else psi - math.copysign(math.pi, psi),
        p_reached.copy(),
        e_reached.copy(),
        q.copy() if current is not None else None,
    )
