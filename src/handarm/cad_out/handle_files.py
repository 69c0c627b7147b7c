"""What ``handarm build`` writes for the handle: meshes, balance, bill of materials, guide.

::

    OUT/handle/saddle.stl, bed.stl, pulley_flange.stl, pulley_drum.stl   print pose, mm
    OUT/handle/handle.json        servo places, centre of mass, balance, masses
    OUT/bom.csv                   every part to print or buy, with quantities
    OUT/assembly.html             one step per part with a picture (assembly/step_NN.png)
    OUT/pictures/arm_assembled.png   the whole arm with handle, servos and pulleys
"""

from __future__ import annotations

import csv
import html
import io
import json
import math
from pathlib import Path

import numpy as np
import trimesh

from handarm._figures import new_figure, save_png
from handarm._io import write_bytes_atomic, write_text_atomic
from handarm.cad_out.pictures import _COLOURS, _draw, _frame_axes
from handarm.carve.carving import CarveResult
from handarm.carve.properties import to_trimesh
from handarm.handle import BOSS, NUT_BLOCK, TRAVEL, Handle, motor_runs
from handarm.kinematics import joint_frames
from handarm.links import MAST_CLAMP, MAST_SCREW_DEPTH, MM, joint_geometry, mast_screws

__all__ = [
    "write_handle_outputs",
    "bom_rows",
    "handle_summary",
    "assembled_meshes",
    "split_meshes",
]

_HANDLE_COLOUR, _SERVO_COLOUR, _PULLEY_COLOUR = "#9aa5ad", "#2b2b2b", "#c9a227"
_FASTENER_COLOUR = "#3d3d3d"  # steel


def _on_bed(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    mesh = mesh.copy()
    lo, hi = mesh.bounds
    mesh.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])
    return mesh


def _write_stl(solid, path: Path) -> Path:
    data = _on_bed(to_trimesh(solid)).export(file_type="stl")
    write_bytes_atomic(path, data)
    return path


def handle_summary(h: Handle) -> str:
    """Lines for summary.txt: the balance and masses of the handle."""
    dx, dy = h.balance
    grip_top = h.bed.bounding_box()[2]  # lowest point of the bed: the grip's end
    lines = [
        "",
        "handle (servos in a sideways V, grip under the centre of mass at q = 0):",
        f"  total mass {h.mass * 1e3:.0f} g (printed parts solid at the design's density; "
        f"servos {h.masses['servos'] * 1e3:.0f} g)",
        f"  centre of mass (mm): x={h.com[0]:.1f} y={h.com[1]:.1f} z={h.com[2]:.1f}",
        f"  grip axis (mm): x={h.grip_xy[0]:.1f} y={h.grip_xy[1]:.1f}; "
        f"balance (centre of mass - grip axis): dx={dx:.2f} mm, dy={dy:.2f} mm, "
        f"{h.com[2] - grip_top:.0f} mm above the grip's end",
    ]
    return "\n".join(lines) + "\n"


def _handle_json(h: Handle) -> dict:
    return {
        "servos": [
            {
                "motor": p.motor,
                "side": p.side,
                "cable_angle_deg": math.degrees(p.angle),
                "pulley_distance_mm": p.distance,
                "cable_height_mm": p.exit_z,
            }
            for p in h.places
        ],
        "tensioner_travel_mm": TRAVEL,
        "center_of_mass_mm": h.com.tolist(),
        "grip_axis_mm": h.grip_xy.tolist(),
        "balance_mm": h.balance.tolist(),
        "total_mass_kg": h.mass,
        "masses_kg": h.masses,
    }


