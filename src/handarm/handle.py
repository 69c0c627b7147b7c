"""The handle: motor saddles, the motor bed with lead-screw tensioners, the grip, motor pulleys.

Paper II-B (Fig. 6): six servos sit on printed saddles that slide in a bed; a bolt acting as
a lead screw moves each saddle along its cable to tension it, and the servos stand in a
sideways "V" so that every cable can be tensioned on its own without the cables crossing.

Layout (base frame, mm; the arm points along +x from joint 1 at the origin): both sides of
each cable leave l0's exit (``links.strands_in_link``) at the cable's own height and run level
to its servo's pulley, whose groove sits at that height (the bed rises under the higher
servos). Each servo stands horn up, its case along its cable's direction, so that sliding it
along the cable (tensioning) does not turn the cable. ``motor_layout`` places the servos one
after the other, alternating sides, each as close to the exit as it can go (a 3 degree by
3 mm grid) while, over the whole tensioner travel of both servos of every pair,

* the saddles keep ``GAP`` apart and stay behind the exit plate,
* two cables at heights closer than a cable's width plus the clearance do not overlap seen
  from above (level cables at different heights cannot meet),
* a cable either passes above a servo (above its pulley's top) or keeps the clearance from
  that servo's saddle seen from above.

``layout_problems`` lists what breaks these rules; the tests re-check a layout by brute force
in 3D (cable sides as segments, servo cases as boxes).

The grip is a vertical cylinder under the bed, placed under the centre of mass of the arm at
q = 0 with the servos, pulleys, saddles and bed, so that holding the handle upright needs no
constant torque; ``Handle.balance`` is the remaining offset.

Servo facts (outline, horn) come from ``design.servo`` only. Printed mass uses the design's
density for solid parts (a slicer's infill makes the real parts lighter).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from manifold3d import CrossSection, Manifold, OpType

from handarm._pulley import (
    CENTRE_POCKET_R,
    CENTRE_POCKET_TOP,
    HEAD_SINK,
    HORN_HEAD_R,
    drum_hexagon,
)
from handarm.design import ArmDesign
from handarm.links import (
    M3_CLEAR,
    M3_COUNTERBORE,
    M3_PILOT,
    MAST_CLAMP,
    MM,
    link_blank,
    mast_screws,
    strands_in_link,
)

__all__ = [
    "MotorPlace",
    "Handle",
    "motor_layout",
    "motor_runs",
    "check_layout",
    "handle",
    "pulley_parts",
    "GAP",
    "TRAVEL",
]

#: Gap between neighbouring saddles, and between parts and the exit plate (mm).
GAP = 3.0
#: Tensioner travel: how far back each saddle can slide on its lead screw (mm).
TRAVEL = 12.0
#: Saddle wall thickness (mm), height of its side walls above its floor (mm).
WALL, SADDLE_WALL_HEIGHT, SADDLE_FLOOR = 2.5, 14.0, 3.0
#: Nut block at the back of the saddle, lead-screw boss on the bed (length along the cable, mm).
NUT_BLOCK, BOSS = 8.0, 8.0
#: Bed thickness, grip radius and length (mm).
BED, GRIP_RADIUS, GRIP_LENGTH = 5.0, 16.0, 100.0
#: Motor pulley: horn flange thickness, drum flanges (mm), turns of cable on the drum.
FLANGE, DRUM_LIP, TURNS = 4.0, 1.5, 3
#: Lead screw: M3, its clearance hole and nut (mm).
M3_NUT_FLATS, M3_NUT_THICK = 5.6, 2.6
_SEG = 64


@dataclasses.dataclass(frozen=True)
class MotorPlace:
    """Where motor ``motor`` (1..6) stands (base frame, mm and rad).

    Attributes
    ----------
    motor : int
    side : int
        +1 left (y > 0) or -1 right of the arm's axis.
    angle : float
        Direction of its cable from the exit point E, from the -x axis towards ``side``.
    distance : float
        Distance from E to the pulley centre with the tensioner fully forward (mm).
    exit_z : float
        Height of its cable's hole in l0's exit plate (mm).
    """

    motor: int
    side: int
    angle: float
    distance: float
    exit_z: float

    @property
    def direction(self) -> np.ndarray:
        """Unit vector (x, y) from E along the cable, away from the arm."""
        return np.array([-math.cos(self.angle), self.side * math.sin(self.angle)])

    def along(self, exit_x: float, t: float) -> np.ndarray:
        """Point (x, y) at distance t from E along the cable (mm)."""
        return np.array([exit_x, 0.0]) + t * self.direction


def _servo_mm(design: ArmDesign) -> dict:
    s = design.servo
    w, h, d = (v * MM for v in s.outline)
    return {"w": w, "h": h, "d": d, "horn": s.horn_offset * MM, "horn_t": s.horn_thickness * MM}


@functools.lru_cache(maxsize=16)
def _exit(design: ArmDesign) -> tuple[float, list[float], float]:
    """Where the cables leave l0 (mm), from ``links.strands_in_link``.

    Returns the x of the exit, the height of each cable 1..6 (the middle of its two sides)
    and the half spacing of the two sides.
    """
    strands = strands_in_link(design, 0)
    x = max(st.start[0] for st in strands)
    heights = []
    for c in range(1, 7):
        zs = [st.start[2] for st in strands if st.cable == c]
        heights.append(float(np.mean(zs)))
    half = float(np.mean([abs(st.start[1]) for st in strands]))
    return float(x), heights, half


def drum_radius(design: ArmDesign) -> float:
    """Outer radius of the motor pulley's lips (mm): the groove plus the cable and a lip."""
    return design.motor_pulley_radius * MM + design.cable_diameter * MM / 2 + DRUM_LIP


