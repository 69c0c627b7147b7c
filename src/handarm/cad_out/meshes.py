"""Mesh files of carved links: binary STL per link and per printed part, a 3MF plate, in mm.

Each link is written whole in the pose it would print in alone (``print_pose``: lying on
the bed, z = 0, centred on the origin), so the URDF can place the same file back. What is
printed are the links' parts (``handarm.carve.split``), each in its own print pose: one STL
per part and all of them on the 3MF plate.
"""

from __future__ import annotations

import io
import math
import os
from pathlib import Path

import numpy as np
import trimesh

from handarm._io import write_bytes_atomic
from handarm.carve.carving import CarvedLink
from handarm.carve.printing import OVERHANG_DEG, pose_on_bed, support_area
from handarm.carve.properties import to_trimesh

__all__ = [
    "print_pose",
    "print_orientation",
    "support_area",
    "OVERHANG_DEG",
    "write_stl",
    "write_part_stl",
    "write_3mf",
    "rpy_from_matrix",
]


def print_orientation(link: CarvedLink) -> tuple[np.ndarray, float]:
    """The link-frame direction put down on the bed and the support area it leaves (mm^2).

    See ``handarm.carve.printing.print_orientation``; found once per link
    (``CarvedLink.print_orientation``).
    """
    return link.print_orientation


def print_pose(link: CarvedLink) -> np.ndarray:
    """4x4 transform (mm) from the link frame to its pose on the print bed.

    Turned so that ``print_orientation``'s direction points down, lying on the bed (z = 0),
    centred on the origin.
    """
    down, _ = link.print_orientation
    return pose_on_bed(link.solid, down)


def _mesh_bytes(mesh: trimesh.Trimesh, file_type: str) -> bytes:
    data = mesh.export(file_type=file_type)
    return data if isinstance(data, bytes) else data.encode()


def write_stl(link: CarvedLink, path: str | os.PathLike[str]) -> Path:
    """Binary STL of the link in its print pose (mm), written atomically."""
    mesh = to_trimesh(link.solid)
    mesh.apply_transform(print_pose(link))
    path = Path(path)
    write_bytes_atomic(path, _mesh_bytes(mesh, "stl"))
    return path


def write_part_stl(part, path: str | os.PathLike[str]) -> Path:
    """Binary STL of a printed part (``handarm.carve.split.PrintedPart``) in its print pose."""
    mesh = to_trimesh(part.solid)
    mesh.apply_transform(part.pose)
    path = Path(path)
    write_bytes_atomic(path, _mesh_bytes(mesh, "stl"))
    return path


def write_3mf(parts, path: str | os.PathLike[str], gap: float = 6.0) -> Path:
    """One 3MF plate with every printed part in its print pose, in rows (mm), atomically.

    ``parts`` are ``handarm.carve.split.PrintedPart`` (a name, a solid and a pose each).
    """
    scene = trimesh.Scene()
    x = y = row_depth = 0.0
    width = 220.0  # a common bed
    for part in parts:
        mesh = to_trimesh(part.solid)
        mesh.apply_transform(part.pose)
        size = mesh.bounds[1] - mesh.bounds[0]
        if x > 0 and x + size[0] > width:
            x, y, row_depth = 0.0, y + row_depth + gap, 0.0
        mesh.apply_translation([x - mesh.bounds[0, 0], y - mesh.bounds[0, 1], 0.0])
        scene.add_geometry(mesh, node_name=part.name, geom_name=part.name)
        x += size[0] + gap
        row_depth = max(row_depth, size[1])
    buf = io.BytesIO()
    scene.export(buf, file_type="3mf")
    path = Path(path)
    write_bytes_atomic(path, buf.getvalue())
    return path


def rpy_from_matrix(r: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)) of a rotation matrix."""
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(r[2, 0]) < 1.0 - 1e-12:
        roll = math.atan2(r[2, 1], r[2, 2])
        yaw = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: put everything in yaw
        roll = 0.0
        yaw = math.atan2(-r[0, 1], r[1, 1])
    return roll, pitch, yaw
