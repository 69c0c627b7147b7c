"""Coupled-tendon transmission: joint <-> motor angles, velocities and torques.

Motor k drives joint k through one closed cable loop that also wraps an idler on every
joint j < k. With motor pulley radius rho, joint pulley radii r_j and wrap signs s_kj::

    rho * phi_k = sum_{j <= k} s_kj * r_j * q_j        i.e.  phi = K q,  K lower-triangular

and virtual work gives tau_joint = K^T tau_motor.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.linalg import solve_triangular

from handarm._checks import check_array, check_design
from handarm.design import ArmDesign

__all__ = [
    "MotorRange",
    "motor_ranges",
    "ticks_from_motor",
    "motor_from_ticks",
    "coupling_matrix",
    "motor_from_joint",
    "joint_from_motor",
    "joint_torque_from_motor",
    "motor_torque_from_joint",
    "joint_effort_limits",
    "joint_velocity_limits",
]


def coupling_matrix(design: ArmDesign) -> np.ndarray:
    """K, shape (6, 6), lower-triangular: motor angles = K @ joint angles."""
    check_design(design)
    signs = np.array(design.routing_signs, dtype=float)
    radii = np.array(design.joint_pulley_radii)
    return signs * radii[None, :] / design.motor_pulley_radius


def motor_from_joint(design: ArmDesign, q) -> np.ndarray:
    """Motor angles (or velocities) from joint ones, shape (..., 6)."""
    q = check_array(q, "q", 6)
    return q @ coupling_matrix(design).T


def joint_from_motor(design: ArmDesign, phi) -> np.ndarray:
    """Joint angles (or velocities) from motor ones by forward substitution, shape (..., 6)."""
    phi = check_array(phi, "phi", 6)
    k = coupling_matrix(design)
    flat = phi.reshape(-1, 6).T
    return solve_triangular(k, flat, lower=True).T.reshape(phi.shape)


def joint_torque_from_motor(design: ArmDesign, tau_motor) -> np.ndarray:
    """Joint torques from motor torques, tau_joint = K^T tau_motor, shape (..., 6)."""
    tau_motor = check_array(tau_motor, "tau_motor", 6)
    return tau_motor @ coupling_matrix(design)


def motor_torque_from_joint(design: ArmDesign, tau_joint) -> np.ndarray:
    """Motor torques that hold given joint torques (K^T is upper-triangular), shape (..., 6)."""
    tau_joint = check_array(tau_joint, "tau_joint", 6)
    k = coupling_matrix(design)
    flat = tau_joint.reshape(-1, 6).T
    return solve_triangular(k.T, flat, lower=False).T.reshape(tau_joint.shape)


def joint_effort_limits(design: ArmDesign, stall_torque: float | None = None) -> np.ndarray:
    """Largest torque each joint can see with all motors at stall, shape (6,), N m.

    Joint j is driven by every cable that wraps it: sum_k |K_kj| * stall. ``stall_torque``
    defaults to the design's servo specification.
    """
    stall = design.servo.stall_torque if stall_torque is None else stall_torque
    return np.abs(coupling_matrix(design)).sum(axis=0) * stall


def joint_velocity_limits(design: ArmDesign, motor_speed: float | None = None) -> np.ndarray:
    """Fastest each joint can turn alone, every motor within its speed, shape (6,), rad/s.

    Turning joint j alone moves motor k at K_kj * qdot_j, so qdot_j <= speed / max_k |K_kj|.
    ``motor_speed`` defaults to the no-load speed of the design's servo.
    """
    speed = design.servo.no_load_speed if motor_speed is None else motor_speed
    return speed / np.abs(coupling_matrix(design)).max(axis=0)


@dataclasses.dataclass(frozen=True)
class MotorRange:
    """The angles motor k travels over the joint-limit box and the servo mode that covers it.

    ``lo``/``hi`` are motor angles (rad) relative to the zero pose; ``mode`` is "joint" when
    the travel fits in one turn (0..4095 ticks) and "multi-turn" otherwise.
    """

    motor: int
    lo: float
    hi: float
    mode: str
    ticks_per_radian: float

    @property
    def travel_ticks(self) -> float:
        """Travel in encoder ticks."""
        return (self.hi - self.lo) * self.ticks_per_radian


def motor_ranges(design: ArmDesign, lower=None, upper=None) -> list[MotorRange]:
    """Travel of each motor over the joint-limit box (the design's, or ``lower``/``upper``).

    phi = K q is linear, so over a box each motor's extremes are at the box's corners:
    sum over j of min/max of K_kj * (lo_j, hi_j).

    Raises
    ------
    ValueError
        If a motor would need more than the servo's multi-turn range (MX-64: +-28672
        ticks), allowing for the up to one turn the zero pose may sit at after power-on.
    """
    k = coupling_matrix(design)
    lo = design.lower if lower is None else np.asarray(lower, float)
    hi = design.upper if upper is None else np.asarray(upper, float)
    a, b = k * lo[None, :], k * hi[None, :]
    mins, maxs = np.minimum(a, b).sum(axis=1), np.maximum(a, b).sum(axis=1)
    servo = design.servo
    tpr = servo.ticks_per_radian
    out = []
    for m in range(6):
        span = (maxs[m] - mins[m]) * tpr
        reach = max(abs(mins[m]), abs(maxs[m])) * tpr
        if span <= servo.joint_mode_max:
            mode = "joint"
        elif reach + servo.ticks_per_rev <= servo.multi_turn_limit:
            mode = "multi-turn"
        else:
            raise ValueError(
                f"joint_limits: motor {m + 1} would turn {math.degrees(maxs[m] - mins[m]):.0f} "
                f"degrees ({reach:.0f} ticks from the zero pose); the {servo.name} multi-turn "
                f"mode reaches +-{servo.multi_turn_limit - servo.ticks_per_rev} ticks beyond "
                "its power-on turn. Use "
                "larger motor pulleys, smaller joint pulleys or smaller limits"
            )
        out.append(MotorRange(m + 1, float(mins[m]), float(maxs[m]), mode, tpr))
    return out


def ticks_from_motor(design: ArmDesign, phi, offsets) -> np.ndarray:
    """Raw encoder ticks (rounded) from motor angles (rad) and zero-pose offsets (ticks)."""
    phi = check_array(phi, "phi", 6)
    tpr = design.servo.ticks_per_radian
    return np.rint(np.asarray(offsets, float) + phi * tpr).astype(np.int64)


def motor_from_ticks(design: ArmDesign, ticks, offsets) -> np.ndarray:
    """Motor angles (rad) from raw encoder ticks and zero-pose offsets (ticks)."""
    ticks = check_array(ticks, "ticks", 6)
    return (ticks - np.asarray(offsets, float)) / design.servo.ticks_per_radian
