"""Mesh files of carved links: binary STL per link and a 3MF plate, in millimetres.

Each link is written in its print pose: its proximal axle vertical, lying on the bed
(z = 0), centred on the origin. ``print_pose`` gives the transform from the link frame,
so the URDF can place the same file back.
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
from handarm.carve.properties import to_trimesh

__all__ = [
    "print_pose",
    "print_orientation",
    "support_area",
    "write_stl",
    "write_3mf",
    "rpy_from_matrix",
]


#: A face overhangs when it faces down steeper than this from the vertical (degrees).
OVERHANG_DEG = 45.0


#: Least area (mm^2) a print pose must rest on.
MIN_BED_CONTACT = 25.0


def _bed_faces(mesh: trimesh.Trimesh, down: np.ndarray) -> np.ndarray:
    """Faces lying on the bed (the lowest level, facing straight down), bool per face."""
    height = -(mesh.vertices @ down)  # up is -down
    bottom = height.min()
    cos = mesh.face_normals @ down
    return np.all(height[mesh.faces] < bottom + 1e-3, axis=1) & (cos > 0.999)


def support_area(mesh: trimesh.Trimesh, down) -> float:
    """Area (mm^2) facing down steeper than ``OVERHANG_DEG`` when ``down`` points down.

    Faces that lie on the bed (the lowest level, facing straight down) need no support.
    """
    down = np.asarray(down, float) / np.linalg.norm(down)
    cos = mesh.face_normals @ down
    steep = (cos > math.cos(math.radians(OVERHANG_DEG)) + 1e-9) & ~_bed_faces(mesh, down)
    return float(mesh.area_faces[steep].sum())


def _rotation_down(down: np.ndarray) -> np.ndarray:
    """A rotation taking the unit vector ``down`` onto -z."""
    target = np.array([0.0, 0.0, -1.0])
    v = np.cross(down, target)
    c = float(down @ target)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def print_orientation(link: CarvedLink) -> tuple[np.ndarray, float]:
    """The link-frame direction put down on the bed and the support area it leaves (mm^2).

    Candidates are the part's stable resting poses: the facets of its convex hull on which
    it rests with at least ``MIN_BED_CONTACT`` of its own surface. Of these, the one with
    the least area overhanging more than ``OVERHANG_DEG`` (ties: the larger contact).
    """
    mesh = to_trimesh(link.solid)
    hull = mesh.convex_hull
    normals = np.vstack([hull.face_normals, np.asarray(hull.facets_normal).reshape(-1, 3)])
    cands = np.unique(np.round(normals, 6), axis=0)
    best = None
    for down in cands:
        down = down / np.linalg.norm(down)
        contact = float(mesh.area_faces[_bed_faces(mesh, down)].sum())
        if contact < MIN_BED_CONTACT:
            continue
        key = (round(support_area(mesh, down), 6), -contact)
        if best is None or key < best[0]:
            best = (key, down)
    if best is None:  # nothing flat enough to stand on: its largest face down
        down = -mesh.face_normals[int(np.argmax(mesh.area_faces))]
        return -down, support_area(mesh, -down)
    return best[1], best[0][0]


def print_pose(link: CarvedLink) -> np.ndarray:
    """4x4 transform (mm) from the link frame to its pose on the print bed.

    Turned so that ``print_orientation``'s direction points down, lying on the bed (z = 0),
    centred on the origin.
    """
    down, _ = print_orientation(link)
    rot = np.eye(4)
    rot[:3, :3] = _rotation_down(down)
    verts = np.asarray(link.solid.to_mesh().vert_properties)[:, :3] @ rot[:3, :3].T
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    m = np.eye(4)
    m[:3, 3] = [-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]]
    return m @ rot


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


def write_3mf(links, path: str | os.PathLike[str], gap: float = 6.0) -> Path:
    """One 3MF plate with every link in its print pose, in rows (mm), written atomically."""
    scene = trimesh.Scene()
    x = y = row_depth = 0.0
    width = 220.0  # a common bed
    for link in links:
        mesh = to_trimesh(link.solid)
        mesh.apply_transform(print_pose(link))
        size = mesh.bounds[1] - mesh.bounds[0]
        if x > 0 and x + size[0] > width:
            x, y, row_depth = 0.0, y + row_depth + gap, 0.0
        mesh.apply_translation([x - mesh.bounds[0, 0], y - mesh.bounds[0, 1], 0.0])
        scene.add_geometry(mesh, node_name=link.name, geom_name=link.name)
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