def bom_rows(h: Handle, carving: CarveResult) -> list[dict]:
    """The bill of materials, one dict per line (see ``write_handle_outputs``)."""
    from handarm.tendons import cut_lengths

    d = h.design
    servo = d.servo
    rows = []

    def add(item, kind, qty, size="", volume=None, mass=None, note=""):
        rows.append(
            {
                "item": item,
                "kind": kind,
                "quantity": qty,
                "size": size,
                "volume_cm3_each": "" if volume is None else f"{volume:.2f}",
                "mass_g_each": "" if mass is None else f"{mass:.2f}",
                "note": note,
            }
        )

    for split in carving.printed:
        for part in split.parts:
            v = float(to_trimesh(part.solid).volume) * 1e-3
            add(part.name, "printed", 1, "", v, v * d.density * 1e-3, f"parts/{part.file_name}")
    for name, solid, qty in (
        ("saddle", h.saddle, 6),
        ("motor bed with grip", h.bed, 1),
        ("motor pulley flange", h.pulley_flange, 6),
        ("motor pulley drum", h.pulley_drum, 6),
    ):
        v = float(to_trimesh(solid).volume) * 1e-3
        add(name, "printed", qty, "", v, v * d.density * 1e-3, "handle/")
    add(
        servo.name,
        "servo",
        6,
        "x".join(f"{v * MM:g}" for v in servo.outline) + " mm",
        mass=servo.mass * 1e3,
        note=f"IDs {list(d.servo_ids)}; horn {servo.horn_part}",
    )
    for j in range(1, 7):
        g = joint_geometry(d, j)
        length = g.fork_width + 2.0
        add(f"axle joint {j}", "bought", 1, f"steel pin {d.axle_diameter * MM:g} x {length:.0f} mm")
        add(
            f"bushing joint {j}",
            "bought",
            2,
            f"flanged bushing {d.axle_diameter * MM:g} mm bore",
            note="in the fork cheeks",
        )
        add(f"e-clip joint {j}", "bought", 2, f"for {d.axle_diameter * MM:g} mm shaft")
        if g.idlers:
            add(
                f"idler joint {j}",
                "bought",
                g.idlers,
                f"bore {d.axle_diameter * MM:g} mm, groove radius "
                f"{d.joint_pulley_radii[j - 1] * MM:g} mm, width {d.idler_width * MM:g} mm",
                note="aluminium in the paper",
            )
        if g.lift:
            add(
                f"spacer joint {j}",
                "bought",
                1,
                f"washer {d.axle_diameter * MM:g} mm bore, {g.lift:.2f} mm thick",
                note="between the tongue and the first idler",
            )
    for split in carving.printed:
        for (kind, size), group in split.fastener_groups.items():
            add(
                f"{kind} {split.link.name}",
                "bought",
                len(group),
                _BOUGHT[kind] + size,
                note=_FASTENER_NOTES[kind].format(link=split.link.name),
            )
    lead = NUT_BLOCK + TRAVEL + BOSS + 6.0
    add("horn screw", "bought", 6 * servo.horn_bolts, servo.horn_bolt, note="pulley flange")
    add("case screw", "bought", 24, servo.case_screw, note="servo into saddle")
    add("lead screw", "bought", 6, f"M3 x {5 * math.ceil(lead / 5):.0f}", note="tensioner")
    add("nut", "bought", 6, "M3", note="nut trap in the saddle")
    add("drum screw + washer", "bought", 6, "M3 x 8", note="holds the drum on the flange")
    add(
        "mast screw",
        "bought",
        len(mast_screws(h.design)),
        f"M3 x {MAST_CLAMP + MAST_SCREW_DEPTH - 2:.0f} socket head",
        note="up through the bed's mast into l0's pilot holes (it cuts its own thread)",
    )
    for c, cut in enumerate(cut_lengths(d, motor_run=motor_runs(d))):
        add(
            f"cable {c + 1}",
            "bought",
            1,
            f"{d.cable_diameter * MM:g} mm braided line, cut {cut * MM:.0f} mm",
            note=f"tensioner travel {TRAVEL:g} mm",
        )
    return rows