def _saddle_span(design: ArmDesign) -> tuple[float, float, float]:
    """Along the cable from the pulley centre: front and back of the saddle, half width (mm)."""
    s = _servo_mm(design)
    centre = s["horn"]  # the case's centre lies this far behind the horn axis
    front = centre - s["h"] / 2 - WALL
    back = centre + s["h"] / 2 + WALL + NUT_BLOCK
    return front, back, s["w"] / 2 + WALL


def _rect(place: MotorPlace, exit_x: float, t0: float, t1: float, half: float) -> np.ndarray:
    d = place.direction
    n = np.array([-d[1], d[0]])
    a, b = place.along(exit_x, t0), place.along(exit_x, t1)
    return np.array([a - half * n, b - half * n, b + half * n, a + half * n])


def saddle_footprint(design: ArmDesign, place: MotorPlace, swept: bool = True) -> np.ndarray:
    """Saddle outline seen from above (4, 2), mm; ``swept`` covers the whole travel + boss."""
    exit_x = _exit(design)[0]
    front, back, half = _saddle_span(design)
    extra = TRAVEL + BOSS if swept else 0.0
    return _rect(place, exit_x, place.distance + front, place.distance + back + extra, half)


def _convex(points: np.ndarray) -> np.ndarray:
    """The points in counter-clockwise order about their centroid (a convex polygon)."""
    c = points.mean(axis=0)
    return points[np.argsort(np.arctan2(points[:, 1] - c[1], points[:, 0] - c[0]))]


def _wedge(design: ArmDesign, place: MotorPlace, t: float) -> np.ndarray:
    """The cable seen from above (4, 2), mm: both sides from l0's exit to the pulley."""
    exit_x, _, half = _exit(design)
    d = place.direction
    n = np.array([-d[1], d[0]])
    r = design.motor_pulley_radius * MM + design.cable_diameter * MM / 2
    p = place.along(exit_x, t)
    return _convex(np.array([[exit_x, half], [exit_x, -half], p + r * n, p - r * n]))


def _sat_overlap(a: np.ndarray, b: np.ndarray, gap: float) -> bool:
    """Whether convex polygons a and b come closer than ``gap`` along every edge normal."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for e in edges:
            n = np.array([-e[1], e[0]]) / np.hypot(*e)
            pa, pb = a @ n, b @ n
            if pa.max() + gap <= pb.min() or pb.max() + gap <= pa.min():
                return False
    return True


def _seg_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    den = float(ab @ ab)
    t = 0.0 if den == 0.0 else min(1.0, max(0.0, float((p - a) @ ab) / den))
    return float(np.hypot(*(p - a - t * ab)))


def _poly_capsule_dist(poly: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance between a convex polygon and segment ab (0 if they meet)."""
    if _sat_overlap(poly, np.array([a, b, b + np.array([1e-9, -1e-9])]), 0.0):
        return 0.0
    d = min(_seg_dist(a, p, q) for p, q in zip(poly, np.roll(poly, -1, axis=0), strict=True))
    d = min(d, *(_seg_dist(b, p, q) for p, q in zip(poly, np.roll(poly, -1, axis=0), strict=True)))
    return min(d, *(_seg_dist(p, a, b) for p in poly))


