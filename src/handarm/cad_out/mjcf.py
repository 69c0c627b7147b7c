"""MJCF (MuJoCo) model of the carved arm: fixed base, limits, tendon-coupled actuators.

The chain is the one of ``handarm.kinematics`` (bodies ``l0`` .. ``l6``, hinge ``joint1`` ..
``joint6`` about each body's z axis). ``l0`` (the handle stub) is fixed to the world.

* **Inertia**: each body's mass, centre of mass and inertia come from its carved mesh (the
  same numbers as ``links/*.json`` and the URDF).
* **Collision**: every piece of ``handarm.collision.envelopes`` (a slab stadium: a segment in
  the joint plane grown by a radius, times a range along the axle) becomes one box and two
  cylinders, which make up exactly that stadium slab. The envelopes contain the carved
  meshes. Each geom has the design's clearance as its contact margin, so MuJoCo reports a
  contact where two envelopes come within the clearance, as ``is_valid`` does. Contacts
  between adjacent links (which the joint limits govern) are excluded.
* **Visual**: the carved STL meshes (``meshes/*.stl``, print pose, mm) placed back in their
  link frames; they take no part in contacts.
* **Actuation**: six fixed tendons ``cable1`` .. ``cable6`` of length ``phi = K q`` (the
  coupling matrix of ``handarm.transmission``), each driven by a position actuator with the
  servo's stall torque as force limit. The actuators' joint torques are ``K^T tau``, as in
  the transmission model.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from handarm._io import write_text_atomic
from handarm.cad_out.meshes import print_pose
from handarm.carve.carving import CarveResult
from handarm.collision import envelopes
from handarm.links import MM
from handarm.transmission import coupling_matrix, motor_ranges

__all__ = ["mjcf_string", "write_mjcf", "BODY_NAMES", "JOINT_NAMES"]

BODY_NAMES = tuple(f"l{k}" for k in range(7))
JOINT_NAMES = tuple(f"joint{k}" for k in range(1, 7))

#: Proportional gain of the position actuators: stall torque at this error (rad).
SERVO_STIFF_ANGLE = math.radians(10.0)


def _f(x: float) -> str:
    return repr(float(x))


def _v(values) -> str:
    return " ".join(_f(v) for v in values)


def _quat(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + r[0, 0] - r[1, 1] - r[2, 2])) / 2, r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] + r[1, 1] - r[2, 2])) / 2, r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] - r[1, 1] + r[2, 2])) / 2, r[1, 0] - r[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def _piece_frame(result: CarveResult, piece) -> np.ndarray:
    """Transform (m) from a piece's frame to its link's body frame."""
    blank = result.links[piece.link].blank
    if piece.frame == 0 or blank.dist_from_prox is None:
        return np.eye(4)
    m = np.array(blank.dist_from_prox, dtype=float)
    m[:3, 3] /= MM
    return m


def _collision_geoms(body: ET.Element, result: CarveResult, k: int, margin: float) -> None:
    """One box and two cylinders per envelope piece of link k (the stadium slab exactly)."""
    env = envelopes(result.design)
    n = 0
    for piece in env.pieces:
        if piece.link != k:
            continue
        frame = _piece_frame(result, piece)
        p0, p1 = piece.segment
        z0, z1 = piece.z
        half_h = (z1 - z0) / 2
        zc = (z0 + z1) / 2
        length = float(np.linalg.norm(p1 - p0))
        angle = math.atan2(p1[1] - p0[1], p1[0] - p0[0]) if length > 0 else 0.0
        c, s = math.cos(angle), math.sin(angle)
        local = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)
        shapes = []
        mid = (p0 + p1) / 2
        if length > 1e-9:
            shapes.append(("box", mid, _v((length / 2, piece.radius, half_h))))
            ends = (p0, p1)
        else:
            ends = (mid,)
        shapes += [("cylinder", e, _v((piece.radius, half_h))) for e in ends]
        for kind, centre, size in shapes:
            m = local.copy()
            m[:3, 3] = (centre[0], centre[1], zc)
            m = frame @ m
            ET.SubElement(
                body,
                "geom",
                name=f"{BODY_NAMES[k]}_env{n}",
                type=kind,
                size=size,
                pos=_v(m[:3, 3]),
                quat=_v(_quat(m[:3, :3])),
                margin=_f(margin),
                gap="0",
                group="3",
                rgba="0.8 0.3 0.3 0.25",
            )
            n += 1


def mjcf_string(
    result: CarveResult,
    properties: Sequence[dict],
    *,
    mesh_dir: str = "meshes",
    visual_meshes: bool = True,
) -> str:
    """The MJCF text of the carved arm.

    Parameters
    ----------
    result : handarm.carve.CarveResult
        The carved links; their joint reports give the achieved limits.
    properties : sequence of 7 dict
        ``handarm.carve.properties.link_properties`` of l0..l6 (mass, centre of mass,
        inertia in the link frame, SI).
    mesh_dir : str
        Folder of the link STLs, relative to the MJCF file.
    visual_meshes : bool
        Include the carved meshes as visual geoms (they need the STL files beside the model).

    Returns
    -------
    str
        MJCF XML. Joint limits are the design's, narrowed to what carving achieved.
    """
    design = result.as_built  # joint limits the printed parts allow
    a = design.lengths
    k_mat = coupling_matrix(design)
    ranges = motor_ranges(design)
    stall = design.servo.stall_torque
    root = ET.Element("mujoco", model=design.name)
    ET.SubElement(
        root,
        "compiler",
        angle="radian",
        inertiafromgeom="false",
        meshdir=mesh_dir,
        autolimits="true",
    )
    ET.SubElement(root, "option", timestep="0.0005", integrator="implicitfast", gravity="0 0 -9.81")
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "joint", damping="0.01", armature="1e-5")
    if visual_meshes:
        asset = ET.SubElement(root, "asset")
        for link in result.links:
            ET.SubElement(
                asset,
                "mesh",
                name=f"{link.name}_mesh",
                file=f"{link.name}.stl",
                scale="0.001 0.001 0.001",
            )
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos="0 0 1", dir="0 0 -1")
    parent = world
    twist = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float)
    for k, link in enumerate(result.links):
        attrs = {"name": BODY_NAMES[k]}
        if k > 0:
            attrs["pos"] = _v((a[k - 1] if k > 1 else 0.0, 0.0, 0.0))
            if k == 4:
                attrs["quat"] = _v(_quat(twist))
        body = ET.SubElement(parent, "body", **attrs)
        props = properties[k]
        i = np.asarray(props["inertia_kg_m2"])
        ET.SubElement(
            body,
            "inertial",
            pos=_v(props["center_of_mass_m"]),
            mass=_f(props["mass_kg"]),
            fullinertia=_v((i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2])),
        )
        if k > 0:
            lo, hi = design.joint_limits[k - 1]
            alo, ahi = result.joints[k - 1].achieved
            ET.SubElement(
                body,
                "joint",
                name=JOINT_NAMES[k - 1],
                type="hinge",
                axis="0 0 1",
                range=_v((max(lo, alo), min(hi, ahi))),
            )
        if visual_meshes:
            back = np.linalg.inv(print_pose(link))
            ET.SubElement(
                body,
                "geom",
                type="mesh",
                mesh=f"{link.name}_mesh",
                pos=_v(back[:3, 3] * 1e-3),
                quat=_v(_quat(back[:3, :3])),
                contype="0",
                conaffinity="0",
                group="1",
                mass="0",
            )
        _collision_geoms(body, result, k, design.clearance)
        parent = body
    contact = ET.SubElement(root, "contact")
    for k in range(6):
        ET.SubElement(contact, "exclude", body1=BODY_NAMES[k], body2=BODY_NAMES[k + 1])
    tendon = ET.SubElement(root, "tendon")
    for m in range(6):
        fixed = ET.SubElement(tendon, "fixed", name=f"cable{m + 1}")
        for j in range(m + 1):
            if k_mat[m, j] != 0.0:
                ET.SubElement(fixed, "joint", joint=JOINT_NAMES[j], coef=_f(k_mat[m, j]))
    actuator = ET.SubElement(root, "actuator")
    for m in range(6):
        ET.SubElement(
            actuator,
            "position",
            name=f"motor{m + 1}",
            tendon=f"cable{m + 1}",
            kp=_f(stall / SERVO_STIFF_ANGLE),
            ctrlrange=_v((ranges[m].lo, ranges[m].hi)),
            forcerange=_v((-stall, stall)),
        )
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def write_mjcf(
    result: CarveResult, properties: Sequence[dict], path: str | os.PathLike[str], **kwargs
) -> Path:
    """Write ``mjcf_string(result, properties, **kwargs)`` to ``path`` atomically."""
    path = Path(path)
    write_text_atomic(path, mjcf_string(result, properties, **kwargs))
    return path
