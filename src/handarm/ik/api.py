"""The public ``solve``: the exact core, then graceful degradation when it finds nothing."""

from __future__ import annotations

from handarm.design import ArmDesign
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
    order : {"paper", "angle"}
        Order of the degradation levels. "paper": 4 DoF (pitch or yaw of ``e`` kept), then
        3 DoF (best direction), then 2 DoF; keeping pitch or yaw can cost more angle than
        the best direction. "angle" (smallest angle first): the reachable direction
        closest to ``e``, reported as level 4 when it keeps pitch or yaw.

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
    if order not in ORDERS:
        raise ValueError(f"order: expected one of {list(ORDERS)}, got {order!r}")
    if not isinstance(degrade, bool):
        raise ValueError(f"degrade: expected True or False, got {degrade!r}")
    p, e, current = check_inputs(design, p, e, current)
    result = _exact(design, p, e, current)
    if result.count or not degrade:
        return result
    return degrade_target(design, p, e, current, order)