def _drum_top(design: ArmDesign, place: MotorPlace) -> float:
    """Height of the top of this servo's pulley (mm, base frame)."""
    return place.exit_z + _groove_width(design) / 2 + DRUM_LIP


def _passes_over(design: ArmDesign, u: MotorPlace, v: MotorPlace) -> bool:
    """Whether cable u runs above everything of servo v (its pulley is the top)."""
    below = u.exit_z - design.cable_diameter * MM / 2 - design.clearance * MM
    return below > _drum_top(design, v)


def _pair_problems(design: ArmDesign, p: MotorPlace, q: MotorPlace, cheap: bool) -> list[str]:
    """What is wrong between servos p and q (one line each); stop at the first if cheap.

    Each cable runs level at its exit height from l0 to its pulley, so two cables whose
    heights differ by more than a cable's width plus the clearance never meet. A cable may
    pass over a servo whose pulley top is below it; otherwise, seen from above, it keeps the
    clearance from that servo's saddle over both tensioner travels.
    """
    out = []
    if _sat_overlap(saddle_footprint(design, p), saddle_footprint(design, q), GAP):
        out.append(f"motors {q.motor} and {p.motor}: saddles closer than {GAP} mm")
        if cheap:
            return out
    c = design.clearance * MM
    if abs(p.exit_z - q.exit_z) < design.cable_diameter * MM + c:
        for tp in (p.distance, p.distance + TRAVEL):
            if _sat_overlap(_wedge(design, p, tp), _wedge(design, q, q.distance), c):
                out.append(f"cables {q.motor} and {p.motor} cross at one height")
                if cheap:
                    return out
                break
    for u, v in ((p, q), (q, p)):
        if _passes_over(design, u, v):
            continue
        foot = saddle_footprint(design, v)
        for t in (u.distance, u.distance + TRAVEL):
            if _sat_overlap(_wedge(design, u, t), foot, c):
                out.append(f"cable {u.motor} runs into servo {v.motor}")
                if cheap:
                    return out
                break
    return out


def _alone_problems(design: ArmDesign, p: MotorPlace) -> list[str]:
    exit_x = _exit(design)[0]
    if saddle_footprint(design, p)[:, 0].max() > exit_x - GAP:
        return [f"motor {p.motor}: saddle reaches in front of the exit plate"]
    return []


def layout_problems(design: ArmDesign, places: list[MotorPlace]) -> list[str]:
    """Everything wrong with a layout (empty when it is sound), one line each."""
    out = []
    for i, p in enumerate(places):
        out += _alone_problems(design, p)
        for q in places[:i]:
            out += _pair_problems(design, p, q, cheap=False)
    return out


def check_layout(design: ArmDesign, places: list[MotorPlace]) -> None:
    """Raise ValueError listing what is wrong with a motor layout."""
    problems = layout_problems(design, places)
    if problems:
        raise ValueError("motor layout: " + "; ".join(problems))


def motor_runs(design: ArmDesign) -> tuple[float, ...]:
    """Each cable's run from l0's exit plate to its motor pulley, tensioner travel included.

    Metres, cables 1..6: what a cable's cut length is made of beside the arm
    (``handarm.tendons.cut_lengths``). The one source of the cut lengths in the bill of
    materials, ``tendons.json``, the summary and the report.
    """
    return tuple((p.distance + TRAVEL) / MM for p in motor_layout(design))