#: How each kind of fastener is bought, and what the bill of materials says it does.
_BOUGHT = {"pin": "steel pin ", "dowel pin": "steel dowel pin ", "screw": ""}
_FASTENER_NOTES = {
    "pin": "cut from silver steel rod; through the fork bridge of all three of {link}'s slabs",
    "dowel pin": "ISO 8734; locates {link}'s fork on its beam",
    "screw": "through {link}'s fork bridge into its beam (cuts its own thread)",
}


def _bom_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def assembled_meshes(h: Handle, carving: CarveResult, q=None) -> list[tuple[str, object, str]]:
    """(name, trimesh in the base frame mm, colour) of every part, in assembly order."""
    q = np.zeros(6) if q is None else np.asarray(q, float)
    frames = joint_frames(h.design, q)
    out = [("bed", to_trimesh(h.bed), _HANDLE_COLOUR)]
    for k, (saddle, servo, pulley) in enumerate(
        zip(h.placed_saddles(), h.servo_boxes(), h.placed_pulleys(), strict=True)
    ):
        out.append((f"saddle {k + 1}", to_trimesh(saddle), _HANDLE_COLOUR))
        out.append((f"servo {k + 1}", to_trimesh(servo), _SERVO_COLOUR))
        out.append((f"pulley {k + 1}", to_trimesh(pulley), _PULLEY_COLOUR))
    for link in carving.links:
        mesh = to_trimesh(link.solid)
        mesh.apply_transform(_link_to_base(frames, link.index))
        out.append((link.name, mesh, _COLOURS[link.index]))
    return out


def _link_to_base(frames, k: int) -> np.ndarray:
    """4x4 (mm) from link k's frame into the base frame, at the frames' pose."""
    if k == 0:
        return np.eye(4)
    m = frames[k - 1].copy()
    m[:3, 3] *= MM
    return m


#: How far (mm) the parts of a split link are drawn apart, and its fasteners out of them.
_EXPLODE = 12.0


def split_meshes(split, to_base: np.ndarray) -> list[tuple[str, object, str]]:
    """(name, trimesh in the base frame mm, colour) of a split link, drawn apart.

    The parts move apart along the cut, the fasteners (steel grey) come backwards out of
    the first part they enter: the picture of the step that joins them.
    """
    normal = np.asarray(split.cuts[0].normal, float)
    shift = {p.name: normal * _EXPLODE * i for i, p in enumerate(split.parts)}
    out = []
    for part in split.parts:
        mesh = to_trimesh(part.solid)
        mesh.apply_translation(shift[part.name])
        mesh.apply_transform(to_base)
        out.append((part.name, mesh, _COLOURS[split.link.index]))
    for f in split.fasteners:
        # out of the first part it enters, backwards along its way in
        start, end = np.asarray(f.start, float), np.asarray(f.end, float)
        back = (start - end) / np.linalg.norm(start - end)
        move = shift[f.joins[0]] + back * _EXPLODE
        mesh = trimesh.creation.cylinder(f.diameter / 2, segment=[end + move, start + move])
        mesh.apply_transform(to_base)
        out.append((f"{f.kind} {split.link.name}", mesh, _FASTENER_COLOUR))
    return out


#: Faces a mesh keeps in the assembly pictures (480 x 400 pixels): matplotlib's 3D drawing
#: costs per face, and 15 pictures of 40,000 faces took 17 s of a build.
PICTURE_FACES = 600


