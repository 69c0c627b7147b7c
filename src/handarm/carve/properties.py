"""Mass properties and strength of carved links (from their meshes).

Volumes, masses, centres of mass and inertia come from trimesh on the carved manifold
(millimetres in, SI out); the minimum cross-section along a link is a strength proxy.
"""

from __future__ import annotations

import numpy as np
import trimesh
from manifold3d import Manifold

from handarm.carve.carving import CarvedLink
from handarm.links import WALL_ANGLE_DEG

__all__ = ["to_trimesh", "link_properties", "min_cross_section", "wall_samples", "wall_thickness"]


def to_trimesh(solid: Manifold) -> trimesh.Trimesh:
    """The manifold as a trimesh (same units)."""
    mesh = solid.to_mesh()
    return trimesh.Trimesh(
        vertices=np.asarray(mesh.vert_properties)[:, :3],
        faces=np.asarray(mesh.tri_verts),
        process=False,  # merging near-duplicate vertices would break the manifold
    )


def min_cross_section(solid: Manifold, x0: float, x1: float, samples: int = 80) -> float:
    """Smallest area (mm^2) of the sections perpendicular to x between x0 and x1."""
    # turn x into z so that Manifold.slice cuts across the link
    turned = solid.transform([[0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]])
    areas = [turned.slice(float(x)).area() for x in np.linspace(x0, x1, samples)]
    return float(min(areas))


def link_properties(link: CarvedLink, density: float) -> dict:
    """Volume, mass, centre of mass, inertia (link frame, SI), bounding box, strength proxy."""
    mesh = to_trimesh(link.solid)
    mm3 = 1e-9
    volume = float(mesh.volume) * mm3
    mass = volume * density
    com = np.asarray(mesh.center_mass) * 1e-3
    # trimesh's moment_inertia is about the centre of mass for unit density (mm^5)
    inertia = np.asarray(mesh.moment_inertia) * density * 1e-15
    lo, hi = np.asarray(link.solid.bounding_box()).reshape(2, 3) * 1e-3
    k, a = link.index, link.blank.length
    span = (-a, 0.0) if k == 0 else (0.0, a)
    area = min_cross_section(link.solid, span[0] + 1.0, span[1] - 1.0)
    return {
        "link": link.name,
        "volume_m3": volume,
        "mass_kg": mass,
        "density_kg_m3": density,
        "center_of_mass_m": com.tolist(),
        "inertia_kg_m2": inertia.tolist(),
        "bounding_box_m": [lo.tolist(), hi.tolist()],
        "min_cross_section_m2": area * 1e-6,
        "watertight": bool(mesh.is_volume),
        "bodies": len(link.solid.decompose()),
    }


def wall_samples(
    solid: Manifold, spacing: float = 0.5, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Points on the surface of a solid and the wall (mm) behind each: (n, 3), (n,).

    Points spread over the surface (about one per ``spacing`` mm squared, plus every face's
    centre) each cast a ray inwards along the surface normal; the distance to where it
    leaves the solid is the wall there, kept when the exit face is within
    ``WALL_ANGLE_DEG`` of parallel to the start face: a plate, a rib or a knife edge sharper
    than that, not the corner of a block (whose faces meet at 90 degrees). Features under
    ``WALL_FEATURE`` (a step a cut leaves where it grazes a face) are merged first: they
    are no wall.
    """
    mesh = _measured(solid)
    rng = np.random.default_rng(seed)
    pts, faces = trimesh.sample.sample_surface(mesh, _random_rays(mesh, spacing), seed=rng)
    centres = mesh.triangles_center
    pts = np.concatenate([pts, centres])
    faces = np.concatenate([faces, np.arange(len(mesh.faces))])
    normals = mesh.face_normals[faces]
    origins = pts - normals * 1e-4
    locs, rays, tris = mesh.ray.intersects_location(origins, -normals, multiple_hits=False)
    if len(rays) == 0:
        return np.zeros((0, 3)), np.zeros(0)
    dist = np.linalg.norm(locs - pts[rays], axis=1)
    # opposite faces only: the exit face must face away from the ray's start face
    cos = np.einsum("ij,ij->i", mesh.face_normals[tris], normals[rays])
    facing = cos < -np.cos(np.radians(WALL_ANGLE_DEG))
    return pts[rays[facing]], dist[facing]


#: mm: steps smaller than this are merged before walls are measured. Carving grows its cuts
#: by a hair (0.2 um) over the clearance, so a neighbour's face that lies exactly at the
#: clearance leaves a step that high where its sweep ends; it prints as nothing.
WALL_FEATURE = 1e-3


def _measured(solid: Manifold) -> trimesh.Trimesh:
    """The mesh walls are measured on: the solid with features under ``WALL_FEATURE`` merged."""
    return to_trimesh(solid.simplify(WALL_FEATURE))


def _random_rays(mesh: trimesh.Trimesh, spacing: float) -> int:
    """How many random surface points ``wall_samples`` casts (besides every face's centre)."""
    return int(mesh.area / spacing**2)


def wall_thickness(
    solid: Manifold, limit: float, spacing: float = 0.5, seed: int = 0, samples=None
) -> tuple[float, float]:
    """Thinnest wall of a solid (mm) and the surface area (mm^2) where it is below ``limit``.

    The walls are ``wall_samples``'s (``samples``: its result for this solid, spacing and
    seed when already cast, e.g. ``CarvedLink.walls``); each sample stands for an equal share
    of the surface (its area over the number of points cast).
    """
    mesh = _measured(solid)
    count = _random_rays(mesh, spacing) + len(mesh.faces)
    _, dist = wall_samples(solid, spacing, seed) if samples is None else samples
    if len(dist) == 0:
        return float("inf"), 0.0
    per_point = mesh.area / max(count, 1)
    return float(dist.min()), float(np.count_nonzero(dist < limit) * per_point)