@functools.lru_cache(maxsize=16)
def motor_layout(design: ArmDesign) -> tuple[MotorPlace, ...]:
    """Place the six servos in a sideways V (see the module docstring).

    Returns
    -------
    tuple of 6 MotorPlace, motors 1..6 (cached per design)

    Raises
    ------
    ValueError
        If no place within 300 mm of the exit plate fits a servo (the message names
        ``motor_pulley_radius`` or ``servo_model``).
    """
    zs = _exit(design)[1]
    placed: list[MotorPlace] = []
    angles = np.radians(np.arange(0.0, 88.0, 3.0))
    distances = np.arange(10.0, 300.0, 3.0)
    for m in range(6):
        side = 1 if m % 2 == 0 else -1
        best = None
        for t in distances:
            for a in angles:
                cand = MotorPlace(m + 1, side, float(a), float(t), zs[m] if m < len(zs) else 0.0)
                if _alone_problems(design, cand):
                    continue
                if not any(_pair_problems(design, cand, q, cheap=True) for q in placed):
                    best = cand
                    break
            if best is not None:
                break
        if best is None:
            raise ValueError(
                f"servo_model: no place for motor {m + 1} within 300 mm of the exit plate "
                "(servo outline or motor_pulley_radius too large)"
            )
        placed.append(best)
    return tuple(placed)


# -- solids -------------------------------------------------------------------------------


def _groove_width(design: ArmDesign) -> float:
    return TURNS * design.cable_diameter * MM + 2 * design.clearance * MM


def _levels(design: ArmDesign) -> dict:
    """Heights in the base frame (mm): groove, horn face, case top and bottom, bed."""
    s = _servo_mm(design)
    horn_face = min(_exit(design)[1]) - (FLANGE + DRUM_LIP + _groove_width(design) / 2)
    case_top = horn_face - s["horn_t"]
    case_bottom = case_top - s["d"]
    bed_top = case_bottom - SADDLE_FLOOR
    return {
        "horn_face": horn_face,
        "case_top": case_top,
        "case_bottom": case_bottom,
        "bed_top": bed_top,
        "bed_bottom": bed_top - BED,
    }


def _box(x0, x1, y0, y1, z0, z1) -> Manifold:
    return Manifold.cube([x1 - x0, y1 - y0, z1 - z0]).translate([x0, y0, z0])


def _cyl(r, z0, z1, x=0.0, y=0.0, n=_SEG) -> Manifold:
    return Manifold.cylinder(z1 - z0, r, r, n).translate([x, y, z0])


def _hole_x(r, x0, x1, y, z) -> Manifold:
    """A cylinder along x from x0 to x1 through (y, z)."""
    c = Manifold.cylinder(x1 - x0, r, r, 32).rotate([0.0, 90.0, 0.0])
    return c.translate([x0, y, z])


def _hole_y(r, y0, y1, x, z) -> Manifold:
    c = Manifold.cylinder(y1 - y0, r, r, 32).rotate([-90.0, 0.0, 0.0])
    return c.translate([x, y0, z])


def saddle_solid(design: ArmDesign) -> Manifold:
    """One saddle in its own frame (mm).

    x runs along the cable from the horn axis, z = 0 is the case's underside: a floor, side
    walls with the case screws, and a nut block for the lead screw at the back.
    """
    s = _servo_mm(design)
    front, back, half = _saddle_span(design)
    case_back = back - NUT_BLOCK
    floor = _box(front, back, -half, half, -SADDLE_FLOOR, 0.0)
    walls = [
        _box(front, case_back, half - WALL, half, 0.0, SADDLE_WALL_HEIGHT),
        _box(front, case_back, -half, -half + WALL, 0.0, SADDLE_WALL_HEIGHT),
        _box(front, front + WALL, -half, half, 0.0, 5.0),
    ]
    nut_h = 10.0
    block = _box(case_back, back, -half, half, 0.0, nut_h)
    solid = Manifold.batch_boolean([floor, *walls, block], OpType.Add)
    cuts = [_hole_x(M3_CLEAR / 2, case_back - 1, back + 1, 0.0, nut_h / 2)]
    # nut trap: a slot from the top, across the screw
    nut_w = M3_NUT_FLATS + 0.3
    mid = (case_back + back) / 2
    cuts.append(
        _box(
            mid - M3_NUT_THICK / 2 - 0.2,
            mid + M3_NUT_THICK / 2 + 0.2,
            -nut_w / 2,
            nut_w / 2,
            nut_h / 2 - nut_w / 2,
            nut_h + 1,
        )
    )
    # two case screws through each side wall (M2.5 clearance)
    centre = s["horn"]
    for dx in (-s["h"] / 4, s["h"] / 4):
        cuts.append(_hole_y(1.45, -half - 1, half + 1, centre + dx, SADDLE_WALL_HEIGHT / 2))
    return solid - Manifold.batch_boolean(cuts, OpType.Add)


