"""Forward kinematics of the arm, batched over any leading dimensions.

The chain is fixed (outside tools rely on it)::

    T(q) = Rz(q1) Tx(a1) Rz(q2) Tx(a2) Rz(q3) Tx(a3) Rx(+90deg)
           Rz(q4) Tx(a4) Rz(q5) Tx(a5) Rz(q6) Tx(a6)

Joints 1-3 turn in the base plane z = 0; joints 4-6 turn in the tip plane, which holds
l3 and the z axis. In the tip plane a point is written (u, v): u along l3's direction
``(cos psi, sin psi, 0)`` with ``psi = q1 + q2 + q3``, and v along +z. Positive q4 lifts
the tip towards +z.
"""

from __future__ import annotations

import numpy as np

from handarm._checks import check_design, check_joints
from handarm.collision import LINK_PAIRS, collision_free, printed_collisions
from handarm.design import ArmDesign

__all__ = [
    "forward",
    "forward_matrix",
    "joint_frames",
    "joint_positions",
    "is_valid",
    "within_limits",
    "planar_points",
    "segments_intersect",
    "link_crossings",
    "colliding_pairs",
    "COLLISION_PAIRS",
]

#: Non-adjacent link pairs checked for crossing (the paper's model): base plane, then tip plane.
#: Relative size below which an orientation test counts as collinear (see segments_intersect).
COLLINEAR_TOL = 1e-12

COLLISION_PAIRS = (
    ("l0", "l2"),
    ("l0", "l3"),
    ("l1", "l3"),
    ("l6", "l4"),
    ("l6", "l3"),
    ("l5", "l3"),
)


