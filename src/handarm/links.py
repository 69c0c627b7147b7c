"""The shape of every link, from the design's dimensions: one description for every part.

Carving builds its manifold3d blanks from it, the printed-link collision model builds its
envelopes from it, and the URDF/MJCF collision geometry comes from it. It sits below
``kinematics`` and ``ik`` (it imports only the design), so the IK never imports ``carve``.

Parametric link blanks (paper II-A.2), in millimetres.

Every link is a union of named convex *parts*, each a prism along the axis of one of the
link's joints: a polygon in that joint's frame (x, y) and a range of z along its axle.
Prisms along an axle make the sweep of a part about that axle a 2D problem (``sweep``).

Joint j's frame has z along its axle. At joint j the proximal link (j - 1) carries a *fork*:
two cheeks (hubs with the axle bore) and a yoke joining them behind the joint; the distal
link j carries the *tongue*: a hub that is also its driving pulley. Cable k passes the idlers
of joints 1 .. k - 1, so joint j's fork leaves room for 6 - j idlers beside the tongue: forks
widen towards the base. l0 is the handle stub where the cables leave towards the motors; l3
turns the axle by 90 degrees; l6 ends in a tool mount.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from handarm.design import ArmDesign

__all__ = [
    "Part",
    "Hole",
    "Groove",
    "LinkBlank",
    "JointGeometry",
    "Strand",
    "joint_geometry",
    "link_blank",
    "strands_in_link",
    "cable_runs",
    "anchor_angles",
    "corridor_radius",
    "mast_screws",
    "MM",
]

MM = 1000.0  # metres -> millimetres
_CIRCLE_SEGMENTS = 48


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class Part:
    """A convex prism: ``polygon`` (n, 2) in the plane of ``frame``, from z0 to z1 (mm)."""

    name: str
    frame: str  # "prox": the link frame (axle of its proximal joint); "dist": its distal joint
    polygon: np.ndarray
    z0: float
    z1: float
    axisymmetric: bool = False  # a disk centred on its frame's axle: its sweep is itself


@dataclasses.dataclass(frozen=True)
class Hole:
    """A cylindrical hole: axis from ``start`` to ``end`` (mm, in ``frame``), ``radius``.

    With ``tip`` > 0 a blind hole's start is closed by a cone ``tip`` mm tall instead of a
    flat end (a drill's point): its wall is steep enough to print as a roof. ``blind``: the
    start is a flat floor inside the material, which a teardrop roof must not run past.
    """

    name: str
    frame: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float
    tip: float = 0.0
    blind: bool = False


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class Groove:
    """A cut revolved about the axle of ``frame`` (mm): the cable groove round a tongue.

    ``profile`` (n, 2) is the cut's outline in (r, z), turned a full turn about the axle.
    Where the beam's root covers the groove (x > 0, |y| < ``root_half_width``) the groove is
    a tunnel and the cut's outline is ``tunnel`` instead.
    """

    name: str
    frame: str
    profile: np.ndarray
    tunnel: np.ndarray
    root_half_width: float


@dataclasses.dataclass(frozen=True)
class Strand:
    """One straight run of one side of a cable along link ``link``, in its frame (mm).

    Cable ``cable`` (1..6) is a closed loop: side +1 runs at +y of the joint planes at
    q = 0, side -1 at -y. Along a link the run is a straight line from where it leaves the
    pulley or idler of the link's proximal joint (on l0: the cable exit, towards the
    motors) to where it meets the pulley or idler of the distal joint.
    """

    link: int
    cable: int
    side: int
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    segment: int = 0  # on l3 a run is three segments: lead-out, the 90-degree twist, lead-in


@dataclasses.dataclass(frozen=True)
class Channel:
    """A cable corridor cut through a link: the hull of consecutive cylinders, ``radius`` (mm).

    ``runs`` are (start, end) axis pairs in the link frame, ``per_cable`` per cable (a
    cable's run, the same run pushed out to the link's edge, on l3 two more copies pushed
    through joint 4's plate edge), cable after cable; each cable's runs are hulled with the
    next cable's (no sliver walls between cables, the corridor opens sideways).
    """

    name: str
    runs: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...]
    radius: float
    per_cable: int = 2  # runs per cable: the run and its copies pushed outwards


@dataclasses.dataclass(frozen=True)
class JointGeometry:
    """Sizes at joint j (mm): tongue, fork gap and width, hub radii, axle bore, cable slots.

    The tongue is centred on z = 0 (the arm's plane); the fork's gap runs from ``gap_lo`` to
    ``gap_hi`` along the axle, with the ``idlers`` whole idlers stacked on the +z side of the
    tongue. ``groove_radius`` is where the cable's centre line wraps the tongue: the
    transmission's pulley radius, the same number.
    """

    joint: int
    idlers: int
    tongue_thickness: float
    tongue_radius: float
    gap: float
    fork_width: float
    hub_radius: float
    bore_radius: float
    gap_lo: float
    gap_hi: float
    groove_radius: float
    idler_width: float
    clearance: float

    lane: float  # the two strands of the driving cable wrap the tongue at z = +-lane
    #: spacer (mm) between the tongue and the first idler, where a run leaving the idler
    #: stack would otherwise cut into the lip over the tongue's groove (``_idler_lift``)
    lift: float = 0.0

    @property
    def cheek(self) -> float:
        """Thickness (mm) of each fork cheek along the axle."""
        return (self.fork_width - self.gap) / 2

    def slot_z(self, slot: int, side: int = 1) -> float:
        """Axle position (mm) of a strand on slot 0 (the tongue) or idler 1 .. ``idlers``.

        On the tongue the strand of side +1 (+y at q = 0) runs in the lane at +``lane``, the
        other at -``lane``: each wraps up to a turn, so they need a lane each.
        """
        if not 0 <= slot <= self.idlers:
            raise ValueError(f"slot: expected 0..{self.idlers} at joint {self.joint}, got {slot}")
        if slot == 0:
            return side * self.lane
        t = self.tongue_thickness / 2 + self.clearance / 2 + self.lift
        return t + (slot - 0.5) * self.idler_width


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class LinkBlank:
    """The uncarved link k: parts, holes, corridors, groove and its joint frames' transform.

    ``dist_from_prox`` (4x4, mm) maps distal-joint-frame coordinates into the link frame;
    None for l0 (whose only joint frame is the base frame) and l6.
    """

    index: int
    parts: tuple[Part, ...]
    holes: tuple[Hole, ...]
    length: float
    dist_from_prox: np.ndarray | None
    channels: tuple[Channel, ...] = ()
    grooves: tuple[Groove, ...] = ()

    @property
    def name(self) -> str:
        """Link name: l0 .. l6."""
        return f"l{self.index}"


def corridor_radius(design: ArmDesign) -> float:
    """Radius (mm) a cable run keeps clear round its centre line: cable radius + clearance."""
    return design.cable_diameter * MM / 2 + design.clearance * MM


def _circle(r: float, cx: float = 0.0, cy: float = 0.0, n: int = _CIRCLE_SEGMENTS) -> np.ndarray:
    # circumscribed polygon: it contains the true circle (conservative when swept)
    t = (np.arange(n) + 0.5) * 2 * math.pi / n
    rr = r / math.cos(math.pi / n)
    return np.stack([cx + rr * np.cos(t), cy + rr * np.sin(t)], axis=1)


def _box(x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def joint_geometry(design: ArmDesign, j: int) -> JointGeometry:
    """Sizes at joint j (1..6), in mm."""
    if not 1 <= j <= 6:
        raise ValueError(f"joint: expected 1..6, got {j}")
    return _joint_geometry(design, j, _idler_lift(design, j))


def _joint_geometry(design: ArmDesign, j: int, lift: float) -> JointGeometry:
    """``joint_geometry`` with the idler stack lifted by ``lift`` (mm) off the tongue."""
    c = design.clearance * MM
    idlers = 6 - j
    tongue_t = design.beam_thickness * MM
    gap = tongue_t + idlers * design.idler_width * MM + 2 * c + lift
    pulley = design.joint_pulley_radii[j - 1] * MM
    # the rim keeps min_wall round the anchor holes (thin cables put the rim close by)
    at, hole_r = _anchor_place(design, pulley)
    anchor_rim = at + hole_r + design.min_wall * MM + _WALL_MARGIN
    tongue_r = max(design.hub_radius * MM, pulley + design.cable_diameter * MM, anchor_rim)
    return JointGeometry(
        joint=j,
        idlers=idlers,
        tongue_thickness=tongue_t,
        tongue_radius=tongue_r,
        gap=gap,
        fork_width=gap + 2 * design.cheek_thickness * MM,
        hub_radius=design.hub_radius * MM,
        bore_radius=design.axle_diameter * MM / 2 + c / 2,
        gap_lo=-tongue_t / 2 - c,
        gap_hi=-tongue_t / 2 - c + gap,
        groove_radius=pulley,
        idler_width=design.idler_width * MM,
        clearance=c,
        lane=(design.cable_diameter * MM + c) / 2,
        lift=lift,
    )


def _groove_roof(design: ArmDesign, g: JointGeometry) -> tuple[float, float, float, float]:
    """(bottom, off, top, rim) of the groove round joint g's tongue (mm, see ``_groove``).

    The groove's bottom radius; its roof, the line z = r + off at 45 degrees; ``top``, the
    highest the roof may reach (``min_wall`` under the tongue's face); ``rim``, where the
    roof is capped (``top``, or inf when the line stays under it out to the rim).
    """
    cable_r = design.cable_diameter * MM / 2
    rc = cable_r + g.clearance / 2  # the cable's clearance circle
    bottom = g.groove_radius - cable_r
    # a micrometre under min_wall from the face: exactly min_wall measured a hair under it
    top = g.tongue_thickness / 2 - design.min_wall * MM - 1e-3
    off = g.lane - g.groove_radius + math.sqrt(2.0) * rc
    rim = top if g.tongue_radius + off > top else math.inf
    return bottom, off, top, rim


def _lip_walls(x, y, d, z, radius, bottom, off, rim) -> np.ndarray:
    """Walls (mm) a corridor's underside leaves over a groove's roof, as walls are measured.

    Points (x, y, z) on the underside of a corridor running along x (``d``: their offset
    across it, ``radius``: the corridor's) against the roof of ``_groove_roof``: the wall
    is the gap between faces within ``WALL_ANGLE_DEG`` of parallel (see
    ``handarm.carve.properties.wall_samples``): the underside's bottom over the roof's flat
    cap, and the underside's flank over the 45-degree roof where they face each other.
    inf where no such pair of faces meets.
    """
    r = np.hypot(x, y)
    out = np.full(np.broadcast(x, y, d, z).shape, np.inf)
    up = np.sqrt(np.maximum(radius**2 - d**2, 0.0))  # the underside's normal, vertical part
    parallel = math.cos(math.radians(WALL_ANGLE_DEG))
    if math.isfinite(rim):
        on_cap = (r >= rim - off) & (up >= parallel * radius)
        out = np.where(on_cap, z - rim, out)
    # the flank's normal (0, -d, up) / radius against the roof's (x, y, -r) / (r sqrt 2)
    facing = (d * y / np.maximum(r, 1e-12) + up) / (radius * math.sqrt(2.0)) >= parallel
    on_line = (r >= bottom) & ((r < rim - off) | ~np.isfinite(rim)) & facing
    return np.where(on_line, np.minimum(out, (z - r - off) / math.sqrt(2.0)), out)


@functools.lru_cache(maxsize=256)
def _idler_lift(design: ArmDesign, j: int) -> float:
    """How far (mm) joint j's idler stack is lifted off its tongue by a spacer.

    The runs of link j leave the idlers above its tongue and head for joint j + 1; the
    steepest (cable j + 1, bound for the next tongue's lanes) passes low over the tongue's
    rim, and its corridor (the cable's radius and the clearance, as cut) cut into the lip
    left over the groove's roof: 0.6-0.9 mm with cables of 1.6-2 mm. The stack is lifted,
    where it must be, until every point of those corridors over the tongue keeps
    ``min_wall`` (and a margin) from the roof. Zero for the paper's arm.
    """
    if not 1 <= j <= 5:
        return 0.0
    g = _joint_geometry(design, j, 0.0)
    nxt = _joint_geometry(design, j + 1, 0.0)
    bottom, off, _, rim = _groove_roof(design, g)
    radius = corridor_radius(design) / math.cos(math.pi / 24)  # as the corridor is cut
    length = design.link_lengths[j] * MM
    wall = design.min_wall * MM + _WALL_MARGIN
    # across the corridor, and along it: a grid over the tongue plus, for each offset, where
    # the run crosses the roof's knee and the rim (along a line of the corridor the wall
    # only thins outwards, so those are its thinnest points; the cap's ring can be a
    # twentieth of a millimetre wide)
    d = np.linspace(-radius, radius, 17) * (1.0 - 1e-9)
    need = 0.0
    for cable in range(j + 1, 7):
        for side in (1, -1):
            z0 = g.slot_z(cable - j, side)
            z1 = nxt.slot_z(cable - j - 1, side)
            slope = 0.0 if j == 3 else (z1 - z0) / length  # l3 leaves joint 3 level
            y = side * g.groove_radius + d
            edges = [rim - off - 1e-9, g.tongue_radius * (1.0 - 1e-12)]
            x = [np.sqrt(np.maximum(e * e - y * y, 0.0)) for e in edges if math.isfinite(e)]
            x = np.vstack(x + [np.repeat(np.linspace(0, 12.0, 25)[:, None], len(y), axis=1)])
            x = np.minimum(x, length)
            # the corridor's underside: flat on its outer side (the hull with the copy
            # pushed outwards), the run's cylinder on its inner side
            outer = side * d >= 0.0
            z = z0 + slope * x - np.where(outer, radius, np.sqrt(radius**2 - d**2))
            face = np.where(outer, 0.0, d)  # a flat underside faces straight down
            r = np.hypot(x, y)
            over = (r >= bottom) & (r <= g.tongue_radius) & (z < g.tongue_thickness / 2)
            if not over.any():
                continue
            short = wall - _lip_walls(x, y, face, z, radius, bottom, off, rim)
            # lifting the stack by h lifts the run there by h (1 - x / length)
            scale = 1.0 - (0.0 if j == 3 else x / length)
            short = np.where(over & (short > 0.0), short / scale, 0.0)
            need = max(need, float(short.max()))
    return math.ceil(need * 100.0) / 100.0 if need > 0.0 else 0.0


def _fork(
    g: JointGeometry,
    frame: str,
    length: float,
    clear: float,
    extra: tuple[float, float],
    below: float = 0.0,
) -> list[Part]:
    """Cheeks and the bridge joining them, in the joint's frame; the link lies towards -x.

    The gap between the cheeks stays open out to ``clear`` (the tongue's radius plus
    margins): the bridge starts beyond it, so nothing of this link turns through the
    neighbour's tongue. ``extra`` (mm, + plate and - plate) thickens a plate outwards where
    a cable corridor cuts into it from the gap (``_plate_extra``); its cheek grows with it,
    so that the plate's outer face is one flat face to print on.
    """
    lo, hi = g.gap_lo, g.gap_hi
    cheek = g.cheek
    top, bottom = hi + cheek + extra[0], lo - cheek - extra[1]
    hub = _circle(g.hub_radius)
    plate = _box(-length, 0.0, -g.hub_radius - below, g.hub_radius)
    return [
        Part(f"fork cheek + at joint {g.joint}", frame, hub, hi, top, axisymmetric=True),
        Part(f"fork cheek - at joint {g.joint}", frame, hub, bottom, lo, axisymmetric=True),
        Part(f"fork plate + at joint {g.joint}", frame, plate, hi, top),
        Part(f"fork plate - at joint {g.joint}", frame, plate, bottom, lo),
        Part(
            f"fork bridge at joint {g.joint}",
            frame,
            _box(-length, -clear, -g.hub_radius - below, g.hub_radius),
            bottom,
            top,
        ),
    ]


#: Two faces closer to parallel than this (degrees) bound a wall; a wider corner is an edge
#: (``handarm.carve.properties.wall_samples`` measures walls so; the lift reads it too).
WALL_ANGLE_DEG = 30.0

#: Margin (mm) kept beyond ``min_wall`` where a plate is thickened: the corridor is cut as a
#: polygon round its circle, and the wall is measured on the written mesh.
_WALL_MARGIN = 0.1


def _plate_cuts(
    design: ArmDesign, k: int, g: JointGeometry, length: float, to_dist: np.ndarray | None
) -> np.ndarray:
    """Where link k's corridors pass its distal fork's plates, and how deep they cut: (n, 4).

    Rows are points on the corridors' axes over the plates' stretch of x (-length .. 0, in
    the distal joint's frame, mm): x, y, and how much the + plate and the - plate must grow
    outwards there to keep ``min_wall`` (plus a margin) beyond the corridor (<= 0: none).
    Cable runs climb from one joint's idler stack to the next one's, so a corridor (the hull
    of the runs and their copies pushed outwards, grown by the cable radius plus the
    clearance; ``_corridors``) can cut into a plate from the gap side. Along an axis the need
    is linear in x, so its largest value over the stretch is at one of the ends sampled.
    """
    radius = corridor_radius(design)
    cheek = g.cheek
    wall = design.min_wall * MM + _WALL_MARGIN
    inv = np.eye(4) if to_dist is None else np.linalg.inv(to_dist)
    # what cuts is the corridor: every axis it is the hull of (the runs and their copies
    # pushed outwards, which on l3's twist reach further along joint 4 than the runs do)
    runs = [run for ch in _corridors(design, k) for run in ch.runs]
    if not runs:
        return np.zeros((0, 4))
    ends = np.asarray(runs, dtype=float)  # (n, 2, 3)
    ends = ends @ inv[:3, :3].T + inv[:3, 3]
    a, d = ends[:, 0], ends[:, 1] - ends[:, 0]
    # the part of each axis over the plate's stretch of x, -length .. 0
    along = np.abs(d[:, 0]) >= 1e-12
    dx = np.where(along, d[:, 0], 1.0)
    ta, tb = (-length - a[:, 0]) / dx, (0.0 - a[:, 0]) / dx
    t0 = np.where(along, np.maximum(np.minimum(ta, tb), 0.0), 0.0)
    t1 = np.where(along, np.minimum(np.maximum(ta, tb), 1.0), 1.0)
    keep = np.where(along, t0 <= t1, (-length <= a[:, 0]) & (a[:, 0] <= 0.0))
    a, d, t0, t1 = a[keep], d[keep], t0[keep], t1[keep]
    t = t0[:, None] + np.linspace(0.0, 1.0, 17) * (t1 - t0)[:, None]  # (n, 17)
    x, y, z = (a[:, None, :] + t[..., None] * d[:, None, :]).reshape(-1, 3).T
    over = np.abs(y) <= g.hub_radius + radius  # the others pass beside the plate
    x, y, z = x[over], y[over], z[over]
    hi = z + radius + wall - (g.gap_hi + cheek)
    return np.column_stack([x, y, hi, (g.gap_lo - cheek) - (z - radius - wall)])


def _plate_extra(
    design: ArmDesign, k: int, g: JointGeometry, length: float, to_dist: np.ndarray | None
) -> tuple[float, float]:
    """How much (mm) link k's fork plates at its distal joint grow outwards for ``min_wall``.

    The deepest cut of ``_plate_cuts``, each plate; the + plate (the idler side) no further
    than the proximal joint's gap allows less the clearance: beyond that the proximal
    neighbour would lose a sliver to its sweep.
    """
    cuts = _plate_cuts(design, k, g, length, to_dist)
    need_hi = max(float(cuts[:, 2].max()), 0.0) if len(cuts) else 0.0
    need_lo = max(float(cuts[:, 3].max()), 0.0) if len(cuts) else 0.0
    if 1 <= k <= 5 and k != 3:  # the two joints' axles are parallel: one z along both
        # 0.01 mm short of touching: carving grows and shifts its cuts by about 1e-4 mm
        room = joint_geometry(design, k).gap_hi - g.clearance - 0.01 - (g.gap_hi + g.cheek)
        need_hi = min(need_hi, max(room, 0.0))
    return need_hi, need_lo


#: mm: a floor under ``min_wall`` plus this is opened into a slot (the walls are measured on
#: the written mesh, by rays cast from sampled points).
_SLOT_MARGIN = 0.02


def _plate_slots(design: ArmDesign, k: int) -> tuple[Channel, ...]:
    """Slots through link k's + fork plate where its corridors would leave it too thin.

    Only where the + plate's growth is capped (``_plate_extra``: joints k and k + 1
    parallel): over the stretch of a run whose corridor comes within ``min_wall`` of the
    capped plate's face, the run and its copy pushed sideways (the corridor's own two axes)
    and both pushed up past the face, hulled: the corridor opens through the plate there.
    """
    if not 1 <= k <= 5 or k == 3:
        return ()
    g = joint_geometry(design, k + 1)
    length, _ = _fork_sizes(design, g, design.link_lengths[k] * MM)
    dist = _dist_transform(design, k)
    radius = corridor_radius(design)
    cut = radius / math.cos(math.pi / 24)  # the corridor is cut as a 24-gon round its circle
    top = g.gap_hi + g.cheek + _plate_extra(design, k, g, length, dist)[0]
    x0 = dist[0, 3] - length  # where the plate starts, link frame
    slots = []
    chs = _corridors(design, k)
    runs = [run for ch in chs for run in ch.runs[0 :: ch.per_cable]]
    copies = [run for ch in chs for run in ch.runs[1 :: ch.per_cable]]
    for (a, b), (ca, cb) in zip(runs, copies, strict=True):  # run, copy
        a, b, ca, cb = (np.array(v, dtype=float) for v in (a, b, ca, cb))
        d = b - a
        if d[0] <= 1e-12 or b[0] < x0:
            continue
        ts = np.linspace(max((x0 - a[0]) / d[0], 0.0), 1.0, 65)
        # the floor left over the run, top - (z + radius as cut), is under min_wall
        thin = ts[a[2] + ts * d[2] > top - cut - design.min_wall * MM - _SLOT_MARGIN]
        if not len(thin):
            continue
        t0, t1 = float(thin.min()), max(float(thin.max()), float(thin.min()) + 0.01)
        up = np.array([0.0, 0.0, top - min(a[2] + t0 * d[2], a[2] + t1 * d[2]) + radius + 1.0])
        axes = []
        for p, q in ((a, b), (ca, cb)):
            s, e = p + t0 * (q - p), p + t1 * (q - p)
            axes += [(tuple(s), tuple(e)), (tuple(s + up), tuple(e + up))]
        slots.append(
            Channel(f"cable slot {len(slots) + 1} through l{k}'s + plate", tuple(axes), radius, 4)
        )
    return tuple(slots)


def _twist_ribs(design: ArmDesign, g: JointGeometry, length: float, below: float) -> list[Part]:
    """Ribs on the outer faces of l3's plates at joint 4, where its twisted corridor cuts in.

    l3's corridor turns from joint 3's plane into joint 4's and crosses the plates of joint
    4's fork near its bridge, at a slant: grown whole, a plate would add material that
    l2's fork sweeps through about joint 3. Each plate grows only over the patch of its
    face the corridor comes within ``min_wall`` of (``_plate_cuts``), from the fork's back
    end (which lies on the bed as l3's fork prints) to past the corridor.
    """
    cuts = _plate_cuts(design, 3, g, length, _dist_transform(design, 3))
    radius = corridor_radius(design)
    margin = radius + design.min_wall * MM + _WALL_MARGIN
    lo, hi = g.gap_lo - g.cheek, g.gap_hi + g.cheek
    ribs = []
    for col, name, z0 in ((2, "+", hi), (3, "-", lo)):
        need = cuts[cuts[:, col] > 0.0] if len(cuts) else cuts
        if not len(need):
            continue
        grow = float(need[:, col].max())
        x1 = min(float(need[:, 0].max()) + margin, 0.0)
        y0 = max(float(need[:, 1].min()) - margin, -g.hub_radius - below)
        y1 = min(float(need[:, 1].max()) + margin, g.hub_radius)
        z = (z0, z0 + grow) if name == "+" else (z0 - grow, z0)
        ribs.append(
            Part(f"fork plate {name} rib at joint 4", "dist", _box(-length, x1, y0, y1), *z)
        )
    return ribs


#: Forks are sized so that the paper's largest limit (150 degrees) carves cleanly; a larger
#: request moves the bridge further back (less material), up to the fork's end.
NOMINAL_LIMIT = math.radians(150.0)


def _wedge_radius(design: ArmDesign, limit: float) -> float:
    """Where two beams fit side by side in the wedge a +-limit range leaves (mm).

    At a limit of +-lim the two beams meet at an angle of 180 - lim; both (half-width h,
    grown by the clearance) fit in that wedge beyond r = h / tan(wedge / 2).
    """
    h = design.beam_width * MM / 2 + 2 * design.clearance * MM
    wedge = max(math.pi - limit, math.radians(6.0)) - math.radians(2.0)
    return h / math.tan(wedge / 2)


#: Least thickness (mm) of a fork's bridge along the link.
_BRIDGE = 3.0


def _fork_sizes(design: ArmDesign, g: JointGeometry, a: float) -> tuple[float, float]:
    """(fork length, bridge start) behind joint j, in mm.

    The fork's length depends on the design's sizes only; the bridge (and the beam of the
    link) stop short of the neighbour's tongue and of the wedge the joint's range leaves
    for the two beams. A larger range only moves the bridge back: it never adds material.
    On a short link the fork stops ``min_wall`` (and a margin) short of the outer wall of
    the proximal joint's groove: reaching further, the groove's ring crossed the beam's and
    the bridge's end faces at a slant and left knife edges (0.002 mm in l3 of a 43 mm link
    with 9.6 mm hubs and a 15.7 mm beam). The wedge left for the beams is then smaller, and
    carving narrows the joint's range where the neighbour needs more.
    """
    tongue = g.tongue_radius + 2 * design.clearance * MM + 0.5
    length = max(0.5 * a, max(tongue, _wedge_radius(design, NOMINAL_LIMIT)) + 4.0)
    if g.joint >= 2:
        prox = _groove_outer(_joint_geometry(design, g.joint - 1, 0.0))
        room = a - prox - design.min_wall * MM - _WALL_MARGIN
        length = min(length, max(room, tongue + _BRIDGE))
    lo, hi = design.joint_limits[g.joint - 1]
    clear = max(tongue, _wedge_radius(design, max(NOMINAL_LIMIT, abs(lo), abs(hi))))
    return length, min(clear, length - _BRIDGE)


#: How far (degrees) each strand still wraps the tongue at the end of the joint's range.
ANCHOR_MARGIN_DEG = 20.0


def anchor_angles(design: ArmDesign, j: int) -> tuple[float, float]:
    """Angles (rad, in link j's frame, from +x) of the cable anchors of sides +1 and -1.

    The strand of side +1 reaches the tongue at +y and wraps it clockwise (over +x) to its
    anchor; at q it wraps (pi/2 - q) - angle, which must stay above the margin at the upper
    limit, and symmetrically for side -1 at the lower limit. Like the forks, anchors are
    placed for at least the nominal +-150 degrees, so that a larger range below it changes
    no material.
    """
    lo, hi = design.joint_limits[j - 1]
    lo, hi = min(lo, -NOMINAL_LIMIT), max(hi, NOMINAL_LIMIT)
    m = math.radians(ANCHOR_MARGIN_DEG)
    return math.pi / 2 - hi - m, -math.pi / 2 - lo + m


#: A blind hole's conical end is this many radii tall: its wall rises 48 degrees, a roof
#: that prints without support.
HOLE_TIP = 1.1


def _groove_outer(g: JointGeometry) -> float:
    """Radius (mm) of the groove's outer wall: it runs 1 mm past the tongue's rim."""
    return g.tongue_radius + 1.0


def _groove(design: ArmDesign, g: JointGeometry) -> Groove:
    """The cable groove round the tongue: two lanes, its roof rising at 45 degrees.

    The groove's bottom is at the pulley radius less the cable's radius; it is as wide as
    the two lanes with the cable's clearance circle (radius plus half the clearance) at
    either side. The tongue prints lying on its -z face, so the groove's + face is a roof:
    it is the line z = r + off at 45 degrees, tangent to the + lane's clearance circle,
    from the groove's bottom out past the rim (flat at ``min_wall`` under the tongue's face
    instead where the rim would keep less). Under the beam's root, where the groove is a
    tunnel, the roof is a 45-degree gable from that line down to the tunnel's outer wall,
    ``min_wall`` under the beam's face at most.
    """
    rc = design.cable_diameter * MM / 2 + g.clearance / 2  # the cable's clearance circle
    half = g.lane + rc
    outer = _groove_outer(g)
    bottom, off, top, rim = _groove_roof(design, g)

    def outline(ridge: list[tuple[float, float]], cap: float) -> np.ndarray:
        # along the floor, up the outer wall, over the ridge, back down the roof's line
        pts = [(bottom, -half), (outer, -half), *ridge]
        knee = cap - off  # where the roof's line meets its cap
        if bottom < knee < pts[-1][0]:
            pts.append((knee, cap))
        pts.append((bottom, min(bottom + off, cap)))
        return np.array(pts, dtype=float)

    ridge_r = (half + outer - off) / 2  # the roof's line meets the gable's outer flank
    if ridge_r + off <= top:
        gable = [(outer, half), (ridge_r, ridge_r + off)]
    else:  # capped: the outer flank stops at the cap
        gable = [(outer, half), (half + outer - top, top)]
    return Groove(
        f"cable groove at joint {g.joint}",
        "prox",
        outline([(outer, min(outer + off, rim))], rim),
        outline(gable, top),
        design.beam_width * MM / 2,
    )


def _anchor_place(design: ArmDesign, pulley: float) -> tuple[float, float]:
    """(radius of its axis, its radius) of an anchor hole (mm) in a groove of ``pulley`` mm.

    The hole breaks into the groove's bottom (the pulley radius less the cable's radius).
    """
    cable_r = design.cable_diameter * MM / 2
    hole_r = cable_r + design.clearance * MM / 2
    return pulley - cable_r - 0.6 * hole_r, hole_r


def _anchors(design: ArmDesign, g: JointGeometry) -> list[Hole]:
    """An anchor hole per strand, from its lane in the groove out through the tongue's face."""
    at, hole_r = _anchor_place(design, g.groove_radius)
    face = g.tongue_thickness / 2 + 1.0
    holes = []
    for side, angle in zip((1, -1), anchor_angles(design, g.joint), strict=True):
        x, y = at * math.cos(angle), at * math.sin(angle)
        holes.append(
            Hole(
                f"cable anchor {'+' if side > 0 else '-'} at joint {g.joint}",
                "prox",
                (x, y, side * g.lane),
                (x, y, side * face),
                hole_r,
                tip=HOLE_TIP * hole_r,
            )
        )
    return holes


def _tongue(g: JointGeometry) -> Part:
    t = g.tongue_thickness / 2
    return Part(
        f"tongue (pulley) at joint {g.joint}",
        "prox",
        _circle(g.tongue_radius),
        -t,
        t,
        axisymmetric=True,
    )


def _axle(g: JointGeometry, frame: str) -> Hole:
    h = g.fork_width
    return Hole(f"axle bore at joint {g.joint}", frame, (0, 0, -h), (0, 0, h), g.bore_radius)


#: Length (mm) of the cable exit plate at the end of l0.
EXIT_PLATE = 4.0

#: Pilot hole (mm) for an M3 screw that cuts its own thread in a printed part, and the
#: clearance hole it passes freely.
M3_PILOT, M3_CLEAR = 2.5, 3.4
#: M3 socket head: diameter (mm) and the counterbore (mm) that lets it and a hex key pass.
M3_HEAD, M3_COUNTERBORE = 5.5, 6.5
#: The bed's mast holds l0 by M3 screws driven up from under the bed: each passes
#: ``MAST_CLAMP`` mm of the mast's top and bites ``MAST_SCREW_DEPTH`` mm into l0's underside.
MAST_CLAMP, MAST_SCREW_DEPTH = 6.0, 8.0


def mast_screws(design: ArmDesign) -> np.ndarray:
    """Where the mast screws meet l0's underside: (n, 3) points in the base frame, mm.

    Two along l0's handle, each with a counterbore's width and a printable wall to the
    handle's ends; one in its middle when a short l0 leaves no room for two. The bed's
    holes (``handarm.handle``) and l0's pilot holes (its blank) are both placed from here.
    """
    g = joint_geometry(design, 1)
    a = design.link_lengths[0] * MM
    _, clear = _fork_sizes(design, g, a)
    x0, x1 = -a, -clear
    inset = M3_COUNTERBORE / 2 + 2.0
    xs = [x0 + inset, x1 - inset] if x1 - x0 >= 4 * inset else [(x0 + x1) / 2]
    return np.array([[x, 0.0, g.gap_lo - g.cheek] for x in xs])


def _dist_transform(design: ArmDesign, k: int) -> np.ndarray | None:
    """4x4 (mm) from link k's distal joint frame into its link frame; None for l0 and l6."""
    if k in (0, 6):
        return None
    dist = np.eye(4)
    dist[0, 3] = design.link_lengths[k] * MM
    if k == 3:
        # joint 4's axle is l3's -y axis: the fork turns by 90 degrees about x
        dist = dist @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
    return dist


#: Longest stretch (mm) of l3 over which its cables twist from joint 3's plane into joint
#: 4's: the paper's arm's (a 50 mm l3 less both lead-outs). The - side's cables cross l3's
#: beam on the way; over a longer twist they cross its faces at under 30 degrees and the
#: corridor leaves knife edges (0.02 to 0.09 mm, measured on a 55 and a 60 mm l3).
TWIST_LENGTH = 27.0


def strands_in_link(design: ArmDesign, k: int) -> list[Strand]:
    """The straight cable runs along link k (0..5), in its frame (mm); none on l6.

    Cable c passes link k for c > k: it leaves joint k on its idler c - k (on l0: the cable
    exit, past the exit plate) and meets joint k + 1 on idler c - k - 1, or on the tongue
    (idler 0) when c = k + 1. Both points sit at +-(pulley radius) from the axle.
    """
    if not 0 <= k <= 6:
        raise ValueError(f"link: expected 0..6, got {k}")
    if k == 6:
        return []
    g_dist = joint_geometry(design, k + 1)
    if k == 0:
        to_link = np.eye(4)
    else:
        to_link = _dist_transform(design, k)
        g_prox = joint_geometry(design, k)
    out = []
    for cable in range(k + 1, 7):
        for side in (1, -1):
            end = to_link @ np.array(
                [0.0, side * g_dist.groove_radius, g_dist.slot_z(cable - k - 1, side), 1.0]
            )
            end = tuple(float(v) for v in end[:3])
            if k == 0:
                x0 = -design.link_lengths[0] * MM - EXIT_PLATE - 1.0
                start = (x0, end[1], end[2])
            else:
                start = (0.0, side * g_prox.groove_radius, g_prox.slot_z(cable - k, side))
            if k != 3:
                out.append(Strand(k, cable, side, start, end))
                continue
            # the turn: leave joint 3 and meet joint 4 in their planes (no fleet angle at the
            # pulleys), twist in between through l3's channel, over at most TWIST_LENGTH
            # before joint 4's lead-in (a longer l3 runs its cables straight first)
            lead_in = g_dist.tongue_radius + 2.0
            p2 = (end[0] - lead_in, end[1], end[2])
            lead_out = max(g_prox.tongue_radius + 2.0, p2[0] - start[0] - TWIST_LENGTH)
            p1 = (start[0] + lead_out, start[1], start[2])
            for n, (a, b) in enumerate(((start, p1), (p1, p2), (p2, end))):
                out.append(Strand(k, cable, side, a, b, segment=n))
    return out


def cable_runs(design: ArmDesign, k: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The free stretches of the cable runs along link k (0..6), (start, end) in mm.

    A run that ends on its own tongue (cable k + 1 on l(k)) lies in the tongue's groove for
    its last ``sqrt((R + rc)^2 - r^2)`` (R the tongue's radius, r the pulley radius, rc the
    cable radius plus clearance): that stretch is on the pulley it wraps and is left off.
    What remains must keep clear of every printed part: the tendon check traces these at
    its poses and sweeps them through each joint's range (``handarm.tendons``).
    """
    rc = corridor_radius(design)
    out = []
    for st in strands_in_link(design, k):
        a, b = np.array(st.start), np.array(st.end)
        if st.cable == k + 1 and st.segment == (2 if k == 3 else 0):
            g = joint_geometry(design, k + 1)
            cut = math.sqrt((g.tongue_radius + rc) ** 2 - g.groove_radius**2)
            length = float(np.linalg.norm(b - a))
            b = a + (b - a) * (1.0 - cut / length)
        out.append((a, b))
    return out


@functools.lru_cache(maxsize=64)
def _twist_fin(design: ArmDesign) -> float:
    """How far (mm) l3's fork plates and bridge reach below the hub radius, along joint 3.

    l3's fork turns about joint 4, square to joint 3, so its plates stand across the slab
    that l2's lower fork plate sweeps about joint 3 (grown by the clearance). Below that
    slab a fin of the plates is left; it is grown to ``min_wall`` (plus a margin) where it
    would be thinner.
    """
    plate = next(p for p in link_blank(design, 2).parts if p.name == "fork plate - at joint 3")
    slab_bottom = plate.z0 - design.clearance * MM
    fin = slab_bottom + joint_geometry(design, 4).hub_radius  # l3's plates end at -hub
    wall = design.min_wall * MM + _WALL_MARGIN
    return wall - fin if 0.0 < fin < wall else 0.0


#: mm: how far l3's lead-out corridor runs on past where the twist begins.
_TWIST_OVERLAP = 2.0


def _side_reach(design: ArmDesign, k: int) -> float:
    """How far (mm) link k's material reaches sideways from its plane's centre line.

    The fork plates and cheeks reach the hub radius (l3's a fin further, ``_twist_fin``),
    l0's exit plate 4 mm beyond the beam's side.
    """
    reach = design.hub_radius * MM
    if k == 0:
        reach = max(reach, design.beam_width * MM / 2 + 4.0)
    if k == 3:
        reach += _twist_fin(design)
    return reach


def _push(p: np.ndarray, out: np.ndarray, edge: float, radius: float) -> float:
    """How far (mm) to push a corridor's axis point p outwards along ``out`` (unit).

    Twice the corridor's radius, or further where that would leave the pushed copy's axis
    inside the link's side (``edge`` from the centre line): the corridor then ends in a
    round cap that stops short of the side, or grazes it, and leaves a sheet or a knife edge
    of the plate there (0.1 mm on a 10.9 mm hub, where the copy was pushed a fixed distance).
    """
    return max(2.0 * radius, edge + _WALL_MARGIN - float(p @ out))


def _under_side(p: np.ndarray, out: np.ndarray, edge: float, radius: float, wall: float) -> bool:
    """Whether a corridor round axis point p stops short of the link's side by under ``wall``.

    The side is ``edge`` along ``out``; grazing it counts, opening through it does not.
    """
    top = float(p @ out) + radius
    return edge - wall - _WALL_MARGIN < top < edge + _WALL_MARGIN


@functools.lru_cache(maxsize=256)
def _corridors(design: ArmDesign, k: int) -> tuple[Channel, ...]:
    """Per side, the corridor of link k's cable runs, widened outwards to the link's edge."""
    radius = corridor_radius(design)
    dist = _dist_transform(design, k)
    y = np.array([0.0, 1.0, 0.0])
    out_end = y if dist is None else dist[:3, 1]
    edge = _side_reach(design, k)
    out = []
    strands = strands_in_link(design, k)
    for side, segment in sorted({(st.side, st.segment) for st in strands}, reverse=True):
        runs = []
        for st in strands:
            if st.side != side or st.segment != segment:
                continue
            a, b = np.array(st.start), np.array(st.end)
            if k == 3 and st.segment == 0:
                # the lead-out runs on into the twist's corridor: the two hulls overlap by
                # _TWIST_OVERLAP instead of meeting in a seam that can hold a sheet of a link
                b = b + _TWIST_OVERLAP * (b - a) / np.linalg.norm(b - a)
            runs.append((tuple(a), tuple(b)))
            # the same run pushed out beyond the link's side: the corridor opens sideways (on
            # l3, in the plane of the joint the segment's end is aligned with: l3's twist
            # opens towards joint 3's plane where it starts and joint 4's where it ends)
            out_a = out_end if (k == 3 and st.segment == 2) else y
            out_b = y if (k == 3 and st.segment == 0) else out_end
            pushed = (
                a + side * _push(a, side * out_a, edge, radius) * out_a,
                b + side * _push(b, side * out_b, edge, radius) * out_b,
            )
            runs.append(tuple(map(tuple, pushed)))
            if k == 3:
                # joint 4's plates end at the hub radius across joint 3's plane too (their
                # top edge): an end pushed out in joint 3's plane but within min_wall under
                # that edge is pushed through the edge as well, else the corridor leaves a
                # floor under min_wall there, or (the twist opening in joint 3's plane at
                # its start and through the edge at its end) its hull rises through the
                # edge at a slant and leaves a sheet of it. (Across joint 4's plane the
                # link reaches further than the hub radius: the fork's plates.)
                alt, both = list(pushed), list(pushed)
                for i, (p, out_p) in enumerate(((a, out_a), (b, out_b))):
                    if out_p is not y:
                        continue
                    other = out_end if p @ out_end >= 0.0 else -out_end  # the edge it is near
                    if _under_side(p, other, edge, radius, design.min_wall * MM):
                        alt[i] = p + _push(p, other, edge, radius) * other
                        both[i] = pushed[i] + _push(p, other, edge, radius) * other
                runs.append(tuple(map(tuple, alt)))
                runs.append(tuple(map(tuple, both)))
        if runs:
            label = "+" if side > 0 else "-"
            name = f"cable corridor {label} in l{k}" + (f", part {segment + 1}" if k == 3 else "")
            out.append(Channel(name, tuple(runs), radius, 4 if k == 3 else 2))
    return tuple(out)


def _channels(design: ArmDesign, k: int) -> tuple[Channel, ...]:
    """Link k's cable corridors, and the slots that open them through a fork plate.

    Where a run climbs into its + plate's reach and the plate may not grow enough
    (``_plate_extra``), the corridor would leave a floor under ``min_wall``: over that
    stretch it opens through the plate instead (a slot, the run and a copy pushed out past
    the plate's face).
    """
    return _corridors(design, k) + _plate_slots(design, k)


def link_blank(design: ArmDesign, k: int) -> LinkBlank:
    """The uncarved link k (0..6), in mm."""
    if not 0 <= k <= 6:
        raise ValueError(f"link: expected 0..6, got {k}")
    a = design.link_lengths[k] * MM
    bw = design.beam_width * MM / 2
    parts: list[Part] = []
    holes: list[Hole] = []
    if k == 0:
        # the handle stub: base frame = joint 1's frame; cables leave through the end plate
        g = joint_geometry(design, 1)
        z0, z1 = g.gap_lo - g.cheek, g.gap_hi + g.cheek
        _, clear = _fork_sizes(design, g, a)
        parts += _fork(g, "dist", length=a, clear=clear, extra=_plate_extra(design, 0, g, a, None))
        parts.append(Part("handle", "dist", _box(-a, -clear, -bw, bw), z0, z1))
        plate = EXIT_PLATE
        parts.append(
            Part("cable exit plate", "dist", _box(-a - plate, -a, -bw - 4, bw + 4), z0, z1)
        )
        holes.append(_axle(g, "dist"))
        for i, (x, y, z) in enumerate(mast_screws(design)):
            holes.append(
                Hole(
                    f"mast screw pilot {i + 1}",
                    "dist",
                    (x, y, z - 1.0),
                    (x, y, z + MAST_SCREW_DEPTH),
                    M3_PILOT / 2,
                )
            )
        return LinkBlank(0, tuple(parts), tuple(holes), a, None, _channels(design, 0))
    g_prox = joint_geometry(design, k)
    t = g_prox.tongue_thickness / 2
    parts.append(_tongue(g_prox))
    holes.append(_axle(g_prox, "prox"))
    holes += _anchors(design, g_prox)
    grooves = (_groove(design, g_prox),)
    if k == 6:
        parts.append(Part("beam", "prox", _box(0.0, a, -bw, bw), -t, t))
        # tool mount: a boss at the tip with a bore along x for the tool's shank
        boss = max(bw, 6.0)
        parts.append(Part("tool mount", "prox", _box(a - 10.0, a, -boss, boss), -t, t))
        holes.append(Hole("tool bore", "prox", (a - 8.0, 0, 0), (a + 1.0, 0, 0), 2.0))
        return LinkBlank(6, tuple(parts), tuple(holes), a, None, grooves=grooves)
    g_dist = joint_geometry(design, k + 1)
    # the fork runs back along half the link; its bridge and the beam stop short of the
    # neighbour's tongue
    length, clear = _fork_sizes(design, g_dist, a)
    dist = _dist_transform(design, k)
    parts.append(Part("beam", "prox", _box(0.0, a - clear, -bw, bw), -t, t))
    below = _twist_fin(design) if k == 3 else 0.0
    if k == 3:
        parts += _fork(g_dist, "dist", length=length, clear=clear, extra=(0.0, 0.0), below=below)
        parts += _twist_ribs(design, g_dist, length, below)
    else:
        extra = _plate_extra(design, k, g_dist, length, dist)
        parts += _fork(g_dist, "dist", length=length, clear=clear, extra=extra)
    holes.append(_axle(g_dist, "dist"))
    return LinkBlank(k, tuple(parts), tuple(holes), a, dist, _channels(design, k), grooves)
