"""URDF export of an arm design (the fixed conventions of ``handarm.kinematics``).

Joint k's origin is ``xyz="a_{k-1} 0 0"`` (joint 1 at the origin), joint 4 adds the 90 degree
twist ``rpy="pi/2 0 0"``, every axis is ``0 0 1`` and a fixed tool frame sits at ``xyz="a6 0 0"``.
Angles are written at full double precision: the 8-digit ``1.5707963`` of the design note would
move the tool point by about 4e-9 m.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

from handarm._checks import check_design
from handarm._io import write_text_atomic
from handarm.design import ArmDesign
from handarm.transmission import joint_effort_limits, joint_velocity_limits

__all__ = ["LINK_NAMES", "JOINT_NAMES", "urdf_string", "write_urdf"]

LINK_NAMES = ("base_link", "link1", "link2", "link3", "link4", "link5", "link6")
JOINT_NAMES = tuple(f"joint{k}" for k in range(1, 7))


def _f(x: float) -> str:
    return repr(float(x))


def urdf_string(design: ArmDesign, *, link_extras: Mapping[str, ET.Element] | None = None) -> str:
    """The design as URDF text.

    Parameters
    ----------
    design : ArmDesign
    link_extras : mapping of link name to list of Elements, optional
        Extra children (``visual``, ``collision``, ``inertial``) per link, as the carving adds.
    """
    check_design(design)
    a = design.lengths
    effort = joint_effort_limits(design)
    velocity = joint_velocity_limits(design)
    robot = ET.Element("robot", name=design.name)
    for name in LINK_NAMES + ("tool",):
        link = ET.SubElement(robot, "link", name=name)
        for child in (link_extras or {}).get(name, ()):
            link.append(child)
    for k in range(6):
        joint = ET.SubElement(robot, "joint", name=JOINT_NAMES[k], type="revolute")
        ET.SubElement(joint, "parent", link=LINK_NAMES[k])
        ET.SubElement(joint, "child", link=LINK_NAMES[k + 1])
        x = a[k] if k > 0 else 0.0
        rpy = f"{_f(math.pi / 2)} 0 0" if k == 3 else "0 0 0"
        ET.SubElement(joint, "origin", xyz=f"{_f(x)} 0 0", rpy=rpy)
        ET.SubElement(joint, "axis", xyz="0 0 1")
        lo, hi = design.joint_limits[k]
        ET.SubElement(
            joint,
            "limit",
            lower=_f(lo),
            upper=_f(hi),
            effort=_f(effort[k]),
            velocity=_f(velocity[k]),
        )
    tool = ET.SubElement(robot, "joint", name="tool_joint", type="fixed")
    ET.SubElement(tool, "parent", link=LINK_NAMES[6])
    ET.SubElement(tool, "child", link="tool")
    ET.SubElement(tool, "origin", xyz=f"{_f(a[6])} 0 0", rpy="0 0 0")
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def write_urdf(design: ArmDesign, path: str | os.PathLike[str], **kwargs) -> Path:
    """Write ``urdf_string(design, **kwargs)`` to ``path`` atomically; returns the path."""
    path = Path(path)
    write_text_atomic(path, urdf_string(design, **kwargs))
    return path
