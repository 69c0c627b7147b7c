"""The public ``solve``: the exact core, then graceful degradation when it finds nothing."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from handarm.design import ArmDesign
from handarm.ik._common import wrap
from handarm.ik._polish import least_motion
from handarm.ik.degrade import ORDERS, _angle, degrade_target
from handarm.ik.exact import _exact, check_clearance, check_inputs
from handarm.ik.results import IKResult

__all__ = ["solve", "least_joint_motion", "FAMILY_END_RATIO"]


def solve(
    design: ArmDesign,
    p,
    e,
    current=None,
    *,
    degrade: bool = True,
    order: str = "paper",
    scene=None,
    clearance: float = 0.0,
) -> IKResult:
    """Every solution range of the target (p, e), or the closest reachable pose.

    Parameters
    ----------
    design : ArmDesign
    p : array-like, shape (3,)
        Tool point (m).
    e : array-like, shape (3,)
        Tool direction; normalised here (a zero vector is an error).
    current : array-like, shape (6,), optional
        The arm's present configuration (rad, within +-2 pi): solutions are sorted by
        distance to it, a vertical ``e`` uses its azimuth, degraded answers stay near it,
        and ``follow`` is the in-range configuration nearest it. An ``e`` within
        VERTICAL_CONE (1e-3 rad) of vertical is reached in current's tip plane: exact
        elevation, ``direction_error`` at most 2e-3 rad, no swing of the tip plane.
    degrade : bool
        When no 5-DoF solution exists, return the closest reachable pose (4, 3 or 2 DoF)
        instead of an empty result.
    order : {"paper", "angle"}
        Order of the degradation levels. "paper": 4 DoF (pitch or yaw of ``e`` kept), then
        3 DoF (best direction), then 2 DoF; keeping pitch or yaw can cost more angle than
        the best direction. "angle" (smallest angle first): the reachable direction
        closest to ``e``, reported as level 4 when it keeps pitch or yaw.
    scene : handarm.scene.Scene, optional
        Obstacles in the handle frame: the ranges keep ``clearance`` (m) from them (see
        ``handarm.ik.obstacles``). A target whose every solution meets an obstacle degrades
        with the scene included (every level keeps the clearance); ``blocked_by`` names the
        obstacles that blocked the exact solutions. With ``degrade=False`` the result is
        then empty.
    clearance : float
        Distance (m) kept from the scene's obstacles.

    Returns
    -------
    IKResult

    Raises
    ------
    TypeError
        If ``design`` is not an ArmDesign.
    ValueError
        If ``p``, ``e`` or ``current`` has the wrong shape, is not finite, or ``e`` is zero;
        if ``p`` lies beyond 100 x the arm's reach or ``current`` beyond +-2 pi (units
        mistaken); if ``order`` or ``degrade`` is not one of its values; if ``clearance``
        is not a distance in [0, 1] m, or not 0 without a ``scene``.
    """
    check_clearance(clearance, scene)
    if order not in ORDERS:
        raise ValueError(f"order: expected one of {list(ORDERS)}, got {order!r}")
    if not isinstance(degrade, (bool, np.bool_)):
        raise ValueError(f"degrade: expected True or False, got {degrade!r}")
    degrade = bool(degrade)  # numpy's booleans too, as chunk takes numpy's integers
    if scene is not None:
        from handarm.ik.obstacles import solve_in_scene

        result = solve_in_scene(design, p, e, scene, clearance, current)
        p, e, current = check_inputs(design, p, e, current)
        if result.count or not degrade:
            return _with_motion(design, result, current)
        degraded = degrade_target(design, p, e, current, order, scene=scene, clearance=clearance)
        _check_finite(degraded)
        degraded = dataclasses.replace(degraded, blocked_by=result.blocked_by)
        return _with_motion(design, degraded, current)
    p, e, current = check_inputs(design, p, e, current)
    v = _cone_direction(e, current)
    result = None if v is None else _exact(design, p, v, current)
    if result is not None and result.count:
        result = dataclasses.replace(result, direction_error=float(_angle(v, e)))
    else:
        result = _exact(design, p, e, current)
    if not (result.count or not degrade):
        # within the cone the degraded levels aim at v too: e's own azimuth is noise there,
        # and level 4's circles would swing with it
        result = degrade_target(design, p, e if v is None else v, current, order)
        if v is not None:
            result = dataclasses.replace(
                result, direction_error=float(_angle(result.achieved_direction, e))
            )
    _check_finite(result)
    return _with_motion(design, result, current)


#: ``follow`` moving more than this many times the least joint motion that reaches the
#: target's pose from ``current`` (to first order) means the range ``current`` lay on has
#: ended. Measured (benchmarks/bench_tracking.py): 1e-6 noise moves follow at most 3.7x that
#: motion, 2 mm path steps at most 3.5x (99th percentile 1.5x), jumps near singular poses
#: included; a range that ends at a joint limit or where two links meet costs far more.
FAMILY_END_RATIO = 10.0
#: ... and more than this (rad): a microradian is far below a servo's step (1.5e-3 rad)
FAMILY_END_FLOOR = 1e-6
#: An answer whose pose lies beyond first order from ``current``'s (the least joint motion
#: to it over this, rad) while ``follow`` moves over this too: the ratio above says nothing
#: there (first order does not hold), and the family ``current`` lay on ended. At a degraded
#: level the best relaxed pose jumped to another region (the levels are optimal per target,
#: not continuous along a path); at an exact one, near a singular pose, where the least
#: motion blows up (1,219 rad for a 67-degree jump a hostile check found). 0.35 rad is 20
#: degrees; 2 mm steps of exactly reachable paths need under 0.25 rad of least motion (99th
#: percentile, benchmarks/bench_tracking.py), and 1e-6 of noise on a degraded answer about
#: 1e-5 rad.
ANSWER_JUMP = 0.35


def _with_motion(design: ArmDesign, result: IKResult, current) -> IKResult:
    """The result with ``follow_distance`` and ``family_ended`` filled in (with current)."""
    if current is None or result.follow is None:
        return result
    moved = float(np.linalg.norm(result.follow - current))
    least = least_joint_motion(design, current, result.achieved_position, result.achieved_direction)
    ended = moved > FAMILY_END_RATIO * least + FAMILY_END_FLOOR
    if least > ANSWER_JUMP and moved > ANSWER_JUMP:
        ended = True  # beyond first order, and follow jumped
    return dataclasses.replace(result, follow_distance=moved, family_ended=ended)


def least_joint_motion(design: ArmDesign, q, p, e) -> float:
    """The least joint motion (rad, Euclidean) that takes q's pose to (p, e) to first order.

    ``|pinv(J) dx|`` with J the 6 x 6 Jacobian of the tool point and direction at q (the
    direction's rows have rank 2) and dx the difference of the poses
    (``handarm.ik._polish.least_motion``).
    """
    return float(
        least_motion(
            np.ascontiguousarray(q, dtype=float),
            design.lengths,
            np.ascontiguousarray(p, dtype=float),
            np.ascontiguousarray(e, dtype=float),
        )
    )


#: With ``current``, a direction within this angle (rad) of straight up/down is reached with
#: the tip plane of ``current`` (its elevation kept exactly, the azimuth of its tiny
#: horizontal part relaxed): that azimuth is sensor noise there, and following it would
#: swing the tip plane around. A degraded target in the cone is degraded towards that
#: direction too (level 4's circles then keep current's tip plane); its ``direction_error``
#: is measured from e itself.
VERTICAL_CONE = 1e-3


def _cone_direction(e, current) -> np.ndarray | None:
    """E turned into ``current``'s tip plane, its elevation kept exactly, or None.

    Only with ``current`` and e within ``VERTICAL_CONE`` of vertical (not exactly vertical).
    """
    h = math.hypot(e[0], e[1])
    if current is None or h == 0.0 or h >= math.sin(VERTICAL_CONE):
        return None
    psi = float(wrap(current[0] + current[1] + current[2]))
    # the tip plane of current, on the side nearer e's horizontal part
    if math.cos(math.atan2(e[1], e[0]) - psi) < 0.0:
        psi += math.pi
    return np.array([h * math.cos(psi), h * math.sin(psi), e[2]])


def _check_finite(result: IKResult) -> None:
    """No NaN leaves ``solve``: a non-finite number here is a bug, never the user's input."""
    parts = [
        result.solutions,
        result.intervals,
        result.achieved_position,
        result.achieved_direction,
    ]
    if result.follow is not None:
        parts.append(result.follow)
    # a sum is NaN or infinite when any term is (no overflow: angles, metres within 100 x
    # the reach); summed as Python floats, which for these few numbers costs a quarter of
    # one numpy reduction per array
    total = result.position_error + result.direction_error + result.azimuth
    for x in parts:
        total += sum(x.ravel().tolist())
    if not math.isfinite(total):
        raise RuntimeError("IK: non-finite number in the result (please report this target)")