def planar_points(design: ArmDesign, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint positions of both 3R sections in their own plane.

    Parameters
    ----------
    design : ArmDesign
    q : ndarray, shape (..., 6)

    Returns
    -------
    base : ndarray, shape (..., 5, 2)
        Base plane (x, y): handle end of l0, joints 1, 2, 3, 4.
    tip : ndarray, shape (..., 5, 2)
        Tip plane (u, v), origin at joint 4: joint 3, joints 4, 5, 6, tool point.
    """
    a = design.lengths
    q = np.asarray(q, dtype=float)
    t = np.cumsum(q[..., 0:3], axis=-1)
    s = np.cumsum(q[..., 3:6], axis=-1)
    lead = q.shape[:-1]

    base = np.zeros(lead + (5, 2))
    base[..., 0, 0] = -a[0]
    steps = a[1:4, None] * np.stack([np.cos(t), np.sin(t)], axis=-1)
    base[..., 2:, :] = np.cumsum(steps, axis=-2)

    tip = np.zeros(lead + (5, 2))
    tip[..., 0, 0] = -a[3]
    steps = a[4:7, None] * np.stack([np.cos(s), np.sin(s)], axis=-1)
    tip[..., 2:, :] = np.cumsum(steps, axis=-2)
    return base, tip


def _lift_tip(base: np.ndarray, tip: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """Tip-plane points (u, v) to 3D, shape (..., n, 3)."""
    j4 = base[..., 4, :]
    dx, dy = np.cos(psi)[..., None], np.sin(psi)[..., None]
    out = np.empty(tip.shape[:-1] + (3,))
    out[..., 0] = j4[..., None, 0] + tip[..., 0] * dx
    out[..., 1] = j4[..., None, 1] + tip[..., 0] * dy
    out[..., 2] = tip[..., 1]
    return out


def forward(design: ArmDesign, q) -> tuple[np.ndarray, np.ndarray]:
    """Tool point and tool direction.

    Parameters
    ----------
    design : ArmDesign
    q : array-like, shape (..., 6)
        Joint angles in radians.

    Returns
    -------
    p : ndarray, shape (..., 3)
        Tool point in the base frame (m).
    e : ndarray, shape (..., 3)
        Tool direction (unit x axis of the tool frame).
    """
    check_design(design)
    q = check_joints(q)
    base, tip = planar_points(design, q)
    psi = q[..., 0] + q[..., 1] + q[..., 2]
    p = _lift_tip(base, tip[..., 4:5, :], psi)[..., 0, :]
    s6 = q[..., 3] + q[..., 4] + q[..., 5]
    e = np.stack([np.cos(s6) * np.cos(psi), np.cos(s6) * np.sin(psi), np.sin(s6)], axis=-1)
    return p, e


def joint_positions(design: ArmDesign, q) -> np.ndarray:
    """Positions along the arm, shape (..., 8, 3), metres.

    Rows: the handle end of l0, joints 1..6, the tool point.
    """
    check_design(design)
    q = check_joints(q)
    base, tip = planar_points(design, q)
    psi = q[..., 0] + q[..., 1] + q[..., 2]
    out = np.zeros(q.shape[:-1] + (8, 3))
    out[..., 0:4, 0:2] = base[..., 0:4, :]
    out[..., 4:8, :] = _lift_tip(base, tip[..., 1:5, :], psi)
    return out


def _rot_z(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    m = np.zeros(np.shape(angle) + (4, 4))
    m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1] = c, -s, s, c
    m[..., 2, 2] = m[..., 3, 3] = 1.0
    return m


def joint_frames(design: ArmDesign, q) -> np.ndarray:
    """Frames of joints 1..6 (after their rotation) and the tool, shape (..., 7, 4, 4).

    These are the URDF link frames ``link1..link6`` and ``tool``.
    """
    check_design(design)
    q = check_joints(q)
    a = design.lengths
    frames = np.empty(q.shape[:-1] + (7, 4, 4))
    current = np.broadcast_to(np.eye(4), q.shape[:-1] + (4, 4))
    twist = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=float)
    for k in range(6):
        origin = np.eye(4)
        origin[0, 3] = a[k] if k > 0 else 0.0
        if k == 3:
            origin = origin @ twist
        current = current @ origin @ _rot_z(q[..., k])
        frames[..., k, :, :] = current
    tool = np.eye(4)
    tool[0, 3] = a[6]
    frames[..., 6, :, :] = current @ tool
    return frames


def forward_matrix(design: ArmDesign, q) -> np.ndarray:
    """Homogeneous tool transform T(q), shape (..., 4, 4)."""
    return joint_frames(design, q)[..., 6, :, :]


def within_limits(design: ArmDesign, q) -> np.ndarray:
    """True where every joint lies within its closed limit interval, shape (...,)."""
    check_design(design)
    q = check_joints(q)
    return np.all((q >= design.lower) & (q <= design.upper), axis=-1)


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (
        b[..., 0] - o[..., 0]
    )


def segments_intersect(p1, p2, p3, p4) -> np.ndarray:
    """Whether closed segments p1p2 and p3p4 share a point, batched, shape (...,).

    Touching counts as intersecting. Orientation values below ``COLLINEAR_TOL`` times the
    product of the segment lengths count as zero, so that exactly degenerate cases (a line
    through a joint) are decided the same way whatever the rounding; the bounding-box test
    keeps nearly collinear, disjoint segments (a straight arm) apart.
    """
    p1, p2, p3, p4 = (np.asarray(x, dtype=float) for x in (p1, p2, p3, p4))
    len_a = np.linalg.norm(p2 - p1, axis=-1)
    len_b = np.linalg.norm(p4 - p3, axis=-1)
    grow = (COLLINEAR_TOL * np.maximum(len_a, len_b))[..., None]
    lo_a, hi_a = np.minimum(p1, p2) - grow, np.maximum(p1, p2) + grow
    lo_b, hi_b = np.minimum(p3, p4), np.maximum(p3, p4)
    boxes = np.all((lo_a <= hi_b) & (lo_b <= hi_a), axis=-1)
    tol = COLLINEAR_TOL * len_a * len_b
    d1, d2 = _snap(_cross(p3, p4, p1), tol), _snap(_cross(p3, p4, p2), tol)
    d3, d4 = _snap(_cross(p1, p2, p3), tol), _snap(_cross(p1, p2, p4), tol)
    # Non-collinear segments meet iff each straddles the other's line; collinear ones
    # (all four zero) meet iff their boxes overlap.
    return boxes & (d1 * d2 <= 0.0) & (d3 * d4 <= 0.0)


def _snap(x: np.ndarray, tol: np.ndarray) -> np.ndarray:
    return np.where(np.abs(x) <= tol, 0.0, x)


#: Up to this many configurations ``link_crossings`` tests the six pairs in one call.
_STACK_PAIRS = 256


def link_crossings(design: ArmDesign, q) -> np.ndarray:
    """Which of ``COLLISION_PAIRS`` cross, shape (..., 6) bool."""
    check_design(design)
    q = check_joints(q)
    base, tip = planar_points(design, q)
    seg_b = {f"l{k}": (base[..., k, :], base[..., k + 1, :]) for k in range(4)}
    seg_t = {f"l{k}": (tip[..., k - 3, :], tip[..., k - 2, :]) for k in range(3, 7)}
    ends = [
        (seg_b if i < 3 else seg_t)[m] + (seg_b if i < 3 else seg_t)[n]
        for i, (m, n) in enumerate(COLLISION_PAIRS)
    ]
    if q[..., 0].size <= _STACK_PAIRS:
        # few configurations: one call for the six pairs, a quarter of the time
        return segments_intersect(*(np.stack(x, axis=-2) for x in zip(*ends, strict=True)))
    # many: pair by pair (stacking copies them all, which costs more than the calls)
    return np.stack([segments_intersect(*x) for x in ends], axis=-1)


def is_valid(design: ArmDesign, q) -> np.ndarray:
    """Joint limits plus the design's collision model, shape (...,) bool.

    Parameters
    ----------
    design : ArmDesign
        ``design.collision_model`` chooses what a collision is: ``"printed"`` (default),
        the envelopes of the printed links, all 15 non-adjacent pairs, with the design's
        clearance (``handarm.collision``); ``"paper"``, the paper's model, no pair in
        ``COLLISION_PAIRS`` crossing or touching as zero-thickness segments in its plane.
    q : array-like, shape (..., 6)
        Joint angles (rad).

    Returns
    -------
    ndarray of bool, shape (...,)

    Raises
    ------
    ValueError
        If ``q`` is not finite or not of shape (..., 6).
    """
    check_design(design)
    q = check_joints(q)
    ok = within_limits(design, q)
    if design.collision_model == "paper":
        return ok & ~np.any(link_crossings(design, q), axis=-1)
    return ok & collision_free(design, q)


def colliding_pairs(design: ArmDesign, q) -> np.ndarray:
    """Which non-adjacent link pairs collide under the design's model, shape (..., 15) bool.

    Columns follow ``handarm.collision.LINK_PAIRS`` ((0, 2), (0, 3), ..., (4, 6)); under the
    paper's model only its six segment pairs can be True.
    """
    check_design(design)
    q = check_joints(q)
    if design.collision_model == "paper":
        out = np.zeros(q.shape[:-1] + (15,), bool)
        crossing = link_crossings(design, q)
        for k, (m, n) in enumerate(COLLISION_PAIRS):
            a, b = sorted((int(m[1]), int(n[1])))
            out[..., LINK_PAIRS.index((a, b))] = crossing[..., k]
        return out
    return printed_collisions(design, q)
