"""A short human-readable summary of a design."""

from __future__ import annotations

import math

import numpy as np

from handarm.design import ArmDesign
from handarm.transmission import coupling_matrix, joint_effort_limits, joint_velocity_limits

__all__ = ["design_summary"]


def design_summary(design: ArmDesign) -> str:
    """Plain-text summary: lengths, limits, reach and the transmission, in mm and degrees."""
    a_mm = np.array(design.link_lengths) * 1e3
    lines = [
        f"handarm design {design.name!r}",
        "",
        "links (mm): " + ", ".join(f"a{k}={v:g}" for k, v in enumerate(a_mm)),
        f"reach from joint 1 (mm): {a_mm[1:].sum():g}; handle stub l0: {a_mm[0]:g}",
        "",
        "joint  lower(deg)  upper(deg)  effort(N m)  speed(deg/s)  servo ID",
    ]
    effort = joint_effort_limits(design)
    speed = np.degrees(joint_velocity_limits(design))
    for k, (lo, hi) in enumerate(design.joint_limits):
        lines.append(
            f"{k + 1:>5}  {math.degrees(lo):>10.2f}  {math.degrees(hi):>10.2f}  "
            f"{effort[k]:>11.2f}  {speed[k]:>12.1f}  {design.servo_ids[k]:>8}"
        )
    lines += [
        "",
        f"servos: {design.servo_model} x6, Protocol 1.0, {design.baud_rate} bit/s",
        "coupling K (motor angles = K q):",
    ]
    for row in coupling_matrix(design):
        lines.append("  " + " ".join(f"{v:6.3f}" for v in row))
    return "\n".join(lines) + "\n"
