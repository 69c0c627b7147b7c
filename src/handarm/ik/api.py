"""The public ``solve``: the exact core, then graceful degradation when it finds nothing."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from handarm.design import ArmDesign
from handarm.ik._common import wrap
from handarm.ik.degrade import ORDERS, degrade_target
from handarm.ik.exact import _exact, check_inputs
from handarm.ik.results import IKResult

__all__ = ["solve"]


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
        mistaken); if ``order`` or ``degrade`` is not one of its values.
    """
    if order not in ORDERS:
        raise ValueError(f"order: expected one of {list(ORDERS)}, got {order!r}")
    if not isinstance(degrade, bool):
        raise ValueError(f"degrade: expected True or False, got {degrade!r}")
    if scene is not None:
        from handarm.ik.obstacles import solve_in_scene

        result = solve_in_scene(design, p, e, scene, clearance, current)
        if result.count or not degrade:
            return result
        p, e, current = check_inputs(design, p, e, current)
        degraded = degrade_target(design, p, e, current, order, scene=scene, clearance=clearance)
        _check_finite(degraded)
        return dataclasses.replace(degraded, blocked_by=result.blocked_by)
    p, e, current = check_inputs(design, p, e, current)
    result = _near_vertical(design, p, e, current)
    if result is None:
        result = _exact(design, p, e, current)
    if not (result.count or not degrade):
        result = degrade_target(design, p, e, current, order)
    _check_finite(result)
    return result


#: With ``current``, a direction within this angle (rad) of straight up/down is reached with
#: the tip plane of ``current`` (its elevation kept exactly, the azimuth of its tiny
#: horizontal part relaxed): that azimuth is sensor noise there, and following it would
#: swing the tip plane around.
VERTICAL_CONE = 1e-3


def _near_vertical(design: ArmDesign, p, e, current) -> IKResult | None:
    """The tolerance-cone answer for a near-vertical e with ``current`` (None otherwise)."""
    h = math.hypot(e[0], e[1])
    if current is None or h == 0.0 or h >= math.sin(VERTICAL_CONE):
        return None
    psi = float(wrap(current[0] + current[1] + current[2]))
    # the tip plane of current, on the side nearer e's horizontal part
    if math.cos(math.atan2(e[1], e[0]) - psi) < 0.0:
        psi += math.pi
    v = np.array([h * math.cos(psi), h * math.sin(psi), e[2]])
    r = _exact(design, p, v, current)
    if r.count == 0:
        return None
    err = 2.0 * math.atan2(float(np.linalg.norm(v - e)), float(np.linalg.norm(v + e)))
    return dataclasses.replace(r, direction_error=err)


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
    scalars = (result.position_error, result.direction_error, result.azimuth)
    if not (all(np.all(np.isfinite(x)) for x in parts) and all(map(math.isfinite, scalars))):
        raise RuntimeError("IK: non-finite number in the result (please report this target)")