def _place(design: ArmDesign, place: MotorPlace, t: float = 0.0) -> np.ndarray:
    """4x4 (mm) from a saddle's frame to the base frame, the tensioner at travel t."""
    exit_x = _exit(design)[0]
    d = place.direction
    m = np.eye(4)
    m[:2, 0] = d
    m[:2, 1] = [-d[1], d[0]]
    m[:2, 3] = place.along(exit_x, place.distance + t)
    m[2, 3] = _levels(design)["case_bottom"] + _rise(design, place)
    return m


def _rise(design: ArmDesign, place: MotorPlace) -> float:
    """How far this servo stands above the lowest (its groove at its cable's exit height)."""
    return place.exit_z - min(_exit(design)[1])


def _affine(m: np.ndarray) -> list[list[float]]:
    return [list(map(float, row)) for row in m[:3]]


def pulley_parts(design: ArmDesign) -> tuple[Manifold, Manifold]:
    """The motor pulley in two printed parts, each in its frame (mm, z up from the horn face).

    The horn flange screws onto the horn with the servo's horn screws, their heads sunk in
    counterbores below the flange's top face, and carries a hexagonal boss; the drum sits on
    the flange over the sunk heads, slides over the boss (torque through the hexagon) and is
    held by an M3 screw into the boss. The hexagon is sized by the drum (1.2 mm of drum wall
    under the groove) and kept inside the ring of counterbores, so the drum's radius does not
    depend on the horn's bolt circle. The drum's groove holds the cable's centre at exactly
    ``design.motor_pulley_radius``. A design whose groove leaves no room for the hexagon
    does not load (``handarm._pulley.drum_hexagon_problem``).
    """
    servo = design.servo
    c = design.clearance * MM
    horn_r = servo.horn_diameter * MM / 2
    bolt_r = servo.horn_bolt_circle * MM / 2
    groove_w = _groove_width(design)
    drum_h = 2 * DRUM_LIP + groove_w
    bottom = design.motor_pulley_radius * MM - design.cable_diameter * MM / 2
    hex_r, slack = drum_hexagon(design)  # one fits: a design without room does not load
    socket_r = hex_r + slack
    # the flange reaches 1.2 mm past the counterbores (a little wider than the horn)
    flange = _cyl(max(horn_r, bolt_r + HORN_HEAD_R + 0.2 + 1.2), 0.0, FLANGE)
    boss = Manifold.extrude(CrossSection.circle(hex_r, 6), drum_h).translate([0, 0, FLANGE])
    flange = flange + boss
    cuts = [
        _cyl(CENTRE_POCKET_R, -1.0, CENTRE_POCKET_TOP),
        _cyl(M3_PILOT / 2, CENTRE_POCKET_TOP, FLANGE + drum_h + 1),  # the screw holding the drum
    ]
    for k in range(servo.horn_bolts):
        a = 2 * math.pi * k / servo.horn_bolts
        x, y = bolt_r * math.cos(a), bolt_r * math.sin(a)
        cuts.append(_cyl(1.45, -1.0, FLANGE + 1.0, x, y, 24))
        # the head (2.5 mm tall) sits 0.2 mm below the top face, under the drum
        cuts.append(_cyl(HORN_HEAD_R + 0.2, FLANGE - HEAD_SINK, FLANGE + 1.0, x, y, 24))
    flange = flange - Manifold.batch_boolean(cuts, OpType.Add)
    lip = drum_radius(design)
    drum = _cyl(lip, 0.0, drum_h)
    ring = _cyl(lip + 1, DRUM_LIP, DRUM_LIP + groove_w) - _cyl(bottom, DRUM_LIP - 1, drum_h)
    socket = Manifold.extrude(CrossSection.circle(socket_r, 6), drum_h + 2).translate([0, 0, -1])
    anchor = _hole_x(design.cable_diameter * MM / 2 + c, 0.0, lip + 1, 0.0, drum_h / 2)
    drum = drum - ring - socket - anchor
    return flange, drum


