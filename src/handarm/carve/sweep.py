"""Conservative swept volumes of prism parts turning about a joint axle.

A convex prism turning about an axle parallel to it sweeps the extrusion of the 2D area its
polygon sweeps. That area is covered by the union of the convex hulls of consecutive poses
(at most ``step`` apart) grown by the sagitta R (1 - cos(step / 2)), the most an arc of radius
R strays from its chord: the result covers the true swept volume (tested against a dense
union of rotated copies).
"""

from __future__ import annotations

import math

import numpy as np
from manifold3d import CrossSection, JoinType, Manifold, OpType

from handarm.links import LinkBlank, Part

__all__ = ["prism", "part_in_frame", "sweep_parts", "frame_to_link"]


def frame_to_link(blank: LinkBlank, frame: str) -> np.ndarray:
    """4x4 transform from one of the link's joint frames into its link frame (mm)."""
    if frame == "prox" or blank.dist_from_prox is None:
        return np.eye(4)
    return blank.dist_from_prox


def _affine(m: np.ndarray) -> list[list[float]]:
    return [list(map(float, row)) for row in m[:3, :4]]


def prism(polygon: np.ndarray, z0: float, z1: float) -> Manifold:
    """Extrusion of a convex polygon from z0 to z1."""
    cs = CrossSection.hull_points(np.asarray(polygon, dtype=float))
    return cs.extrude(z1 - z0).translate([0.0, 0.0, z0])


def part_in_frame(blank: LinkBlank, part: Part, frame: str) -> Part:
    """The part as a prism in another joint frame of its link.

    Where the two axles cross (on l3) it is the bounding prism, which contains the part.
    """
    if part.frame == frame:
        return part
    to_link_src = frame_to_link(blank, part.frame)
    to_link_dst = frame_to_link(blank, frame)
    m = np.linalg.solve(to_link_dst, to_link_src)
    rot = m[:3, :3]
    if np.allclose(rot, np.eye(3)):
        poly = part.polygon + m[:2, 3]
        return Part(part.name, frame, poly, part.z0 + m[2, 3], part.z1 + m[2, 3])
    corners = np.concatenate(
        [np.column_stack([part.polygon, np.full(len(part.polygon), z)]) for z in (part.z0, part.z1)]
    )
    pts = corners @ rot.T + m[:3, 3]
    hull = CrossSection.hull_points(pts[:, :2]).to_polygons()[0]
    return Part(part.name, frame, np.asarray(hull), float(pts[:, 2].min()), float(pts[:, 2].max()))


def _rotate(poly: np.ndarray, t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return poly @ np.array([[c, s], [-s, c]])


def sweep_parts(parts, lo: float, hi: float, step: float, grow: float, within=None) -> Manifold:
    """Union of the volumes the parts sweep turning from ``lo`` to ``hi`` (rad) about z.

    Parameters
    ----------
    parts : iterable of Part
        Prisms in the joint frame (their axle is z).
    lo, hi : float
        Rotation range (rad).
    step : float
        Largest angle between consecutive poses (rad).
    grow : float
        Extra margin (mm) in every direction: the print clearance.
    within : array-like, shape (2, 3), optional
        Bounding box (mm) of what the sweep will be cut from: the sweep is clipped to it
        (grown by 1 mm), which keeps the meshes small and changes no cut.
    """
    n = max(1, math.ceil((hi - lo) / step - 1e-9))
    angles = np.linspace(lo, hi, n + 1)
    sag_factor = 1.0 - math.cos((hi - lo) / n / 2.0)
    clip = None
    if within is not None:
        box = np.asarray(within, dtype=float)
        clip = CrossSection.square(box[1, :2] - box[0, :2] + 2.0).translate(box[0, :2] - 1.0)
    by_height: dict[tuple[float, float], list[CrossSection]] = {}
    for part in parts:
        z0, z1 = part.z0 - grow, part.z1 + grow
        if within is not None and (z1 < box[0, 2] - 1.0 or z0 > box[1, 2] + 1.0):
            continue
        poly = np.asarray(part.polygon, dtype=float)
        if part.axisymmetric:
            area = CrossSection.hull_points(poly).offset(grow, JoinType.Round)
        else:
            pieces = [
                CrossSection.hull_points(np.vstack([_rotate(poly, a), _rotate(poly, b)]))
                for a, b in zip(angles[:-1], angles[1:], strict=True)
            ]
            area = CrossSection.batch_boolean(pieces, OpType.Add)
            sag = float(np.max(np.linalg.norm(poly, axis=1))) * sag_factor
            area = area.offset(sag + grow, JoinType.Round)
        if clip is not None:
            area = area ^ clip
        by_height.setdefault((z0, z1), []).append(area)
    solids = []
    for (z0, z1), areas in by_height.items():
        area = CrossSection.batch_boolean(areas, OpType.Add)
        if not area.is_empty():
            solids.append(area.extrude(z1 - z0).translate([0.0, 0.0, z0]))
    return Manifold.batch_boolean(solids, OpType.Add) if solids else Manifold()
