"""Tendon paths: where each cable runs, how long it is, and proof that it runs clear.

Cable k (1..6) is one closed loop from motor k's pulley, out of l0's exit plate, past the
idlers of joints 1 .. k - 1 and round the tongue of joint k, where each of its two sides
ends in an anchor. Along a link a side is a straight run (``handarm.links.strands_in_link``:
the geometry lives there, once, and carving cuts the corridors from it); on a pulley or an
idler it is an arc at the pulley radius, the radius the transmission uses.

``cut_lengths`` gives the length to cut per cable (for the bill of materials);
``tendon_report`` traces every side at several poses across the joint ranges and checks that
the cable (its centre line grown by the cable radius and the print clearance) meets no
printed part except the pulley it wraps; ``swept_overlap`` proves it for each joint over its
whole range, or measures the material in the way.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from handarm._checks import check_design
from handarm.design import ArmDesign
from handarm.links import (
    MM,
    anchor_angles,
    cable_runs,
    corridor_radius,
    joint_geometry,
    strands_in_link,
)

__all__ = [
    "CableLength",
    "cable_lengths",
    "cut_lengths",
    "tendon_report",
    "tendon_summary",
    "cable_clear_limits",
    "swept_overlap",
    "TIE_ALLOWANCE",
    "DEFAULT_MOTOR_RUN",
]

#: Cable (m) added at each anchor for the knot or crimp.
TIE_ALLOWANCE = 0.03
#: How far (mm) beyond its radius a tongue counts as the pulley in ``swept_overlap``: the
#: sweeps hold their runs with some room to spare (polygons outside circles, rings of
#: 0.2 mm), and a run stops where its clearance would touch the tongue's rim.
PULLEY_SLACK = 0.5
#: Default straight run (m) from l0's exit plate to the motor pulley, per side, until the
#: handle's motor bed gives the real one.
DEFAULT_MOTOR_RUN = 0.10


@dataclasses.dataclass(frozen=True)
class CableLength:
    """Lengths of one cable (m) between l0's exit plate and its anchors.

    ``side_plus``/``side_minus`` are the two sides at q = 0; ``change`` is (least, most)
    change of the side-plus length over the joint-limit box (side minus changes by the
    opposite amount: the loop's length is constant, the motor takes up the difference).
    """

    cable: int
    side_plus: float
    side_minus: float
    change: tuple[float, float]

    def to_dict(self) -> dict:
        """JSON-ready (metres)."""
        return {
            "cable": self.cable,
            "length_at_zero_m": {"plus": self.side_plus, "minus": self.side_minus},
            "change_over_range_m": {"least": self.change[0], "most": self.change[1]},
        }


def _wrap_at_zero(design: ArmDesign, cable: int, side: int) -> float:
    """Angle (rad) side ``side`` of a cable wraps its tongue at q = 0, up to its anchor."""
    plus, minus = anchor_angles(design, cable)
    return math.pi / 2 - plus if side > 0 else minus + math.pi / 2


def cable_lengths(design: ArmDesign) -> list[CableLength]:
    """Each cable's two sides at q = 0 and their change over the joint ranges (m).

    The straight runs are measured on the runs carving cuts the corridors for; the arc on
    the tongue runs from the tangent point to the anchor. The change is the transmission's
    (``rho * phi_k`` over the limit box, ``handarm.transmission.motor_ranges``): the
    transmission and the tendon lengths agree by construction.
    """
    from handarm.transmission import motor_ranges

    check_design(design)
    sides = {(c, s): 0.0 for c in range(1, 7) for s in (1, -1)}
    for k in range(6):
        for st in strands_in_link(design, k):
            sides[st.cable, st.side] += float(np.linalg.norm(np.subtract(st.end, st.start)))
    rho = design.motor_pulley_radius
    out = []
    for c, mr in zip(range(1, 7), motor_ranges(design), strict=True):
        r = joint_geometry(design, c).groove_radius
        plus = sides[c, 1] + r * _wrap_at_zero(design, c, 1)
        minus = sides[c, -1] + r * _wrap_at_zero(design, c, -1)
        # side +1 shortens when the motor winds it in (phi > 0)
        change = (-rho * mr.hi, -rho * mr.lo)
        out.append(CableLength(c, plus / MM, minus / MM, change))
    return out


def cut_lengths(
    design: ArmDesign, motor_run: float | tuple[float, ...] = DEFAULT_MOTOR_RUN, motor_turns=1.0
) -> list[float]:
    """Length (m) of cable to cut for each cable 1..6 (for the bill of materials).

    One piece per cable: both sides at q = 0, the runs from l0's exit plate to the motor
    pulley on both sides (``motor_run``, m, one value or six), ``motor_turns`` extra turns
    plus half a turn round the motor pulley, and ``TIE_ALLOWANCE`` at each anchor.

    Raises
    ------
    ValueError
        If ``motor_run`` is not positive (or not 6 values) or ``motor_turns`` is negative.
    """
    runs = (
        np.broadcast_to(np.asarray(motor_run, dtype=float), (6,))
        if np.ndim(motor_run) == 0
        else np.asarray(motor_run, dtype=float)
    )
    if runs.shape != (6,) or not np.all(np.isfinite(runs)) or np.any(runs <= 0):
        raise ValueError(f"motor_run: expected one or six lengths > 0 (m), got {motor_run!r}")
    if (
        not (isinstance(motor_turns, (int, float)) and math.isfinite(motor_turns))
        or motor_turns < 0
    ):
        raise ValueError(f"motor_turns: expected a number >= 0, got {motor_turns!r}")
    wrap = (0.5 + motor_turns) * 2 * math.pi * design.motor_pulley_radius
    return [
        c.side_plus + c.side_minus + 2 * float(run) + wrap + 2 * TIE_ALLOWANCE
        for c, run in zip(cable_lengths(design), runs, strict=True)
    ]


def _poses(design: ArmDesign, carved: list[tuple[float, float]], samples: int, seed: int):
    """Poses q = 0, each joint alone at either end of its carved range, and random valid poses."""
    from handarm.kinematics import is_valid

    poses = [np.zeros(6)]
    for j, (lo, hi) in enumerate(carved):
        for v in (lo, hi):
            q = np.zeros(6)
            q[j] = v
            poses.append(q)
    rng = np.random.default_rng(seed)
    lo, hi = np.array(carved).T
    found, tries = 0, 0
    while found < samples and tries < 200 * max(samples, 1):
        q = rng.uniform(lo, hi)
        tries += 1
        if bool(is_valid(design, q)):
            poses.append(q)
            found += 1
    return poses


def _runs(design: ArmDesign) -> list[tuple[int, int, int, np.ndarray, np.ndarray]]:
    """(link, cable, side, start, end) of every free stretch of run, mm (``cable_runs``)."""
    out = []
    for k in range(6):
        strands = strands_in_link(design, k)
        for st, (a, b) in zip(strands, cable_runs(design, k), strict=True):
            out.append((k, st.cable, st.side, a, b))
    return out


def tendon_report(
    design: ArmDesign, carving=None, *, samples: int = 12, seed: int = 0, poses=None
) -> dict:
    """Trace every cable at several poses and check it meets no printed part.

    Each straight run (centre line grown by the cable radius plus the print clearance, a
    32-sided cylinder inside that radius) is placed with its link at each pose and
    intersected (manifold3d) with every carved link placed at the same pose; the arcs lie on
    the pulley and idlers the cable wraps. Poses: q = 0, each joint alone at both ends of its
    carved range, and ``samples`` random poses within the carved ranges that the design's
    collision model accepts. ``swept_overlap`` adds, per joint, the proof over the joint's
    whole range (or what stands in the way).

    Parameters
    ----------
    design : ArmDesign
    carving : handarm.carve.CarveResult, optional
        The carved links (carved here when not given).
    samples : int
        Random poses to add (>= 0).
    seed : int
        Seed of the random poses.
    poses : array-like, shape (n, 6), optional
        Check exactly these poses (rad) instead.

    Returns
    -------
    dict
        ``clear`` (bool), ``poses`` (count), ``contacts`` (list of pose, cable, side, link,
        volume in mm^3), ``cable_clear_deg`` (per joint, how far it turns alone with its
        cables clear, ``cable_clear_limits``), ``swept_in_the_way_mm3`` (per joint, the
        material its links would give up for their cables to clear its whole range,
        ``swept_overlap``), ``cables`` (``CableLength.to_dict`` per cable with
        ``cut_length_m``).

    Raises
    ------
    ValueError
        If ``samples`` is not a non-negative integer.
    """
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 0:
        raise ValueError(f"samples: expected an integer >= 0, got {samples!r}")
    from manifold3d import Manifold, OpType

    from handarm.carve import carve
    from handarm.carve.carving import _cylinder
    from handarm.carve.sweep import _affine
    from handarm.kinematics import joint_frames

    check_design(design)
    carving = carving if carving is not None else carve(design)
    carved = [j.carved for j in carving.joints]
    rc = corridor_radius(design)
    runs = _runs(design)
    cyls = [(k, c, s, _cylinder(a, b, rc, 32)) for k, c, s, a, b in runs]
    by_link = {
        k: Manifold.batch_boolean([m for kk, *_, m in cyls if kk == k], OpType.Add)
        for k in {k for k, *_ in cyls}
    }
    if poses is None:
        poses = _poses(design, carved, samples, seed)
    else:
        from handarm._checks import check_joints

        poses = list(np.atleast_2d(check_joints(poses)))
    contacts = []
    for n, q in enumerate(poses):
        tf = np.empty((7, 4, 4))
        tf[0] = np.eye(4)
        tf[1:] = joint_frames(design, q)[:6]
        tf[:, :3, 3] *= MM
        placed = [link.solid.transform(_affine(tf[i])) for i, link in enumerate(carving.links)]
        boxes = [np.asarray(m.bounding_box()).reshape(2, 3) for m in placed]
        for k, group in by_link.items():
            moved = group.transform(_affine(tf[k]))
            box = np.asarray(moved.bounding_box()).reshape(2, 3)
            for i, link in enumerate(placed):
                if np.any(box[1] < boxes[i][0]) or np.any(boxes[i][1] < box[0]):
                    continue
                if (moved ^ link).volume() <= 1e-6:
                    continue
                for kk, c, s, m in cyls:  # which cables: only now, one by one
                    if kk != k:
                        continue
                    v = (m.transform(_affine(tf[k])) ^ link).volume()
                    if v > 1e-6:
                        contacts.append(
                            {
                                "pose": n,
                                "q_deg": [round(math.degrees(x), 2) for x in q],
                                "cable": c,
                                "side": s,
                                "run_on": f"l{k}",
                                "meets": f"l{i}",
                                "volume_mm3": v,
                            }
                        )
    lengths = cable_lengths(design)
    cuts = cut_lengths(design)
    clear_limits = cable_clear_limits(design, carving)
    return {
        "design": design.name,
        "clear": not contacts,
        "poses": len(poses),
        "cable_clear_deg": [
            {"joint": j + 1, "lower": math.degrees(lo), "upper": math.degrees(hi)}
            for j, (lo, hi) in enumerate(clear_limits)
        ],
        "swept_in_the_way_mm3": swept_overlap(design, carving),
        "cable_radius_plus_clearance_mm": rc,
        "contacts": contacts,
        "cables": [
            dict(c.to_dict(), cut_length_m=cut) for c, cut in zip(lengths, cuts, strict=True)
        ],
    }


def tendon_summary(report: dict) -> str:
    """A few lines for ``summary.txt`` from a ``tendon_report``."""
    lines = ["", "tendons (cable k: length at q = 0, change over the ranges, cut length):"]
    for c in report["cables"]:
        at0 = c["length_at_zero_m"]
        ch = c["change_over_range_m"]
        lines.append(
            f"  cable {c['cable']}: {at0['plus'] * 1e3:.1f} / {at0['minus'] * 1e3:.1f} mm, "
            f"{ch['least'] * 1e3:+.1f} .. {ch['most'] * 1e3:+.1f} mm, "
            f"cut {c['cut_length_m'] * 1e3:.0f} mm"
        )
    lines.append(
        "  joints turn alone with their cables clear to (deg): "
        + ", ".join(f"{c['lower']:.0f}..{c['upper']:.0f}" for c in report["cable_clear_deg"])
    )
    lines.append(
        "  printed material in the cables' way over each joint's whole range "
        "(mm^3, proximal / distal link): "
        + ", ".join(
            f"{s['proximal_mm3']:.0f} / {s['distal_mm3']:.0f}"
            for s in report["swept_in_the_way_mm3"]
        )
    )
    if report["clear"]:
        lines.append(f"  every cable runs clear of the printed parts at {report['poses']} poses")
    else:
        hits = report["contacts"]
        worst = max(hits, key=lambda h: h["volume_mm3"])
        lines.append(
            f"  cables meet printed parts at {len({h['pose'] for h in hits})} of "
            f"{report['poses']} poses (worst: cable {worst['cable']} on {worst['run_on']} "
            f"meets {worst['meets']} at q = {worst['q_deg']} deg); see tendons.json"
        )
    return "\n".join(lines) + "\n"


def swept_overlap(design: ArmDesign, carving) -> list[dict]:
    """Per joint, the printed material (mm^3) in the cables' way anywhere in its range.

    Joint j turns l(j) against l(j-1) through its carved range. The free runs on l(j-1)
    (cylinders of the cable radius plus clearance, ``links.cable_runs``), seen from l(j),
    sweep a volume that holds every place they take; so do those on l(j), seen from l(j-1)
    (``handarm.carve.sweep.sweep_runs``). No material of the other link inside them proves
    that joint j, alone and anywhere in its range, keeps both links' cables clear of both
    links; what lies inside is what the links would have to give up for it. Within
    ``PULLEY_SLACK`` of its rim the tongue of joint j is the pulley the cable wraps, left
    out as the traced check leaves it out (its runs stop where they would touch it).

    Parameters
    ----------
    design : ArmDesign
    carving : handarm.carve.CarveResult
        The carved links; each joint is swept over its carved range.

    Returns
    -------
    list of dict
        Per joint: ``joint``, ``proximal_mm3`` (l(j-1) inside the sweep of l(j)'s runs)
        and ``distal_mm3`` (l(j) inside the sweep of l(j-1)'s runs).
    """
    from manifold3d import Manifold

    from handarm.carve.carving import _in_joint_frame
    from handarm.carve.sweep import frame_to_link, sweep_runs

    rc = corridor_radius(design)

    def inside(solid, runs, lo, hi) -> float:
        if not runs:
            return 0.0
        box = np.asarray(solid.bounding_box()).reshape(2, 3)
        return float((solid ^ sweep_runs(runs, rc, lo, hi, 0.0, box)).volume())

    out = []
    for j in range(1, 7):
        p_link, d_link = carving.links[j - 1], carving.links[j]
        lo, hi = carving.joints[j - 1].carved
        # l(j-1)'s runs in joint j's frame, which is l(j)'s own frame
        to_joint = np.linalg.inv(frame_to_link(p_link.blank, "dist"))
        p_runs = [
            tuple((to_joint @ np.array([*pt, 1.0]))[:3] for pt in run)
            for run in cable_runs(design, j - 1)
        ]
        box = np.asarray(d_link.solid.bounding_box()).reshape(2, 3)
        pulley = Manifold.cylinder(
            box[1, 2] - box[0, 2] + 2.0,
            joint_geometry(design, j).tongue_radius + PULLEY_SLACK,
            circular_segments=96,
        ).translate([0.0, 0.0, box[0, 2] - 1.0])
        out.append(
            {
                "joint": j,
                "proximal_mm3": inside(
                    _in_joint_frame(p_link, "dist"), cable_runs(design, j), lo, hi
                ),
                "distal_mm3": inside(d_link.solid - pulley, p_runs, -hi, -lo),
            }
        )
    return out


def _pinched(prox, dist, prox_runs, dist_runs, q: float) -> bool:
    """Whether, at joint angle q, the distal link meets the proximal runs or vice versa."""
    deg = math.degrees(q)
    if (prox_runs ^ dist.rotate([0.0, 0.0, deg])).volume() > 1e-6:
        return True
    return (dist_runs.rotate([0.0, 0.0, deg]) ^ prox).volume() > 1e-6


def cable_clear_limits(design: ArmDesign, carving, step_deg: float = 5.0) -> list[list[float]]:
    """Per joint, how far (rad, each side) it turns alone before a cable meets a link.

    Only joint j moves: the runs on l(j-1) and l(j) are intersected with the other of the
    two carved links, stepping ``step_deg`` from 0 towards each carved limit and bisecting
    the first contact to 0.5 degrees. Returns ``[[lower, upper], ...]`` for joints 1..6;
    a side that stays clear up to its carved limit returns that limit.
    """
    from manifold3d import Manifold, OpType

    from handarm.carve.carving import _cylinder, _in_joint_frame
    from handarm.carve.sweep import _affine, frame_to_link

    rc = corridor_radius(design)
    runs = _runs(design)
    out = []
    for j in range(1, 7):
        p_link, d_link = carving.links[j - 1], carving.links[j]
        prox = _in_joint_frame(p_link, "dist")
        dist = _in_joint_frame(d_link, "prox")
        to_joint = np.linalg.inv(frame_to_link(p_link.blank, "dist"))
        on_prox = [_cylinder(a, b, rc, 32) for k, _, _, a, b in runs if k == j - 1]
        on_dist = [_cylinder(a, b, rc, 32) for k, _, _, a, b in runs if k == j]
        prox_runs = Manifold.batch_boolean(on_prox, OpType.Add).transform(_affine(to_joint))
        dist_runs = Manifold.batch_boolean(on_dist, OpType.Add) if on_dist else Manifold()

        hit = functools.partial(_pinched, prox, dist, prox_runs, dist_runs)
        sides = []
        for end in carving.joints[j - 1].carved:
            free, bad = 0.0, None
            n = max(1, math.ceil(abs(math.degrees(end)) / step_deg))
            for q in np.linspace(0.0, end, n + 1)[1:]:
                if hit(float(q)):
                    bad = float(q)
                    break
                free = float(q)
            while bad is not None and abs(bad - free) > math.radians(0.5):
                mid = 0.5 * (free + bad)
                free, bad = (free, mid) if hit(mid) else (mid, bad)
            sides.append(free)
        out.append(sides)
    return out