@dataclasses.dataclass(frozen=True, eq=False)  # holds solids: identity equality
class Handle:
    """The handle of one design (base frame, mm; masses in kg).

    Attributes
    ----------
    places : tuple of 6 MotorPlace
    saddle : Manifold
        One saddle in its own frame (six are printed).
    bed : Manifold
        Bed, lead-screw bosses, the mast up to l0 and the grip, in the base frame.
    pulley_flange, pulley_drum : Manifold
        One motor pulley's two parts in their own frame (six of each are printed).
    grip_xy : ndarray, shape (2,)
        Axis of the grip (mm).
    com : ndarray, shape (3,)
        Centre of mass of the whole arm at q = 0 with servos and handle (mm).
    mass : float
        Total mass (kg).
    masses : dict
        Mass per item (kg): printed parts, servos, the arm's links.
    """

    design: ArmDesign
    places: tuple[MotorPlace, ...]
    saddle: Manifold
    bed: Manifold
    pulley_flange: Manifold
    pulley_drum: Manifold
    grip_xy: np.ndarray
    com: np.ndarray
    mass: float
    masses: dict

    @property
    def balance(self) -> np.ndarray:
        """Centre of mass relative to the grip's axis, (dx, dy) in mm: 0 needs no torque."""
        return self.com[:2] - self.grip_xy

    def placed_saddles(self) -> list[Manifold]:
        """The six saddles in the base frame (tensioners forward)."""
        return [self.saddle.transform(_affine(_place(self.design, p))) for p in self.places]

    def placed_pulleys(self) -> list[Manifold]:
        """The six pulleys (flange + drum) in the base frame."""
        lv = _levels(self.design)
        out = []
        for p in self.places:
            m = _place(self.design, p)
            x, y, z = m[0, 3], m[1, 3], lv["horn_face"] + _rise(self.design, p)
            flange = self.pulley_flange.translate([x, y, z])
            drum = self.pulley_drum.translate([x, y, z + FLANGE])
            out.append(flange + drum)
        return out

    def servo_boxes(self) -> list[Manifold]:
        """The servo cases as boxes in the base frame (for pictures)."""
        s = _servo_mm(self.design)
        box = _box(
            s["horn"] - s["h"] / 2, s["horn"] + s["h"] / 2, -s["w"] / 2, s["w"] / 2, 0.0, s["d"]
        )
        return [box.transform(_affine(_place(self.design, p))) for p in self.places]


def _mass_com(solid: Manifold, density: float) -> tuple[float, np.ndarray]:
    from handarm.carve.properties import to_trimesh

    mesh = to_trimesh(solid)
    return float(mesh.volume) * 1e-9 * density, np.asarray(mesh.center_mass, float)


