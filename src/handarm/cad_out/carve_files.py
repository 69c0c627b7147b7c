"""Everything ``handarm carve`` writes for a carved design.

::

    OUT/meshes/l0.stl .. l6.stl   binary STL per whole link, mm (the URDF and MJCF meshes)
    OUT/parts/l0.stl, l1_lower_plate.stl, ...   binary STL per printed part, print pose, mm
    OUT/plate.3mf                 every printed part on one plate, mm
    OUT/links/l0.json .. l6.json  per link: volume, mass, centre of mass, inertia, bounding box,
                                  minimum cross-section, requested and achieved limits (SI),
                                  print pose, support area, thinnest wall against min_wall,
                                  and how it prints: cuts, parts, fasteners (``print``)
    OUT/carve.json                every link and joint in one file (degrees for limits)
    OUT/pictures/*.png            each link; the arm straight and folded
    OUT/NAME.urdf                 the URDF with the meshes and their inertials
    OUT/NAME.mjcf.xml             the MuJoCo model: fixed base, limits, tendon actuators
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handarm._io import read_regular_bytes, write_text_atomic
from handarm.cad_out.meshes import (
    print_pose,
    rpy_from_matrix,
    write_3mf,
    write_part_stl,
    write_stl,
)
from handarm.cad_out.mjcf import write_mjcf
from handarm.cad_out.pictures import arm_picture, folded_pose, link_picture
from handarm.cad_out.urdf import LINK_NAMES, write_urdf
from handarm.carve.carving import CarveResult
from handarm.carve.properties import link_properties, wall_thickness

__all__ = [
    "write_carve_outputs",
    "urdf_mesh_elements",
    "read_achieved_limits",
    "printing_report",
    "split_report",
    "printed_summary",
    "thin_links",
    "OUTPUT_STEPS",
]

#: Progress ticks write_carve_outputs makes (for a progress bar's total).
OUTPUT_STEPS = 7 + 1 + 1 + 1 + 7 + 9 + 3


def _f(x: float) -> str:
    return repr(float(x))


def urdf_mesh_elements(result: CarveResult, properties, mesh_dir: str = "meshes") -> dict:
    """URDF children (visual, collision, inertial) per link name, for ``urdf_string``."""
    extras = {}
    for link, props in zip(result.links, properties, strict=True):
        back = np.linalg.inv(print_pose(link))  # print pose (mm) -> link frame (mm)
        xyz = " ".join(_f(v * 1e-3) for v in back[:3, 3])
        rpy = " ".join(_f(v) for v in rpy_from_matrix(back[:3, :3]))
        elements = []
        for tag in ("visual", "collision"):
            el = ET.Element(tag)
            ET.SubElement(el, "origin", xyz=xyz, rpy=rpy)
            geom = ET.SubElement(el, "geometry")
            ET.SubElement(
                geom, "mesh", filename=f"{mesh_dir}/{link.name}.stl", scale="0.001 0.001 0.001"
            )
            elements.append(el)
        inertial = ET.Element("inertial")
        ET.SubElement(
            inertial, "origin", xyz=" ".join(_f(v) for v in props["center_of_mass_m"]), rpy="0 0 0"
        )
        ET.SubElement(inertial, "mass", value=_f(props["mass_kg"]))
        i = np.asarray(props["inertia_kg_m2"])
        ET.SubElement(
            inertial,
            "inertia",
            ixx=_f(i[0, 0]),
            ixy=_f(i[0, 1]),
            ixz=_f(i[0, 2]),
            iyy=_f(i[1, 1]),
            iyz=_f(i[1, 2]),
            izz=_f(i[2, 2]),
        )
        elements.append(inertial)
        extras[LINK_NAMES[link.index]] = elements
    return extras


def printing_report(link, min_wall: float, split=None) -> dict:
    """Print pose, remaining support area and thinnest wall of one carved link (JSON-ready).

    ``min_wall`` is the design's limit (m). ``min_wall_met`` is False where carving left a
    wall thinner than it (``thin_area_mm2`` says how much surface). ``print_down_axis`` and
    ``support_area_mm2`` are the one-piece link's; given the link's ``split``
    (``handarm.carve.split.LinkSplit``), ``support_area_mm2`` is its worst printed part's
    and ``support_area_unsplit_mm2`` the one-piece link's.
    """
    down, support = link.print_orientation  # the one-piece link's (the split's unsplit_*)
    wall, thin = wall_thickness(link.solid, min_wall * 1e3, samples=link.walls)
    out = {
        "print_down_axis": _axis(down),
        "support_area_mm2": support if split is None else split.support,
        "min_wall_m": wall * 1e-3,
        "min_wall_required_m": min_wall,
        "min_wall_met": bool(wall >= min_wall * 1e3 - 1e-9),
        "thin_area_mm2": thin,
    }
    if split is not None:
        out["support_area_unsplit_mm2"] = support
    return out


def _axis(v) -> list[float]:
    return [float(round(x, 6)) + 0.0 for x in v]


def _mm_or_none(v: float) -> float | None:
    """A length in metres from mm; None for none (no cut: no wall 'near a cut')."""
    return None if not np.isfinite(v) else float(v) * 1e-3


def split_report(split, density: float) -> dict:
    """How a link prints, JSON-ready (SI but areas in mm^2): scheme, cuts, parts, fasteners.

    ``target_met`` is False when a part needs ``target_mm2`` or more of support or the
    scheme misses something else; ``problems`` says what.
    """
    return {
        "scheme": split.scheme,
        "target_mm2": split.target,
        "target_met": not split.problems,
        "problems": list(split.problems),
        "cuts": [
            {"normal": _axis(c.normal), "offset_m": c.offset * 1e-3, "label": c.label}
            for c in split.cuts
        ],
        "parts": [
            {
                "name": p.name,
                "stl": f"parts/{p.file_name}",
                "volume_m3": p.solid.volume() * 1e-9,
                "mass_kg": p.solid.volume() * 1e-9 * density,
                "print_down_axis": _axis(p.down),
                "support_area_mm2": p.support,
                "contact_area_mm2": p.contact,
                "height_m": p.height * 1e-3,
                "min_wall_m": _mm_or_none(p.min_wall),
                "min_wall_near_cut_m": _mm_or_none(p.min_wall_near_cut),
            }
            for p in split.parts
        ],
        "fasteners": [
            {
                "kind": f.kind,
                "size": f.size,
                "diameter_m": f.diameter * 1e-3,
                "length_m": f.length * 1e-3,
                "start_m": [v * 1e-3 for v in f.start],
                "end_m": [v * 1e-3 for v in f.end],
                "joins": list(f.joins),
                "wall_m": f.wall * 1e-3,
            }
            for f in split.fasteners
        ],
    }


def thin_links(splits, min_wall: float) -> list[tuple[str, float]]:
    """(link name, thinnest wall in mm) of every link with a wall under ``min_wall`` (m)."""
    out = []
    for s in splits:
        wall, _ = wall_thickness(s.link.solid, min_wall * 1e3, samples=s.link.walls)
        if wall < min_wall * 1e3 - 1e-9:
            out.append((s.link.name, wall))
    return out


def printed_summary(splits, min_wall: float | None = None) -> str:
    """Lines for summary.txt: how each link prints, its worst part's support and fasteners.

    With the design's ``min_wall`` (m), a link with a wall under it says so (its JSON's
    ``min_wall_met`` is false).
    """
    target = max(s.target for s in splits)
    thin = dict(thin_links(splits, min_wall)) if min_wall is not None else {}
    lines = [
        "",
        f"printed parts (target: under {target:g} mm^2 of support each; links/*.json 'print'):",
    ]
    for s in splits:
        groups = s.fastener_groups
        held = (
            "; " + ", ".join(f"{len(g)} x {k} {z}" for (k, z), g in groups.items())
            if groups
            else ""
        )
        lines.append(
            f"  {s.link.name}  {s.scheme:<13}  {len(s.parts)} part(s), worst support "
            f"{s.support:6.1f} mm^2 (one piece: {s.unsplit_support:6.1f}){held}"
        )
        lines += [f"    target missed: {p}" for p in s.problems]
        if s.link.name in thin:
            lines.append(
                f"    thin wall: {thin[s.link.name]:.3g} mm, under min_wall {min_wall * 1e3:g} mm "
                "(the link's shape is that thin where carving could not keep it; "
                "links/*.json 'min_wall_met')"
            )
    return "\n".join(lines) + "\n"


def _limits_of(result: CarveResult, k: int) -> list[dict]:
    """Reports of the joints at link k's ends."""
    return [j.to_dict() for j in result.joints if j.joint in (k, k + 1)]


