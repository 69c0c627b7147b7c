"""How a solid prints: the poses it can rest in and the area that then needs support.

A face needs support when it faces down steeper than ``OVERHANG_DEG`` from the vertical,
unless it lies on the bed. A solid rests on a facet of its convex hull that it touches with
at least ``MIN_BED_CONTACT`` of its own surface; ``print_orientation`` picks the one that
leaves the least area to support.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from manifold3d import Manifold

from handarm.carve.properties import to_trimesh

__all__ = [
    "OVERHANG_DEG",
    "MIN_BED_CONTACT",
    "bed_faces",
    "support_area",
    "print_orientation",
    "rotation_down",
    "pose_on_bed",
]

#: A face overhangs when it faces down steeper than this from the vertical (degrees).
OVERHANG_DEG = 45.0

#: Degrees a face must lean past ``OVERHANG_DEG`` to count: a face cut at exactly 45
#: degrees (where a neighbour's sweep ends at +-135) leans a few micro-degrees either way
#: once its mesh is rounded, and prints the same either way.
_OVERHANG_TOL_DEG = 0.01

#: Least area (mm^2) a print pose must rest on.
MIN_BED_CONTACT = 25.0

#: Faces this close (mm) to the lowest point lie on the bed.
BED_TOLERANCE = 1e-3


def bed_faces(mesh: trimesh.Trimesh, down) -> np.ndarray:
    """Faces lying on the bed (the lowest level, facing straight down), bool per face."""
    down = np.asarray(down, float) / np.linalg.norm(down)
    height = -(mesh.vertices @ down)  # up is -down
    bottom = height.min()
    cos = mesh.face_normals @ down
    return np.all(height[mesh.faces] < bottom + BED_TOLERANCE, axis=1) & (cos > 0.999)


def support_area(mesh: trimesh.Trimesh, down) -> float:
    """Area (mm^2) facing down steeper than ``OVERHANG_DEG`` when ``down`` points down.

    Faces that lie on the bed (the lowest level, facing straight down) need no support.
    """
    down = np.asarray(down, float) / np.linalg.norm(down)
    cos = mesh.face_normals @ down
    # the face's normal lies within 90 - OVERHANG_DEG - tol degrees of down
    steep = (cos > math.sin(math.radians(OVERHANG_DEG + _OVERHANG_TOL_DEG))) & ~bed_faces(
        mesh, down
    )
    return float(mesh.area_faces[steep].sum())


def print_orientation(solid: Manifold) -> tuple[np.ndarray, float]:
    """The direction (unit, the solid's frame) put down on the bed and the support it leaves.

    Candidates are the solid's stable resting poses: the facets of its convex hull on which
    it rests with at least ``MIN_BED_CONTACT`` of its own surface. Of these, the one with
    the least area (mm^2) overhanging more than ``OVERHANG_DEG`` (ties: the larger contact).
    """
    mesh = to_trimesh(solid)
    hull = mesh.convex_hull
    normals = np.vstack([hull.face_normals, np.asarray(hull.facets_normal).reshape(-1, 3)])
    cands = np.unique(np.round(normals, 6), axis=0)
    best = None
    for down in cands:
        down = down / np.linalg.norm(down)
        contact = float(mesh.area_faces[bed_faces(mesh, down)].sum())
        if contact < MIN_BED_CONTACT:
            continue
        key = (round(support_area(mesh, down), 6), -contact)
        if best is None or key < best[0]:
            best = (key, down)
    if best is None:  # nothing flat enough to stand on: its largest face down
        down = -mesh.face_normals[int(np.argmax(mesh.area_faces))]
        return -down, support_area(mesh, -down)
    return best[1], best[0][0]


def rotation_down(down) -> np.ndarray:
    """A rotation (3x3) taking the unit vector ``down`` onto -z."""
    down = np.asarray(down, float)
    target = np.array([0.0, 0.0, -1.0])
    v = np.cross(down, target)
    c = float(down @ target)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def pose_on_bed(solid: Manifold, down) -> np.ndarray:
    """4x4 transform (mm) from the solid's frame to its pose on the bed.

    Turned so that ``down`` points down, lying on the bed (z = 0), centred on the origin.
    """
    rot = np.eye(4)
    rot[:3, :3] = rotation_down(down)
    verts = np.asarray(solid.to_mesh().vert_properties)[:, :3] @ rot[:3, :3].T
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    m = np.eye(4)
    m[:3, 3] = [-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]]
    return m @ rot
