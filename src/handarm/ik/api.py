"""The public ``solve``: the exact core, then graceful degradation when it finds nothing."""

from __future__ import annotations

from handarm.design import ArmDesign
from handarm.ik.degrade import degrade_target
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
        The arm's present configuration (rad): solutions are sorted by distance to it, a
        vertical ``e`` uses its azimuth, and degraded answers stay near it.
    degrade : bool
        When no 5-DoF solution exists, return the closest reachable pose (4, 3 or 2 DoF)
        instead of an empty result.
    scene : handarm.scene.Scene, optional
        Obstacles in the handle frame: the ranges keep ``clearance`` (m) from them (see
        ``handarm.ik.obstacles``). With a scene there is no degradation yet: a target whose
        every solution meets an obstacle gives an empty result naming them in ``blocked_by``.
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
        If ``p``, ``e`` or ``current`` has the wrong shape, is not finite, or ``e`` is zero.
    """
    if scene is not None:
        from handarm.ik.obstacles import solve_in_scene

        return solve_in_scene(design, p, e, scene, clearance, current)
    p, e, current = check_inputs(design, p, e, current)
    result = _exact(design, p, e, current)
    if result.count or not degrade:
        return result
    return degrade_target(design, p, e, current)
