"""Mass properties and strength of carved links (from their meshes).

Volumes, masses, centres of mass and inertia come from trimesh on the carved manifold
(millimetres in, SI out); the minimum cross-section along a link is a strength proxy.
"""

from __future__ import annotations

import numpy as np
import trimesh
from manifold3d import Manifold

from handarm.carve.carving import CarvedLink

__all__ = ["to_trimesh", "link_properties", "min_cross_section"]


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