def write_carve_outputs(
    result: CarveResult, out: str | Path, *, progress: Callable[[str], None] | None = None
) -> list[Path]:
    """Write every carving output into ``out``; returns the paths written."""
    tick = progress or (lambda label: None)
    out = Path(out)
    design = result.design
    written = []
    props = []
    for link in result.links:
        written.append(write_stl(link, out / "meshes" / f"{link.name}.stl"))
        tick(f"{link.name}.stl")
    splits = result.printed
    tick("parts split")
    parts = [part for split in splits for part in split.parts]
    written += [write_part_stl(p, out / "parts" / p.file_name) for p in parts]
    tick("parts/*.stl")
    written.append(write_3mf(parts, out / "plate.3mf"))
    tick("plate.3mf")
    for link, split in zip(result.links, splits, strict=True):
        p = link_properties(link, design.density)
        p["joints"] = _limits_of(result, link.index)
        p.update(printing_report(link, design.min_wall, split))
        p["print"] = split_report(split, design.density)
        props.append(p)
        path = out / "links" / f"{link.name}.json"
        write_text_atomic(path, json.dumps(p, indent=2) + "\n")
        written.append(path)
        tick(f"{link.name}.json")
    for link in result.links:
        written.append(link_picture(result, link.index, out / "pictures" / f"{link.name}.png"))
        tick(f"{link.name}.png")
    written.append(
        arm_picture(
            result,
            np.zeros(6),
            out / "pictures" / "arm_straight.png",
            "carved arm, straight (q = 0)",
        )
    )
    tick("arm_straight.png")
    q = folded_pose(result)
    title = "carved arm folded: q = " + ", ".join(f"{math.degrees(v):.0f}" for v in q) + " deg"
    written.append(arm_picture(result, q, out / "pictures" / "arm_folded.png", title))
    tick("arm_folded.png")
    summary = {
        "design": design.name,
        "resolution_deg": result.resolution,
        "joints": [j.to_dict() for j in result.joints],
        "links": props,
        "total_mass_kg": sum(p["mass_kg"] for p in props),
    }
    path = out / "carve.json"
    write_text_atomic(path, json.dumps(summary, indent=2) + "\n")
    written.append(path)
    tick("carve.json")
    written.append(
        write_urdf(  # the limits the printed parts allow, as the MuJoCo model's
            result.as_built,
            out / f"{design.name}.urdf",
            link_extras=urdf_mesh_elements(result, props),
        )
    )
    tick("urdf")
    written.append(write_mjcf(result, props, out / f"{design.name}.mjcf.xml"))
    tick("mjcf")
    return written


def read_achieved_limits(path: str | Path) -> list[tuple[float, float]]:
    """The achieved joint limits (rad) recorded in a ``carve.json``.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        If the file is not a carve.json this module wrote, or its limits are malformed
        (not 6 finite pairs with lower <= upper).
    """
    path = Path(path)
    try:
        data = json.loads(read_regular_bytes(path))
        pairs = [j["achieved_deg"] for j in data["joints"]]
    except FileNotFoundError:
        raise FileNotFoundError(f"file not found: {path}") from None
    except (ValueError, KeyError, TypeError) as exc:  # JSON, encoding, special file
        raise ValueError(f"{path}: not a handarm carve.json ({exc})") from None
    if len(pairs) != 6:
        raise ValueError(f"{path}: expected 6 joints, found {len(pairs)}")
    out = []
    for k, pair in enumerate(pairs):
        try:
            lo, hi = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise ValueError(
                f"{path}: joint {k + 1}: achieved limits malformed: {pair!r}"
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise ValueError(f"{path}: joint {k + 1}: achieved limits {lo:g} > {hi:g} deg")
        out.append((math.radians(lo), math.radians(hi)))
    return out
