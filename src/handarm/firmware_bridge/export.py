"""Controller configuration for the servo bus: JSON and a C header.

No ros2_control fragment is written: ROBOTIS ``dynamixel_hardware_interface`` speaks only
Protocol 2.0 and ships no table for model 310 (the MX-64 Protocol 1.0 firmware handarm
drives), so a fragment could not load, let alone drive this arm (issue 12).

``controller_config`` gathers everything a controller needs: per servo its ID, joint, model,
protocol, baud, mode (joint or multi-turn), angle-limit and torque registers; the coupling
matrix K and its inverse; joint limits (the carving's achieved limits intersected with the
design's, when given); link lengths; calibration offsets.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from handarm._io import write_text_atomic
from handarm.design import ArmDesign
from handarm.firmware_bridge.calibration import Calibration
from handarm.firmware_bridge.mx64 import baud_register
from handarm.transmission import (
    coupling_matrix,
    joint_effort_limits,
    motor_ranges,
)

__all__ = [
    "SCHEMA",
    "controller_config",
    "write_controller_json",
    "write_header",
    "angle_limit_registers",
]

SCHEMA = "handarm.controller/1"


def angle_limit_registers(design: ArmDesign, offsets=None, lower=None, upper=None):
    """(mode, CW, CCW) per motor: joint-mode limits around the travel, or 4095/4095.

    Without ``offsets`` the joint-mode window is centred on tick 2048: ``assembly_ticks``
    says where to put each horn before tensioning so that it is.
    """
    servo = design.servo
    tpr, mid = servo.ticks_per_radian, servo.ticks_per_rev // 2
    out = []
    for r, m in zip(motor_ranges(design, lower, upper), range(6), strict=True):
        if r.mode == "multi-turn":
            out.append(("multi-turn", 4095, 4095))
            continue
        zero = mid - (r.lo + r.hi) / 2 * tpr if offsets is None else offsets[m]
        cw = math.floor(zero + r.lo * tpr)
        ccw = math.ceil(zero + r.hi * tpr)
        if cw < 0 or ccw > servo.joint_mode_max:
            raise ValueError(
                f"calibration: motor {m + 1}'s zero reading {zero:.0f} leaves its travel "
                f"({cw}..{ccw}) outside joint mode's 0..{servo.joint_mode_max}; re-seat the "
                f"horn at {mid - (r.lo + r.hi) / 2 * tpr:.0f} ticks at the zero pose"
            )
        out.append(("joint", cw, ccw))
    return out


def controller_config(
    design: ArmDesign,
    calibration: Calibration | None = None,
    achieved_limits=None,
    *,
    max_torque_fraction: float = 1.0,
) -> dict:
    """The controller configuration as a JSON-ready dict (schema ``handarm.controller/1``).

    Parameters
    ----------
    design : ArmDesign
    calibration : Calibration, optional
        Zero-pose encoder offsets; checked against the design.
    achieved_limits : sequence of 6 (lo, hi), optional
        Limits the carved links allow (rad); the exported limits are their intersection
        with the design's.
    max_torque_fraction : float
        Max Torque register as a fraction of the servo's maximum (0 < f <= 1).
    """
    least = 1.0 / design.servo.max_torque_register  # Max Torque 1: the least not limp
    if not least <= max_torque_fraction <= 1.0:
        raise ValueError(
            f"max_torque_fraction: expected {least:.2g} <= f <= 1 (Max Torque "
            f"{design.servo.max_torque_register} x f must round to 1 or more, or the servo is "
            f"limp), got {max_torque_fraction}"
        )
    if achieved_limits is not None:
        ach = np.asarray(achieved_limits, dtype=float)
        if ach.shape != (6, 2):
            raise ValueError(f"achieved_limits: expected 6 (lo, hi) pairs, got shape {ach.shape}")
        design = design.limited_to(ach)
    lower, upper = np.array(design.lower), np.array(design.upper)
    offsets = None
    if calibration is not None:
        calibration.check_matches(design)
        offsets = list(calibration.offsets)
    k = coupling_matrix(design)
    ranges = motor_ranges(design, lower, upper)
    registers = angle_limit_registers(design, offsets, lower, upper)
    effort = joint_effort_limits(design)
    servos = []
    for m in range(6):
        mode, cw, ccw = registers[m]
        r = ranges[m]
        servos.append(
            {
                "id": design.servo_ids[m],
                "joint": m + 1,
                "model": design.servo_model,
                "model_number": design.servo.model_number,
                "protocol": 1.0,
                "baud_rate": design.baud_rate,
                "baud_register": baud_register(design.baud_rate),
                "mode": mode,
                "cw_angle_limit": cw,
                "ccw_angle_limit": ccw,
                "max_torque": round(design.servo.max_torque_register * max_torque_fraction),
                "travel_rad": [r.lo, r.hi],
                "assembly_ticks": round(
                    design.servo.ticks_per_rev // 2 - (r.lo + r.hi) / 2 * r.ticks_per_radian
                ),
            }
        )
    return {
        "schema": SCHEMA,
        "design": design.name,
        "ticks_per_rad": design.servo.ticks_per_radian,
        "servos": servos,
        "coupling": {
            "K": k.tolist(),
            "K_inv": np.linalg.inv(k).tolist(),
            "note": "motor angles = K @ joint angles; joint torques = K.T @ motor torques",
        },
        "joint_limits_rad": [[float(a), float(b)] for a, b in zip(lower, upper, strict=True)],
        "joint_effort_limits_Nm": effort.tolist(),
        "link_lengths_m": list(design.link_lengths),
        "calibration": None
        if calibration is None
        else {
            "offsets_ticks": offsets,
            "recorded_at": calibration.recorded_at,
        },
    }


def write_controller_json(config: dict, path: str | os.PathLike[str]) -> Path:
    """Write controller.json atomically."""
    path = Path(path)
    write_text_atomic(path, json.dumps(config, indent=2) + "\n")
    return path


def c_comment(text: str) -> str:
    """``text`` made safe inside a C block comment: printable ASCII, no comment delimiters."""
    out = "".join(c if " " <= c <= "~" else "?" for c in str(text))
    while "*/" in out or "/*" in out:
        out = out.replace("*/", "* /").replace("/*", "/ *")
    return json.dumps(out)


def _c_array(values, fmt) -> str:
    return "{" + ", ".join(fmt(v) for v in values) + "}"


def header_text(config: dict) -> str:
    """arm_config.h: the same content as const arrays for the controller firmware."""
    servos = config["servos"]
    k, kinv = np.array(config["coupling"]["K"]), np.array(config["coupling"]["K_inv"])
    f = lambda v: repr(float(v))  # noqa: E731
    i = lambda v: str(int(v))  # noqa: E731
    lim = np.array(config["joint_limits_rad"])
    cal = config["calibration"]
    offsets = cal["offsets_ticks"] if cal else [s["assembly_ticks"] for s in servos]
    rows = lambda m: "{\n    " + ",\n    ".join(_c_array(r, f) for r in m) + "\n}"  # noqa: E731
    lines = [
        "/* Generated by handarm from design " + c_comment(config["design"]) + ". Do not edit. */",
        f"/* schema {config['schema']} */",
        "#ifndef HANDARM_ARM_CONFIG_H",
        "#define HANDARM_ARM_CONFIG_H",
        "",
        "#include <stdint.h>",
        "",
        "#define HANDARM_N_JOINTS 6",
        f"#define HANDARM_BAUD_RATE {servos[0]['baud_rate']}L",
        f"#define HANDARM_MODEL_NUMBER {servos[0]['model_number']}",
        f"#define HANDARM_TICKS_PER_RAD {f(config['ticks_per_rad'])}",
        f"#define HANDARM_CALIBRATED {1 if cal else 0}",
        "",
        "static const uint8_t HANDARM_SERVO_ID[6] = "
        + _c_array([s["id"] for s in servos], i)
        + ";",
        "/* 1 = multi-turn mode (CW = CCW = 4095), 0 = joint mode */",
        "static const uint8_t HANDARM_MULTI_TURN[6] = "
        + _c_array([s["mode"] == "multi-turn" for s in servos], i)
        + ";",
        "static const uint16_t HANDARM_CW_ANGLE_LIMIT[6] = "
        + _c_array([s["cw_angle_limit"] for s in servos], i)
        + ";",
        "static const uint16_t HANDARM_CCW_ANGLE_LIMIT[6] = "
        + _c_array([s["ccw_angle_limit"] for s in servos], i)
        + ";",
        "static const uint16_t HANDARM_MAX_TORQUE[6] = "
        + _c_array([s["max_torque"] for s in servos], i)
        + ";",
        "/* encoder ticks at the zero pose (calibration, else the assembly targets) */",
        "static const int32_t HANDARM_ZERO_TICKS[6] = " + _c_array(offsets, i) + ";",
        "/* motor angles = K * joint angles; joint angles = K_INV * motor angles */",
        "static const double HANDARM_K[6][6] = " + rows(k) + ";",
        "static const double HANDARM_K_INV[6][6] = " + rows(kinv) + ";",
        "static const double HANDARM_JOINT_LOWER_RAD[6] = " + _c_array(lim[:, 0], f) + ";",
        "static const double HANDARM_JOINT_UPPER_RAD[6] = " + _c_array(lim[:, 1], f) + ";",
        "static const double HANDARM_LINK_LENGTH_M[7] = "
        + _c_array(config["link_lengths_m"], f)
        + ";",
        "",
        "#endif /* HANDARM_ARM_CONFIG_H */",
    ]
    return "\n".join(lines) + "\n"


def write_header(config: dict, path: str | os.PathLike[str]) -> Path:
    """Write arm_config.h atomically."""
    path = Path(path)
    write_text_atomic(path, header_text(config))
    return path
