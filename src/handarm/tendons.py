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
import math

import numba as nb
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
    "cable_limits",
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
    """Poses q = 0, each joint alone at either end of its range, and random valid poses."""
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


def _joint_runs(design: ArmDesign, links, j: int):
    """The free runs on l(j-1) and on l(j) in joint j's frame (l(j)'s own), mm.

    Returns (on the proximal link, on the distal link), each a list of
    (cable, side, start, end).
    """
    from handarm.carve.sweep import frame_to_link

    to_joint = np.linalg.inv(frame_to_link(links[j - 1].blank, "dist"))
    prox, dist = [], []
    for k, cable, side, a, b in _runs(design):
        if k == j - 1:
            prox.append((cable, side, *((to_joint @ np.array([*pt, 1.0]))[:3] for pt in (a, b))))
        elif k == j:
            dist.append((cable, side, a, b))
    return prox, dist


def _pulley_reach(design: ArmDesign, j: int) -> float:
    """Radius (mm) within which joint j's tongue counts as the pulley its cable wraps."""
    return joint_geometry(design, j).tongue_radius + PULLEY_SLACK


def tendon_report(
    design: ArmDesign,
    carving=None,
    *,
    samples: int = 12,
    seed: int = 0,
    poses=None,
    motor_run: float | tuple[float, ...] = DEFAULT_MOTOR_RUN,
) -> dict:
    """Trace every cable at several poses and check it meets no printed part.

    Each straight run (centre line grown by the cable radius plus the print clearance, a
    32-sided cylinder inside that radius) is placed with its link at each pose and
    intersected (manifold3d) with every carved link placed at the same pose; the arcs lie on
    the pulley and idlers the cable wraps. Poses: q = 0, each joint alone at both ends of its
    range, and ``samples`` random poses within the ranges that the design's collision model
    accepts. The ranges are the design's joint limits within what the printed joints allow
    (``JointReport.achieved``, which the cables' own limits narrow). ``swept_overlap`` adds,
    per joint, the proof over the joint's whole range (or what stands in the way).

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
    motor_run : float or tuple of 6 float
        Each cable's run beside the arm for its cut length (m, see ``cut_lengths``): a
        build passes its handle's (``handarm.handle.motor_runs``), as the bill of
        materials does.

    Returns
    -------
    dict
        ``clear`` (bool), ``poses`` (count), ``contacts`` (list of pose, cable, side, link,
        volume in mm^3), ``ranges_deg`` (per joint, the range checked and what ends it),
        ``swept_in_the_way_mm3`` (per joint, the material its links would give up for their
        cables to clear that whole range, ``swept_overlap``: zero is the proof that they
        clear), ``cables`` (``CableLength.to_dict`` per cable with ``cut_length_m``).

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
    ranges = design.limited_to([j.achieved for j in carving.joints]).joint_limits
    rc = corridor_radius(design)
    runs = _runs(design)
    cyls = [(k, c, s, _cylinder(a, b, rc, 32)) for k, c, s, a, b in runs]
    by_link = {
        k: Manifold.batch_boolean([m for kk, *_, m in cyls if kk == k], OpType.Add)
        for k in {k for k, *_ in cyls}
    }
    if poses is None:
        poses = _poses(design, ranges, samples, seed)
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
    cuts = cut_lengths(design, motor_run=motor_run)
    return {
        "design": design.name,
        "clear": not contacts,
        "poses": len(poses),
        "ranges_deg": [
            {
                "joint": j + 1,
                "lower": math.degrees(lo),
                "upper": math.degrees(hi),
                "stopped_by": {"lower": r.stopped_by[0], "upper": r.stopped_by[1]},
            }
            for j, ((lo, hi), r) in enumerate(zip(ranges, carving.joints, strict=True))
        ],
        "swept_in_the_way_mm3": swept_overlap(design, carving, ranges),
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
        "  joint ranges checked (deg): "
        + ", ".join(f"{c['lower']:.1f}..{c['upper']:.1f}" for c in report["ranges_deg"])
    )
    swept = report["swept_in_the_way_mm3"]
    if all(s["proximal_mm3"] <= 1e-6 and s["distal_mm3"] <= 1e-6 for s in swept):
        lines.append("  proved: every joint turns through its whole range with its cables clear")
    else:
        lines.append(
            "  printed material in the cables' way over each joint's whole range "
            "(mm^3, proximal / distal link): "
            + ", ".join(f"{s['proximal_mm3']:.2f} / {s['distal_mm3']:.2f}" for s in swept)
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


def swept_overlap(design: ArmDesign, carving, ranges=None) -> list[dict]:
    """Per joint, the printed material (mm^3) in the cables' way anywhere in its range.

    Joint j turns l(j) against l(j-1) through its range. The free runs on l(j-1)
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
        The carved links.
    ranges : sequence of 6 (lower, upper), optional
        Range (rad) to sweep each joint over; by default its carved range.

    Returns
    -------
    list of dict
        Per joint: ``joint``, ``proximal_mm3`` (l(j-1) inside the sweep of l(j)'s runs)
        and ``distal_mm3`` (l(j) inside the sweep of l(j-1)'s runs).
    """
    from manifold3d import Manifold

    from handarm.carve.carving import _in_joint_frame
    from handarm.carve.sweep import sweep_runs

    rc = corridor_radius(design)

    def inside(solid, runs, lo, hi) -> float:
        if not runs:
            return 0.0
        box = np.asarray(solid.bounding_box()).reshape(2, 3)
        return float((solid ^ sweep_runs(runs, rc, lo, hi, 0.0, box)).volume())

    out = []
    for j in range(1, 7):
        p_link, d_link = carving.links[j - 1], carving.links[j]
        lo, hi = carving.joints[j - 1].carved if ranges is None else ranges[j - 1]
        on_prox, on_dist = _joint_runs(design, carving.links, j)
        box = np.asarray(d_link.solid.bounding_box()).reshape(2, 3)
        pulley = Manifold.cylinder(
            box[1, 2] - box[0, 2] + 2.0, _pulley_reach(design, j), circular_segments=96
        ).translate([0.0, 0.0, box[0, 2] - 1.0])
        out.append(
            {
                "joint": j,
                "proximal_mm3": inside(
                    _in_joint_frame(p_link, "dist"), [r[2:] for r in on_dist], lo, hi
                ),
                "distal_mm3": inside(d_link.solid - pulley, [r[2:] for r in on_prox], -hi, -lo),
            }
        )
    return out


#: Spacing (mm) of the surface points that stand for a link in ``cable_limits`` near the
#: axle; farther out it grows with the distance r from the axle as ``SURFACE_TURN * r``, so
#: that the angle a point stands for stays under about ``SURFACE_TURN`` rad.
SURFACE_STEP = 0.2
SURFACE_TURN = 0.02


def _surface_points(solid, r_max: float, z_lo: float, z_hi: float):
    """Points (n, 3), mm, on the surface of ``solid`` near the axle, and how far apart.

    Every triangle that may come within ``r_max`` of the z axis between ``z_lo`` and
    ``z_hi`` is divided into n^2 similar ones with edges under its step (``SURFACE_STEP``,
    or ``SURFACE_TURN`` times its least distance from the axle if more); their corners are
    returned with that step. Any point of a triangle lies within its longest edge of each
    corner, so every surface point there lies within its step of a returned one.
    """
    mesh = solid.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=float)[:, :3]
    tris = verts[np.asarray(mesh.tri_verts, dtype=np.int64)]
    lo, hi = tris.min(axis=1), tris.max(axis=1)
    # the nearest point of each triangle's box to the axle, seen along z
    near = np.hypot(np.clip(0.0, lo[:, 0], hi[:, 0]), np.clip(0.0, lo[:, 1], hi[:, 1]))
    keep = (near <= r_max) & (hi[:, 2] >= z_lo) & (lo[:, 2] <= z_hi)
    tris, near = tris[keep], near[keep]
    if not len(tris):
        return np.empty((0, 3)), np.empty(0)
    step = np.maximum(SURFACE_STEP, SURFACE_TURN * near)
    edge = np.max(np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2), axis=1)
    n = np.maximum(1, np.ceil(edge / step)).astype(np.int64)
    pts, steps = [], []
    for k in np.unique(n):
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        grid = i + j <= k
        u, v = i[grid] / k, j[grid] / k  # barycentric grid
        t = tris[n == k]
        a, ab, ac = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        p = a[:, None, :] + u[None, :, None] * ab[:, None, :] + v[None, :, None] * ac[:, None, :]
        pts.append(p.reshape(-1, 3))
        steps.append(np.repeat(step[n == k], len(u)))
    return np.concatenate(pts), np.concatenate(steps)


@nb.njit(cache=True, nogil=True)
def _any_within(rho, z, slack, first, last, r_near, r_far, z0, z1):
    """Whether a point of first:last may lie, within its slack, in the rings and slab."""
    for i in range(first, last):
        sl = slack[i]
        if r_near - sl <= rho[i] <= r_far + sl and z0 - sl <= z[i] <= z1 + sl:
            return True
    return False


@nb.njit(cache=True, nogil=True)
def _piece_contacts(rho, theta, z, slack, first, last, r_near, r_far, z0, z1, low, high, ref):
    """(turn by -q, turn by +q) before a run piece meets one of the points first:last.

    Ring i of the piece (``_ring_angles``, from ``ref``) spans ``low[i] .. high[i]``; a point
    stands for every point within its ``slack`` (see ``_first_contacts``).
    """
    two_pi = 2.0 * math.pi
    n = len(low)
    width = (r_far - r_near) / n
    best_minus, best_plus = math.inf, math.inf
    for i in range(first, last):
        r, sl = rho[i], slack[i]
        if r < r_near - sl or r > r_far + sl or z[i] < z0 - sl or z[i] > z1 + sl:
            continue
        i0 = min(n - 1, max(0, int(math.floor((r - sl - r_near) / width))))
        i1 = min(n - 1, max(0, int(math.floor((r + sl - r_near) / width))))
        lo, hi = low[i0], high[i0]
        for m in range(i0 + 1, i1 + 1):
            lo, hi = min(lo, low[m]), max(hi, high[m])
        pad = math.asin(min(1.0, sl / max(r - sl, 1e-12)))
        lo, hi = lo - pad, hi + pad
        t = theta[i] - ref
        if hi - lo >= two_pi or (t - lo) % two_pi <= hi - lo:
            return 0.0, 0.0
        # turning by -q the piece covers t when lo - q reaches t; by +q when hi + q does
        best_minus = min(best_minus, (lo - t) % two_pi)
        best_plus = min(best_plus, (t - hi) % two_pi)
    return best_minus, best_plus


def _first_contacts(points: np.ndarray, slack: np.ndarray, pieces, start: float):
    """How far (rad) the run pieces turn from ``start``, each way, before they meet a point.

    ``pieces``: (polygon, z0, z1, tag) from ``sweep._run_pieces``, each a prism holding a
    piece of cable run. At radius r a piece covers the angles ``_ring_angles`` gives for the
    ring holding r (as ``sweep_runs`` does); a point at (r, theta) is met when the turned
    piece's angles reach theta. Each point stands for every surface point within its
    ``slack`` (mm): the rings it may lie in and the angle ``asin(slack / (r - slack))`` are
    added. Returns ((angle, tag) turning by -q, (angle, tag) turning by +q), the tag of the
    piece met first; (inf, None) where nothing is ever met.
    """
    from handarm.carve.sweep import _RING, _nearest, _ring_angles

    order = np.argsort(points[:, 2], kind="stable")  # each piece reads a z slab
    points, slack = points[order], slack[order]
    z = points[:, 2]
    rho = np.hypot(points[:, 0], points[:, 1])
    theta = np.arctan2(points[:, 1], points[:, 0])
    reach = float(np.max(slack)) if len(slack) else 0.0
    best = [(math.inf, None), (math.inf, None)]
    for poly, z0, z1, piece_tag in pieces:
        r_near = _nearest(poly)
        r_far = float(np.max(np.linalg.norm(poly, axis=1)))
        first = int(np.searchsorted(z, z0 - reach, side="left"))
        last = int(np.searchsorted(z, z1 + reach, side="right"))
        if not _any_within(rho, z, slack, first, last, r_near, r_far, z0, z1):
            continue
        if r_near <= reach:
            return (0.0, piece_tag), (0.0, piece_tag)  # a run over the axle meets all round
        c = poly.mean(axis=0)
        ref = math.atan2(c[1], c[0])
        n = max(1, math.ceil((r_far - r_near) / _RING))
        low, high = _ring_angles(poly, np.linspace(r_near, r_far, n + 1), ref)
        empty = ~np.isfinite(low)  # no extreme found in a ring: take the whole turn
        low[empty], high[empty] = -math.pi, math.pi
        found = _piece_contacts(
            rho, theta, z, slack, first, last, r_near, r_far, z0, z1, low, high, ref + start
        )
        for side in range(2):
            if found[side] < best[side][0]:
                best[side] = (found[side], piece_tag)
    return best[0], best[1]


def cable_limits(design: ArmDesign, links, ranges) -> list[dict]:
    """Per joint, how far it turns each way before a cable run meets either of its links.

    Joint j turns l(j) against l(j-1). The free runs on each link (``links.cable_runs``,
    cylinders of the cable radius plus the print clearance, held in prisms as
    ``sweep_runs`` holds them) turn with their link; the other link is stood for by points
    on its surface (``_surface_points``), its pulley left out as in ``swept_overlap``. From
    the point of the range nearest 0, the first angle at which a point enters a run's
    angles is found exactly for those prisms, less what a surface point beside it could
    need: ``swept_overlap`` over the returned range finds no material (a test holds the two
    together). First contact is made on a surface, so no interior point can enter earlier,
    provided nothing meets at the start (the traced check of ``tendon_report`` tests q = 0).
    Where a surface point already lies in a run at the start, both sides stop there and
    name the cable.

    Parameters
    ----------
    design : ArmDesign
    links : sequence of handarm.carve.CarvedLink
        The carved links l0..l6.
    ranges : sequence of 6 (lower, upper)
        Range (rad) to search in per joint; the search starts at its point nearest 0.

    Returns
    -------
    list of dict
        Per joint: ``joint``, ``limits`` (lower, upper) in rad within ``ranges``, and
        ``stopped_by`` (lower, upper): ``None`` where the range's end is reached, else
        "cable k on lN meets lM" for the run met first.
    """
    from handarm.carve.carving import _in_joint_frame
    from handarm.carve.sweep import _run_pieces

    rc = corridor_radius(design)

    def pieces(runs):
        return [
            (poly, z0, z1, (cable, side))
            for cable, side, a, b in runs
            for poly, z0, z1 in _run_pieces([(a, b)], rc)
        ]

    def points(solid, own):
        if not own:
            return np.empty((0, 3)), np.empty(0)
        r_max = max(float(np.max(np.linalg.norm(p[0], axis=1))) for p in own)
        z_lo, z_hi = min(p[1] for p in own), max(p[2] for p in own)
        reach = max(SURFACE_STEP, SURFACE_TURN * r_max)
        pts, slack = _surface_points(solid, r_max + reach, z_lo - reach, z_hi + reach)
        keep = np.hypot(pts[:, 0], pts[:, 1]) <= r_max + slack
        return pts[keep], slack[keep]

    out = []
    for j in range(1, 7):
        p_link, d_link = links[j - 1], links[j]
        lo, hi = ranges[j - 1]
        s = min(max(0.0, lo), hi)
        runs_prox, runs_dist = _joint_runs(design, links, j)
        on_prox, on_dist = pieces(runs_prox), pieces(runs_dist)
        prox_pts = points(_in_joint_frame(p_link, "dist"), on_dist)
        # l(j) less its pulley (``swept_overlap``): inside that cylinder's radius nothing
        # counts, and beyond it the material's edge at each radius lies on l(j)'s surface
        pts, slack = points(d_link.solid, on_prox)
        keep = np.hypot(pts[:, 0], pts[:, 1]) >= _pulley_reach(design, j)
        dist_pts = (pts[keep], slack[keep])
        # l(j)'s runs turn by +q against l(j-1); l(j-1)'s by -q against l(j)
        by_dist = _first_contacts(*prox_pts, on_dist, s)
        by_prox = _first_contacts(*dist_pts, on_prox, -s)
        limits, stops = [], []
        for side, (sign, end) in enumerate(((-1.0, lo), (1.0, hi))):
            found = [(*by_dist[side], j, j - 1), (*by_prox[1 - side], j - 1, j)]
            angle, tag, run_on, meets = min(found, key=lambda f: f[0])
            limit = s + sign * angle
            # a cable already meeting a link at the start stops both sides there
            if angle > 0.0 and sign * (limit - end) >= 0.0:
                limits.append(end)
                stops.append(None)
            else:
                limits.append(limit)
                stops.append(f"cable {tag[0]} on l{run_on} meets l{meets}")
        out.append({"joint": j, "limits": tuple(limits), "stopped_by": tuple(stops)})
    return out
