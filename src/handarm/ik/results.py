"""Result values of the IK: one target (IKResult) or many (BatchResult), and a text table."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from handarm._checks import check_joints

__all__ = ["IKResult", "BatchResult", "MAX_SOLUTIONS", "format_result", "nearest_solution"]

#: Usual rows per target of a batch result (the paper's example has up to 3 ranges x 2 x 2 x 2
#: = 24); a batch holding a target with more ranges is widened to fit them all.
MAX_SOLUTIONS = 24


@dataclasses.dataclass(frozen=True, eq=False)
class IKResult:
    """Every solution range of one target.

    Attributes
    ----------
    solutions : ndarray, shape (k, 6)
        Joint angles (rad) at the midpoint of each range; sorted by distance to ``current``
        when it was given, else by branch and u.
    branches : ndarray of int, shape (k, 3)
        (sign of d, elbow of B, elbow of E), each +1/-1.
    intervals : ndarray, shape (k, 2)
        [u_lo, u_hi] of joint 4 along L for each range (m); u_lo == u_hi where two joints
        meet their limits at once and that one configuration is the range.
    reached_dof : int
        5 when the target is reached exactly; 4, 3 or 2 when degraded (see ``degrade``);
        0 when there is no range (nothing reached).
    position_error, direction_error : float
        Distance (m) and angle (rad) between the target and the pose of ``solutions``.
    vertical : bool
        The direction the ranges solve (``target[1]``: ``e`` when exact, the relaxed one
        when degraded) was vertical, so d was free; the ranges are those at ``azimuth``:
        the azimuth with a solution nearest to that of ``current`` (l3's direction), or
        without ``current``, nearest to the direction from joint 1 towards the target (0.5
        degree steps).
    azimuth : float
        Direction of L (rad from +x) for d = +1.
    achieved_position, achieved_direction : ndarray, shape (3,)
        The pose the solutions reach (the target itself when reached_dof == 5).
    follow : ndarray, shape (6,) or None
        With ``current``: the configuration inside the ranges nearest to it (u of each range
        clamped towards the present one). It moves little when the target moves little,
        which makes it the output to send in a handheld control loop. None without
        ``current`` or without solutions.
    follow_distance : float or None
        With ``follow``: its joint-space distance from ``current`` (rad, Euclidean).
    family_ended : bool
        With ``follow``: True when the range ``current`` lay on does not continue to this
        target (a joint limit reached, two links met, the target out of its reach), so
        ``follow`` had to jump to another range: it moved more than ``FAMILY_END_RATIO``
        (10) times the least joint motion that reaches the target's pose from ``current``
        (to first order, ``handarm.ik.api.least_joint_motion``). Also when that least
        motion and ``follow``'s move both exceed ``ANSWER_JUMP`` (0.35 rad), where first
        order does not hold: a degraded answer whose best relaxed pose jumped (the levels
        are optimal per target, not continuous along a path), or a jump next to a singular
        pose. A loop that sees it should slow down or ask before sending ``follow``.
    clearances : ndarray, shape (k, 2) or None
        With a scene (``solve(..., scene=...)``): the smallest and largest clearance (m)
        between the printed links and the obstacles, sampled at 65 points of each range.
    clearest : ndarray, shape (k,) or None
        With a scene: the u (m) of each range's largest sampled clearance, where its
        representative in ``solutions`` sits.
    blocked_by : tuple of str
        With a scene and no exact range left: the obstacles that block the exact solutions
        (the result is then degraded, or empty when nothing near the target keeps clear).

    A result with no range (``count == 0``) reached nothing: its ``reached_dof`` is 0
    whatever it was made with, its errors 0, its achieved pose the target itself (no pose
    was reached: ``to_dict`` writes these as null).
    """

    solutions: np.ndarray
    branches: np.ndarray
    intervals: np.ndarray
    reached_dof: int = 5
    position_error: float = 0.0
    direction_error: float = 0.0
    vertical: bool = False
    azimuth: float = 0.0
    achieved_position: np.ndarray | None = None
    achieved_direction: np.ndarray | None = None
    follow: np.ndarray | None = None
    follow_distance: float | None = None
    family_ended: bool = False
    clearances: np.ndarray | None = None
    clearest: np.ndarray | None = None
    blocked_by: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if len(self.solutions) == 0 and self.reached_dof != 0:
            # no range reached anything: a loop that tests reached_dof == 5 must not take
            # an empty answer for an exact one (frozen: set through object)
            object.__setattr__(self, "reached_dof", 0)

    @property
    def count(self) -> int:
        """Number of solution ranges."""
        return len(self.solutions)

    def __len__(self) -> int:
        return self.count

    @property
    def target(self) -> tuple[np.ndarray, np.ndarray]:
        """The (p, e) the ranges solve exactly: the relaxed target when degraded.

        Pass it (and ``azimuth``) to ``configuration_at`` for other points of a range; the
        ranges of a degraded result do not belong to the requested target.
        """
        return self.achieved_position, self.achieved_direction

    def to_dict(self) -> dict:
        """Plain JSON-ready dict; angles in degrees, lengths in metres (keys say which).

        An empty answer (``reached_dof`` 0) reached no pose: its errors and achieved pose
        are null, so that no reader of the file takes it for the target reached.
        """
        reached = self.reached_dof != 0
        return {
            "reached_dof": int(self.reached_dof),
            "position_error_m": float(self.position_error) if reached else None,
            "direction_error_deg": math.degrees(self.direction_error) if reached else None,
            "vertical": bool(self.vertical),
            "azimuth_deg": math.degrees(self.azimuth),
            "achieved_position_m": _list(self.achieved_position) if reached else None,
            "achieved_direction": _list(self.achieved_direction) if reached else None,
            "solutions": [
                {
                    "q_deg": np.degrees(q).tolist(),
                    "branch": [int(b) for b in br],
                    "u_range_m": iv.tolist(),
                }
                for q, br, iv in zip(self.solutions, self.branches, self.intervals, strict=True)
            ],
            "follow_deg": None if self.follow is None else np.degrees(self.follow).tolist(),
            "follow_distance_rad": self.follow_distance,
            "family_ended": bool(self.family_ended),
        } | self._scene_dict()

    def _scene_dict(self) -> dict:
        if self.clearances is None:
            return {}
        return {
            "clearance_m": [[float(lo), float(hi)] for lo, hi in self.clearances],
            "clearest_u_m": [float(u) for u in self.clearest],
            "blocked_by": list(self.blocked_by),
        }

    def nearest(self, current) -> np.ndarray:
        """The solution closest to ``current`` (Euclidean in joint space), shape (6,)."""
        if self.count == 0:
            raise ValueError("no solution to choose from")
        return self.solutions[nearest_solution(self.solutions, current)]


@dataclasses.dataclass(frozen=True, eq=False)
class BatchResult:
    """Solutions of N targets, padded to W >= ``MAX_SOLUTIONS`` rows (W fits every range).

    Attributes
    ----------
    counts : ndarray of int, shape (N,)
        Ranges stored per target (rows past it are NaN in ``solutions`` and ``intervals``,
        0 in ``branches``).
    solutions : ndarray, shape (N, W, 6)
    branches : ndarray of int8, shape (N, W, 3)
    intervals : ndarray, shape (N, W, 2)
    truncated : ndarray of bool, shape (N,)
        Always False: kept for compatibility, no range is dropped any more.
    vertical : ndarray of bool, shape (N,)
    azimuth : ndarray, shape (N,)
        Direction of L for d = +1 (for vertical rows, the azimuth used; see IKResult).
    """

    counts: np.ndarray
    solutions: np.ndarray
    branches: np.ndarray
    intervals: np.ndarray
    truncated: np.ndarray
    vertical: np.ndarray
    azimuth: np.ndarray


def _list(x):
    return None if x is None else np.asarray(x, dtype=float).tolist()


def format_result(result: IKResult) -> str:
    """Human-readable table of an IKResult: joint angles in degrees, ranges in mm."""
    lines = []
    level = {
        0: "nothing (no solution)",
        5: "5 DoF (exact)",
        4: "4 DoF (pitch or yaw relaxed)",
        3: "3 DoF (position only)",
        2: "2 DoF (out of reach: nearest point, pointing at the target)",
    }
    lines.append(f"reached: {level.get(result.reached_dof, result.reached_dof)}")
    if 0 < result.reached_dof < 5:
        lines.append(
            f"position error {result.position_error * 1e3:.3f} mm, "
            f"direction error {math.degrees(result.direction_error):.3f} deg"
        )
    if result.vertical:
        lines.append(
            f"vertical direction: L taken at azimuth {math.degrees(result.azimuth):.2f} deg"
        )
    lines.append(f"{result.count} solution range(s)")
    if result.count:
        head = "  #   " + "".join(f"{'q' + str(k):>9}" for k in range(1, 7))
        lines.append(head + "   branch (d,B,E)   u range (mm)")
        for i, (q, br, iv) in enumerate(
            zip(result.solutions, result.branches, result.intervals, strict=True)
        ):
            angles = "".join(f"{v:9.2f}" for v in np.degrees(q))
            signs = " ".join(f"{int(b):+d}" for b in br)
            lines.append(
                f"{i + 1:>3}   {angles}   {signs:>14}   [{iv[0] * 1e3:.2f}, {iv[1] * 1e3:.2f}]"
            )
    if result.follow is not None:
        lines.append(
            "follow (nearest to current): "
            + " ".join(f"{v:.2f}" for v in np.degrees(result.follow))
        )
    return "\n".join(lines) + "\n"


def nearest_solution(solutions: np.ndarray, current) -> int:
    """Index of the row of ``solutions`` (k, 6) closest to ``current`` (6,)."""
    current = check_joints(current, "current")
    return int(np.argmin(np.sum((solutions - current) ** 2, axis=-1)))