def _bed(design: ArmDesign, places, grip_xy) -> Manifold:
    lv = _levels(design)
    front, back, half = _saddle_span(design)
    blank = link_blank(design, 0)
    handle_part = next(p for p in blank.parts if p.name == "handle")
    mx0, mx1 = float(handle_part.polygon[:, 0].min()), float(handle_part.polygon[:, 0].max())
    my = float(np.abs(handle_part.polygon[:, 1]).max())
    pts = [saddle_footprint(design, p) for p in places]
    pts.append(np.array([[mx0, -my], [mx1, -my], [mx1, my], [mx0, my]]))
    circle = np.asarray(CrossSection.circle(GRIP_RADIUS + 2.0, _SEG).to_polygons()[0])
    pts.append(circle + np.asarray(grip_xy))
    hull = CrossSection.hull_points(np.concatenate(pts).tolist()).offset(2.0, 0)
    bed = Manifold.extrude(hull, BED).translate([0, 0, lv["bed_bottom"]])
    parts = [bed]
    # mast from the bed up to the underside of l0's handle; its screws go in from under the
    # bed, through a counterbore up to the last MAST_CLAMP mm, into l0's pilot holes
    top = handle_part.z0
    parts.append(_box(mx0, mx1, -my, my, lv["bed_top"] - 0.5, top))
    cuts = []
    for x, y, _ in mast_screws(design):
        cuts.append(_cyl(M3_CLEAR / 2, top - MAST_CLAMP - 0.5, top + 1, x, y, 24))
        cuts.append(_cyl(M3_COUNTERBORE / 2, lv["bed_bottom"] - 1, top - MAST_CLAMP, x, y, 32))
    # per motor: a lead-screw boss behind the saddle's travel, its hole along the cable
    for p in places:
        m = _place(design, p)
        boss = _box(back + TRAVEL, back + TRAVEL + BOSS, -6.0, 6.0, -SADDLE_FLOOR - 0.5, 10.0)
        hole = _hole_x(M3_CLEAR / 2, back - 1, back + TRAVEL + BOSS + 1, 0.0, 5.0)
        parts.append(boss.transform(_affine(m)))
        rise = _rise(design, p)
        if rise > 0:
            foot = CrossSection([saddle_footprint(design, p).tolist()])
            riser = Manifold.extrude(foot, rise + 0.5).translate([0, 0, lv["bed_top"] - 0.5])
            parts.append(riser)
        cuts.append(hole.transform(_affine(m)))
    grip = _cyl(GRIP_RADIUS, lv["bed_bottom"] - GRIP_LENGTH, lv["bed_bottom"] + 0.5, *grip_xy)
    parts.append(grip)
    return Manifold.batch_boolean(parts, OpType.Add) - Manifold.batch_boolean(cuts, OpType.Add)


def handle(design: ArmDesign, carving=None) -> Handle:
    """Lay out the servos, build saddles, bed, pulleys and grip, and balance the grip.

    Parameters
    ----------
    design : ArmDesign
    carving : handarm.carve.CarveResult, optional
        The carved links (their meshes give the arm's mass); default: carve the design.

    Returns
    -------
    Handle
    """
    from handarm.carve import carve
    from handarm.carve.properties import to_trimesh
    from handarm.kinematics import joint_frames

    if carving is None:
        carving = carve(design)
    rho = design.density
    places = motor_layout(design)
    saddle = saddle_solid(design)
    flange, drum = pulley_parts(design)
    lv = _levels(design)
    s = _servo_mm(design)
    masses: dict[str, float] = {}
    items: list[tuple[float, np.ndarray]] = []
    frames = joint_frames(design, np.zeros(6))
    for link in carving.links:
        mesh = to_trimesh(link.solid)
        com = np.asarray(mesh.center_mass, float)
        if link.index > 0:
            f = frames[link.index - 1]
            com = f[:3, :3] @ com + f[:3, 3] * MM
        masses[link.name] = float(mesh.volume) * 1e-9 * rho
        items.append((masses[link.name], com))
    servo_mass = design.servo.mass
    for p in places:
        m = _place(design, p)
        centre = m[:3, :3] @ np.array([s["horn"], 0.0, s["d"] / 2]) + m[:3, 3]
        items.append((servo_mass, centre))
        ms, cs = _mass_com(saddle.transform(_affine(m)), rho)
        items.append((ms, cs))
        z0 = lv["horn_face"] + _rise(design, p)
        for part, z in ((flange, z0), (drum, z0 + FLANGE)):
            mp, cp = _mass_com(part.translate([m[0, 3], m[1, 3], z]), rho)
            items.append((mp, cp))
    masses["servos"] = 6 * servo_mass
    masses["saddle"] = _mass_com(saddle, rho)[0]
    masses["pulley_flange"] = _mass_com(flange, rho)[0]
    masses["pulley_drum"] = _mass_com(drum, rho)[0]
    fixed_m = sum(m for m, _ in items)
    fixed_c = sum(m * c for m, c in items) / fixed_m
    grip_xy = fixed_c[:2].copy()
    for _ in range(4):  # the bed's own mass moves the centre a little: iterate
        bed = _bed(design, places, grip_xy)
        mb, cb = _mass_com(bed, rho)
        com = (fixed_m * fixed_c + mb * cb) / (fixed_m + mb)
        if np.hypot(*(com[:2] - grip_xy)) < 1e-3:
            break
        grip_xy = com[:2].copy()
    masses["bed_and_grip"] = mb
    return Handle(design, places, saddle, bed, flange, drum, grip_xy, com, fixed_m + mb, masses)