def _for_picture(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """``mesh`` decimated to ``PICTURE_FACES`` for drawing (the mesh files are not)."""
    if len(mesh.faces) <= PICTURE_FACES:
        return mesh
    return mesh.simplify_quadric_decimation(face_count=PICTURE_FACES)


def _picture(meshes, highlight: set[str], path: Path, title: str) -> Path:
    fig = new_figure((6, 5))
    ax = fig.add_subplot(projection="3d")
    pts = []
    for name, mesh, colour in meshes:
        _draw(ax, mesh, "#e8541e" if name in highlight else colour)
        pts.append(mesh.vertices)
    ax.view_init(elev=28, azim=-130)
    _frame_axes(ax, np.concatenate(pts), title)
    return save_png(fig, path, dpi=80)


_STEPS = [
    (
        "Print the parts",
        None,
        "Print every part of bom.csv marked 'printed' (parts/ and handle/, or plate.3mf "
        "and handle/), each as its STL lies: flat faces on the bed, no support needed but "
        "where links/*.json says (print.parts, support_area_mm2).",
    ),
    (
        "Motor bed",
        ["bed"],
        "The bed carries the six saddles, the lead-screw bosses, the mast "
        "that holds l0 and the grip.",
    ),
    (
        "Saddles and servos",
        "saddle servo",
        "Screw each servo into its saddle with the case "
        "screws; set its ID first (controller/controller.json lists them). Drop a nut into the "
        "saddle's nut trap, put the saddle on the bed and run the lead screw through the boss "
        "into the nut, tensioner fully forward.",
    ),
    (
        "Motor pulleys",
        "pulley",
        "Screw each pulley flange onto its servo's horn with the horn "
        "screws, slide the drum over the hexagon and fix it with the drum screw and washer.",
    ),
]


def write_handle_outputs(h: Handle, carving: CarveResult, out: str | Path) -> list[Path]:
    """Write the handle's files into ``out`` (see the module docstring).

    Parameters
    ----------
    h : handarm.handle.Handle
    carving : handarm.carve.CarveResult
        The carved links of the same design.
    out : path
        Output folder.

    Returns
    -------
    list of Path
        Every file written.
    """
    out = Path(out)
    written = []
    for name, solid in (
        ("saddle", h.saddle),
        ("bed", h.bed),
        ("pulley_flange", h.pulley_flange),
        ("pulley_drum", h.pulley_drum),
    ):
        written.append(_write_stl(solid, out / "handle" / f"{name}.stl"))
    path = out / "handle" / "handle.json"
    write_text_atomic(path, json.dumps(_handle_json(h), indent=2) + "\n")
    written.append(path)
    rows = bom_rows(h, carving)
    path = out / "bom.csv"
    write_text_atomic(path, _bom_csv(rows))
    written.append(path)
    meshes = [(name, _for_picture(m), c) for name, m, c in assembled_meshes(h, carving)]
    written.append(
        _picture(
            meshes,
            set(),
            out / "pictures" / "arm_assembled.png",
            "assembled arm with handle, servos and pulleys (q = 0)",
        )
    )
    written += _write_assembly(h, carving, meshes, rows, out)
    return written


def _join_text(split) -> str:
    """The assembly step that joins a split link's parts."""
    name = split.link.name
    files = ", ".join(f"parts/{p.file_name}" for p in split.parts)
    groups = split.fastener_groups
    bought = "; ".join(f"{len(g)} x {_BOUGHT[kind]}{size}" for (kind, size), g in groups.items())
    if split.scheme == "slabs":
        how = (
            f"Push the pins through the fork bridge of {name}'s middle slab, then the lower "
            "and the upper plate over their ends (a drop of glue holds them). The axle of "
            "the fork's joint clamps the plates to it at the hub."
        )
    else:
        how = (
            f"Push the dowel pins into {name}'s beam end, fit the fork over them and drive "
            "the M3 screw through the fork bridge into the beam (2.5 mm hex key; it cuts "
            "its own thread). Do it now: once the next link is in the fork, its plates hide "
            "the screw's head."
        )
    return f"{name} prints as {len(split.parts)} parts ({files}); it takes {bought}. {how}"


def _write_assembly(h, carving, meshes, rows, out: Path) -> list[Path]:
    d = h.design
    steps = list(_STEPS)
    steps.append(
        (
            "l0 on the mast",
            ["l0"],
            f"Screw l0 onto the bed's mast: {len(mast_screws(d))} M3 mast screw(s) go up "
            "through the counterbores under the bed (a 2.5 mm hex key reaches them) into "
            "l0's pilot holes. Its cable exit faces the servos.",
        )
    )
    frames = joint_frames(d, np.zeros(6))
    for k in range(1, 7):
        split = carving.printed[k]
        if split.fasteners:
            scene = [
                (name, _for_picture(mesh), colour)
                for name, mesh, colour in split_meshes(split, _link_to_base(frames, k))
            ]
            steps.append((f"l{k}: join its parts", scene, _join_text(split)))
        g = joint_geometry(d, k)
        idlers = f", with {g.idlers} idler(s) on the axle beside the tongue" if g.idlers else ""
        if g.lift:
            idlers += f" (a {g.lift:.2f} mm spacer between the tongue and the first idler)"
        steps.append(
            (
                f"l{k} at joint {k}",
                [f"l{k}"],
                f"Put l{k}'s tongue into the fork of "
                f"l{k - 1}{idlers}; push the joint {k} axle through the bushings and "
                "fit an e-clip at each end.",
            )
        )
    steps.append(
        (
            "Cables",
            None,
            "Cut each cable to the length in bom.csv. Tie one end in the "
            "anchor of its joint's tongue, run both sides over the idlers of the joints "
            "below as the routing asks, out through l0's exit at its height, and round its "
            "servo's drum (the anchor hole in the groove takes the ends).",
        )
    )
    steps.append(
        (
            "Tensioning",
            None,
            "With the arm straight, turn each lead screw until its "
            "cable is taut: both sides should give the same note when plucked; go from "
            f"cable 6 down to cable 1. The tensioner has {TRAVEL:g} mm of travel; "
            "re-tension after the first hour of use.",
        )
    )
    steps.append(
        (
            "Calibration",
            None,
            "Hold the arm straight (q = 0) and run "
            "<code>handarm bridge calibrate</code>: it records each servo's offset at the "
            "straight pose. Repeat it whenever the cables are re-tensioned.",
        )
    )
    written = []
    names = [n for n, _, _ in meshes]
    body = []
    shown: list[int] = []
    for i, (title, parts, text) in enumerate(steps, start=1):
        img = ""
        if parts and isinstance(parts[0], tuple):  # a scene of its own: a link's parts
            pic = out / "assembly" / f"step_{i:02d}.png"
            written.append(_picture(parts, set(), pic, f"step {i}: {title}"))
            img = f'<img src="assembly/{pic.name}" alt="{html.escape(title)}">'
        elif parts is not None:
            prefixes = parts.split() if isinstance(parts, str) else parts
            new = [
                j
                for j, n in enumerate(names)
                if any(n == p or n.startswith(p + " ") for p in prefixes)
            ]
            shown += new
            sel = [meshes[j] for j in sorted(set(shown))]
            pic = out / "assembly" / f"step_{i:02d}.png"
            written.append(_picture(sel, {names[j] for j in new}, pic, f"step {i}: {title}"))
            img = f'<img src="assembly/{pic.name}" alt="{html.escape(title)}">'
        else:
            pic = out / "assembly" / f"step_{i:02d}.png"
            written.append(_picture(meshes, set(), pic, f"step {i}: {title}"))
            img = f'<img src="assembly/{pic.name}" alt="{html.escape(title)}">'
        body.append(f"<h2>Step {i}: {html.escape(title)}</h2>\n<p>{text}</p>\n{img}")
    table = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(r[k]))}</td>" for k in r) + "</tr>\n" for r in rows
    )
    head = "".join(f"<th>{html.escape(k)}</th>" for k in rows[0])
    page = (
        f"<!doctype html>\n<html><head><meta charset='utf-8'><title>Assembling "
        f"{html.escape(d.name)}</title></head><body>\n<h1>Assembling {html.escape(d.name)}</h1>\n"
        f"<h2>Parts</h2>\n<table border='1'><tr>{head}</tr>\n{table}</table>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )
    path = out / "assembly.html"
    write_text_atomic(path, page)
    written.append(path)
    return written
