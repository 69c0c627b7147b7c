"""Reading what a build folder holds: the URDF chain, display meshes, units of JSON keys."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

__all__ = ["UrdfModel", "read_urdf", "display_mesh", "unit_of", "read_json"]

#: Largest face count of a display mesh; larger meshes are decimated for the page only.
FACE_BUDGET = 20_000

_UNITS = (
    ("_kg_m2", "kg·m²"),
    ("_kg_m3", "kg/m³"),
    ("_m3_per_deg", "m³/deg"),
    ("_per_second", "1/s"),
    ("_n_m", "N·m"),
    ("_nm", "N·m"),
    ("_mm2", "mm²"),
    ("_m3", "m³"),
    ("_m2", "m²"),
    ("_mm", "mm"),
    ("_m", "m"),
    ("_kg", "kg"),
    ("_g", "g"),
    ("_l", "L"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_s", "s"),
    ("_n", "N"),
)


def unit_of(key: str) -> tuple[str, str]:
    """The label and unit a JSON key names by its suffix: ``mass_kg`` -> ("mass", "kg")."""
    low = key.lower()
    m = re.fullmatch(r"(.*)_(deg|rad|mm|m)_(\d+)", low)
    if m:  # a unit before an index: limit_deg_5 -> ("limit 5", "deg")
        return f"{m.group(1).replace('_', ' ')} {m.group(3)}", m.group(2)
    for suffix, unit in _UNITS:
        if low.endswith(suffix):
            return key[: -len(suffix)].replace("_", " "), unit
    return key.replace("_", " "), "–"


def read_json(path: Path):
    """The JSON in ``path``, or None when the file is missing."""
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError:
        return None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from None


def _origin(el) -> np.ndarray:
    """4x4 transform of a URDF ``origin`` element (identity when absent)."""
    m = np.eye(4)
    if el is None:
        return m
    xyz = [float(v) for v in el.get("xyz", "0 0 0").split()]
    r, p, y = (float(v) for v in el.get("rpy", "0 0 0").split())
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    m[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    m[:3, 3] = xyz
    return m


@dataclasses.dataclass(frozen=True)
class UrdfModel:
    """The kinematic tree and mesh visuals of a URDF (SI units).

    Attributes
    ----------
    root : str
        The link no joint has as child.
    joints : list of dict
        In tree order: ``parent``, ``child``, ``origin`` (4x4 nested list), ``axis`` (3),
        ``q`` (index of the revolute joint in joint order, or -1 for a fixed joint),
        ``name``.
    visuals : list of dict
        ``link``, ``mesh`` (path relative to the URDF's folder), ``origin`` (4x4),
        ``scale`` (3).
    """

    root: str
    joints: list
    visuals: list


def read_urdf(path: Path) -> UrdfModel:
    """The chain and mesh visuals of the URDF at ``path``.

    Raises
    ------
    ValueError
        If the file is not a URDF tree.
    """
    try:
        robot = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"{path}: not valid XML ({exc})") from None
    raw = []
    for j in robot.findall("joint"):
        axis = [
            float(v)
            for v in (j.find("axis").get("xyz") if j.find("axis") is not None else "1 0 0").split()
        ]
        raw.append(
            {
                "name": j.get("name"),
                "type": j.get("type"),
                "parent": j.find("parent").get("link"),
                "child": j.find("child").get("link"),
                "origin": _origin(j.find("origin")).tolist(),
                "axis": axis,
            }
        )
    children = {j["child"] for j in raw}
    roots = [link.get("name") for link in robot.findall("link") if link.get("name") not in children]
    if len(roots) != 1:
        raise ValueError(f"{path}: expected one root link, found {roots}")
    ordered, known, q = [], {roots[0]}, 0
    while len(ordered) < len(raw):
        ready = [j for j in raw if j["parent"] in known and j["child"] not in known]
        if not ready:
            raise ValueError(f"{path}: joints do not form a tree from {roots[0]!r}")
        for j in ready:
            moving = j["type"] in ("revolute", "continuous")
            ordered.append({**j, "q": q if moving else -1})
            q += moving
            known.add(j["child"])
    visuals = []
    for link in robot.findall("link"):
        for vis in link.findall("visual"):
            mesh = vis.find("geometry/mesh")
            if mesh is None:
                continue
            scale = [float(v) for v in mesh.get("scale", "1 1 1").split()]
            visuals.append(
                {
                    "link": link.get("name"),
                    "mesh": mesh.get("filename"),
                    "origin": _origin(vis.find("origin")).tolist(),
                    "scale": scale,
                }
            )
    return UrdfModel(roots[0], ordered, visuals)


def display_mesh(path: Path, origin, scale) -> tuple[np.ndarray, np.ndarray]:
    """A visual's mesh in its link frame, in mm, for display.

    Meshes above ``FACE_BUDGET`` faces are decimated to it (quadric decimation); the mesh
    files themselves are never changed. The decimation stops early where collapsing more
    edges would tear the surface: a small part with many small holes (l0 of the paper's arm,
    1,026 faces with its axle bore and screw pilots) goes no lower than about 400 faces.

    Returns
    -------
    vertices : ndarray, shape (n, 3), float32, mm
    faces : ndarray, shape (m, 3), int32
    """
    import trimesh

    mesh = trimesh.load_mesh(path, force="mesh")
    if len(mesh.faces) > FACE_BUDGET:  # trimesh decimates with fast_simplification
        mesh = mesh.simplify_quadric_decimation(face_count=FACE_BUDGET)
    v = np.asarray(mesh.vertices, dtype=float) * np.asarray(scale, dtype=float)
    m = np.asarray(origin, dtype=float)
    v = v @ m[:3, :3].T + m[:3, 3]
    return (v * 1000.0).astype(np.float32), np.asarray(mesh.faces, dtype=np.int32)
