"""Space carving (paper II-A.2): each link minus what its neighbours sweep.

At joint j the distal link turns by q in [lo, hi] relative to the proximal one. The
proximal link loses the volume the distal link sweeps over [lo, hi]; the distal link loses
what the proximal one sweeps, seen from the distal link, over [-hi, -lo]; both sweeps are
grown by the print clearance. A range whose sweeps would leave either link in pieces, without
its bore wall, or with a wall thinner than ``min_wall`` is narrowed until they do not; walls
under ``min_wall`` that a blank's own corridors leave (or that slip past the range's test)
are rounded off by a local morphological opening (``opened``). Each side, the links meet at
the largest angle before their carved solids touch (manifold3d intersection volume,
bisection to 0.05 degrees); the *achieved* limit is that angle (or the carved limit, where
carving narrowed the request), or less where a cable run would meet one of the two links
first (``handarm.tendons.cable_limits``): the range over which the printed joint turns with
its cables clear.
"""

from __future__ import annotations

import dataclasses
import functools
import io
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from manifold3d import CrossSection, Manifold, OpType

from handarm._checks import check_design
from handarm.carve.sweep import _affine, frame_to_link, part_in_frame, prism, sweep_parts
from handarm.design import MIN_BORE_WALL, ArmDesign
from handarm.links import MM, Groove, Hole, LinkBlank, Part, link_blank

if TYPE_CHECKING:
    from handarm.carve.split import LinkSplit

__all__ = ["CarvedLink", "JointReport", "CarveResult", "carve", "check_carvable"]

_LIMIT_TOL = math.radians(0.05)
_CONTACT_VOLUME = 1e-6  # mm^3: less than this is rounding, not contact
_BORE_WALL = MIN_BORE_WALL * MM  # wall around the axle bore that must survive carving
_JITTER_MM = 1e-4  # see carve(): cuts are grown by twice this and shifted by less
_JITTER = [0.6e-4, 0.5e-4, 0.4e-4]  # mm, |shift| < _JITTER_MM


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class CarvedLink:
    """One carved link: the solid in its link frame (mm) and its blank."""

    blank: LinkBlank
    solid: Manifold

    @property
    def name(self) -> str:
        """Link name: l0 .. l6."""
        return self.blank.name

    @property
    def index(self) -> int:
        """Link index 0..6."""
        return self.blank.index

    @functools.cached_property
    def walls(self) -> tuple[np.ndarray, np.ndarray]:
        """Surface points and the wall behind each (mm), cast once.

        ``handarm.carve.properties.wall_samples`` of the solid at its default spacing: the
        split and the link's JSON report both read it.
        """
        from handarm.carve.properties import wall_samples

        return wall_samples(self.solid)

    @functools.cached_property
    def print_orientation(self) -> tuple[np.ndarray, float]:
        """The one-piece link's print pose: direction put down, support area (mm^2).

        ``handarm.carve.printing.print_orientation`` of the solid, found once: the split, the
        STL, the URDF and the MJCF all read it.
        """
        from handarm.carve.printing import print_orientation

        return print_orientation(self.solid)


@dataclasses.dataclass(frozen=True)
class JointReport:
    """Requested, carved and achieved limits of one joint (rad) and what stops it.

    ``links_meet``: each way, the angle before the two carved links meet. ``achieved``:
    what the printed parts allow (wider than ``requested`` where the request is narrow;
    ``as_built`` is the range the arm is built for): that range, or the carved one on a side
    where carving narrowed the request (past it the links pass closer than the print clearance),
    narrowed to where both links' cable runs keep clear of both links
    (``handarm.tendons.cable_limits``). ``stopped_by`` names what ends ``achieved`` each
    way: the link features that meet, carving, or the cable.
    """

    joint: int
    requested: tuple[float, float]
    carved: tuple[float, float]
    achieved: tuple[float, float]
    stopped_by: tuple[str, str]
    links_meet: tuple[float, float]

    @property
    def as_built(self) -> tuple[float, float]:
        """The joint's range on the printed arm: ``requested`` within ``achieved``."""
        return max(self.requested[0], self.achieved[0]), min(self.requested[1], self.achieved[1])

    @property
    def built_stop(self) -> tuple[str, str]:
        """What ends ``as_built`` each way: ``stopped_by``, or the request where narrower."""
        lo = "the request" if self.requested[0] > self.achieved[0] else self.stopped_by[0]
        hi = "the request" if self.requested[1] < self.achieved[1] else self.stopped_by[1]
        return lo, hi

    def to_dict(self) -> dict:
        """JSON-ready, in degrees."""
        return {
            "joint": self.joint,
            "requested_deg": [math.degrees(v) for v in self.requested],
            "carved_deg": [math.degrees(v) for v in self.carved],
            "achieved_deg": [math.degrees(v) for v in self.achieved],
            "as_built_deg": [math.degrees(v) for v in self.as_built],
            "links_meet_deg": [math.degrees(v) for v in self.links_meet],
            "stopped_by": {"lower": self.stopped_by[0], "upper": self.stopped_by[1]},
        }


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class CarveResult:
    """Carved links l0..l6 and the joint reports of joints 1..6."""

    design: ArmDesign
    links: tuple[CarvedLink, ...]
    joints: tuple[JointReport, ...]
    resolution: float

    @property
    def as_built(self) -> ArmDesign:
        """The design with its joint limits narrowed to what the carved links allow.

        Equal to ``design`` when every requested range fits the printed parts (the default
        arm); what the URDF, the MuJoCo model, the tendons, the handle, the sizing and the
        workspace map of a build describe.
        """
        return self.design.limited_to([j.achieved for j in self.joints])

    @functools.cached_property
    def printed(self) -> tuple[LinkSplit, ...]:
        """How each link prints, l0..l6: ``handarm.carve.split.split_links`` (on first use).

        A tuple of ``LinkSplit``: each link's cuts, printed parts in their print poses and
        the fasteners joining them.
        """
        # split reads carving (sections, holes): imported here, not at the top
        from handarm.carve.split import split_links

        return split_links(self)


def check_carvable(design: ArmDesign) -> None:
    """Raise ValueError naming the field when the design cannot be carved.

    Joint limits are requests: a range the links cannot survive (up to +-180 degrees) is
    carved to the largest healthy range, and the joint reports say so.
    """
    check_design(design)
    # hub and beam sizes against link lengths are checked when the design loads


def _to_link(blank: LinkBlank, part: Part) -> Manifold:
    return prism(part.polygon, part.z0, part.z1).transform(
        _affine(frame_to_link(blank, part.frame))
    )


def _blank_solid(blank: LinkBlank) -> Manifold:
    solid = Manifold.batch_boolean([_to_link(blank, p) for p in blank.parts], OpType.Add)
    return solid - _holes(blank)


#: mm: how far round the thin walls a link's knife edges are opened away (the box grows to
#: take in thin walls the opening itself leaves at the box's faces), and how many times.
_OPEN_MARGIN, _OPEN_ROUNDS = 2.0, 4
#: mm: the widest spread of thin walls opened. Knife edges are local (l3's spread over 3-8
#: mm); thin walls spread wider (cheeks, or a bore wall, thinner than min_wall by design:
#: 14.5 mm round the widest axle's) are the design's and are reported, not opened (a
#: Minkowski sum that large takes minutes).
_OPEN_MAX = 10.0
#: Segments round the ball the opening rolls (manifold3d's sphere), and the turns (degrees
#: about x, y and z) tried where its facets leave a mesh that does not close as an STL (two
#: sheets touching at a point, an edge shorter than float32 resolves).
_BALL_SEGMENTS = 16
_BALL_TURNS = ((0.0, 0.0, 0.0), (7.0, 11.0, 5.0), (13.0, 3.0, 17.0))
#: mm^3: a body this small that an opening leaves beside the link is the boolean's rounding
#: (a degenerate point of the ball's facets), not material.
_SPECK = 1e-3
#: mm: slivers booleans leave are dropped down to 0.1 um (more than float32 resolves at
#: these sizes), so that STL readers see a closed mesh.
_SLIVER = 1e-4


def opened(
    solid: Manifold, lo, hi, wall: float, keep: Manifold | None = None, turn=(0.0, 0.0, 0.0)
) -> Manifold:
    """The solid with what is thinner than ``wall`` inside the box lo..hi (mm) taken away.

    A morphological opening inside the box: what is left there is the union of the balls of
    diameter ``wall`` that fit in the solid, so every wall there is at least ``wall`` thick
    (a ray cast inwards from its surface crosses a whole ball). Rounding off a knife edge
    this way leaves no new one, where a cut with flat faces across a slanted face does. The
    ball is a polyhedron circumscribing the sphere of diameter ``wall`` (turned by ``turn``,
    degrees), so that the walls left are not a facet's depth under it. It is opened over a
    box grown by its diameter so that the box's own faces round nothing inside; ``keep``
    (where walls of exactly ``wall`` are built on purpose, e.g. the groove's roof) is never
    taken away.
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    radius = wall / 2 / math.cos(math.pi / _BALL_SEGMENTS) ** 2
    pad = 2 * radius + 0.5
    outer = Manifold.cube(hi - lo + 2 * pad).translate(lo - pad)
    inner = Manifold.cube(hi - lo).translate(lo)
    piece = solid ^ outer
    ball = Manifold.sphere(radius, _BALL_SEGMENTS).rotate(list(turn))
    eroded = piece - (outer - piece).minkowski_sum(ball)
    kept = eroded.minkowski_sum(ball) ^ inner
    if keep is not None:
        kept = kept + (solid ^ inner ^ keep)
    return (solid - inner) + kept


def _closes_as_stl(solid: Manifold) -> bool:
    """Whether the solid, written as a binary STL and read back (trimesh), is closed.

    A reader merges vertices that fall on one point in float32 and drops the faces that
    collapse: where an opening's ball leaves two sheets touching at a point, or an edge
    shorter than float32 resolves, the mesh it reads is open.
    """
    import trimesh

    from handarm.carve.properties import to_trimesh

    data = to_trimesh(solid).export(file_type="stl")
    return bool(trimesh.load(io.BytesIO(data), file_type="stl").is_watertight)


def _opened_whole(solid: Manifold, lo, hi, wall: float, keep) -> Manifold | None:
    """``opened``, slivers dropped, if that leaves one body that closes as an STL; else None."""
    for turn in _BALL_TURNS:
        result = opened(solid, lo, hi, wall, keep, turn).simplify(_SLIVER)
        bodies = [b for b in result.decompose() if b.volume() > _SPECK]
        if len(bodies) == 1 and _closes_as_stl(bodies[0]):
            return bodies[0]
    return None


def _without_knife_edges(link: LinkBlank, solid: Manifold, wall: float) -> Manifold:
    """The link's solid with its walls under ``wall`` (mm) opened away (``opened``).

    As it was where the thin walls spread over more than ``_OPEN_MAX``, or no opening (four
    rounds) leaves every wall at least ``wall`` in one piece that closes as an STL: the
    link then reports its thin wall. A cable corridor that leaves a face at a slant leaves
    a knife edge (l3's twist leaving its fork's bridge on a short l3, or passing just under
    joint 4's plate edge), and so may a neighbour's sweep past a corridor. The box opened
    round the thin walls grows until the walls it leaves at its faces are inside it too.
    The tongue, whose groove's roof stands ``min_wall`` under its face by design, is kept
    whole. The walls are measured as the link reports measure them
    (``properties.wall_samples``), on the solid returned.
    """
    from handarm.carve.properties import wall_samples

    pts, dist = wall_samples(solid)
    thin = pts[dist < wall]
    if not len(thin) or float(np.max(thin.max(axis=0) - thin.min(axis=0))) > _OPEN_MAX:
        return solid
    tongue = [_to_link(link, p) for p in link.parts if p.name.startswith("tongue")]
    keep = Manifold.batch_boolean(tongue, OpType.Add) if tongue else None
    lo, hi = thin.min(axis=0) - _OPEN_MARGIN, thin.max(axis=0) + _OPEN_MARGIN
    for _ in range(_OPEN_ROUNDS):
        result = _opened_whole(solid, lo, hi, wall, keep)
        if result is None:  # broken, or pinched with every turn of the ball: a larger box
            lo, hi = lo - _OPEN_MARGIN, hi + _OPEN_MARGIN
            continue
        pts, dist = wall_samples(result)
        thin = pts[dist < wall]
        if not len(thin):
            return result
        lo = np.minimum(lo, thin.min(axis=0) - _OPEN_MARGIN)
        hi = np.maximum(hi, thin.max(axis=0) + _OPEN_MARGIN)
    return solid


def _cylinder(start, end, radius: float, segments: int = 32, turn: float = 0.0) -> Manifold:
    """A cylinder of ``radius`` on the axis from ``start`` to ``end`` (same frame).

    Its polygon's vertices sit at ``turn`` + k 360 / segments degrees about the axis.
    """
    start, end = np.asarray(start, float), np.asarray(end, float)
    axis = end - start
    length = float(np.linalg.norm(axis))
    cyl = Manifold.cylinder(length, radius, radius, segments)
    if turn:
        cyl = cyl.rotate([0.0, 0.0, turn])
    # rotate z onto the axis, then place it
    z = axis / length
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(ref, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, :3] = np.column_stack([x, y, z])
    m[:3, 3] = start
    return cyl.transform(_affine(m))


def _lengthened(a, b, by: float) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.asarray(a, float), np.asarray(b, float)
    u = (b - a) / np.linalg.norm(b - a)
    return a - by * u, b + by * u


def _hole(h: Hole) -> Manifold:
    """A cylindrical hole in its own frame; with a tip, its start closed by a cone."""
    cut = _cylinder(h.start, h.end, h.radius)
    if h.tip <= 0.0:
        return cut
    start = np.asarray(h.start, float)
    axis = np.asarray(h.end, float) - start
    tip = start - h.tip * axis / np.linalg.norm(axis)
    verts = np.asarray(cut.to_mesh().vert_properties)[:, :3]
    return Manifold.hull_points(np.vstack([verts, tip]))


#: Segments of a groove's turn: its bottom is the pulley radius.
_GROOVE_SEGMENTS = 128


def _groove(g: Groove) -> Manifold:
    """The groove's cut in its frame: its outline turned about the axle, or the tunnel's."""
    # the bottom circumscribed: the groove's bottom is never inside its radius
    grow = 1.0 / math.cos(math.pi / _GROOVE_SEGMENTS)

    def turned(outline: np.ndarray) -> Manifold:
        pts = np.array(outline, dtype=float)
        pts[pts[:, 0] <= pts[:, 0].min(), 0] *= grow
        x, z = pts[:, 0], pts[:, 1]
        if np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z) < 0:  # counter-clockwise
            pts = pts[::-1]
        return Manifold.revolve(CrossSection([pts]), _GROOVE_SEGMENTS)

    ring, tunnel = turned(g.profile), turned(g.tunnel)
    lo, hi = ring.bounding_box()[2] - 1.0, ring.bounding_box()[5] + 1.0
    far = float(g.profile[:, 0].max()) + 1.0
    w = g.root_half_width
    root = Manifold.cube([far, 2 * w, hi - lo]).translate([0.0, -w, lo])
    return (ring - root) + (tunnel ^ root)


def _holes(blank: LinkBlank) -> Manifold:
    cuts = [_hole(h).transform(_affine(frame_to_link(blank, h.frame))) for h in blank.holes]
    cuts += [_groove(g).transform(_affine(frame_to_link(blank, g.frame))) for g in blank.grooves]
    return Manifold.batch_boolean(cuts + _corridors(blank), OpType.Add)


def _corridors(blank: LinkBlank) -> list[Manifold]:
    """The link's cable corridors (its channels), link frame."""
    cuts = []
    for ch in blank.channels:
        # circumscribed: the corridor holds a cable of the full radius everywhere; each run
        # 0.05 mm longer at both ends, so that consecutive segments (on l3) overlap instead
        # of meeting face to face (coincident faces leave edges STL readers cannot close)
        cyls = [
            _cylinder(*_lengthened(a, b, 0.05), ch.radius / math.cos(math.pi / 24), 24)
            for a, b in ch.runs
        ]
        # runs come in groups per cable (the run, its copies pushed out): hull neighbours
        n = ch.per_cable
        cuts += [
            Manifold.batch_hull(cyls[i : i + 2 * n]) for i in range(0, max(len(cyls) - n, 1), n)
        ]
    return cuts


def _bounds_in(blank: LinkBlank, solid: Manifold, frame: str) -> np.ndarray:
    """Bounding box (2, 3) of a link solid seen in one of its joint frames."""
    m = np.linalg.inv(frame_to_link(blank, frame))
    return np.asarray(solid.transform(_affine(m)).bounding_box()).reshape(2, 3)


def _sweep_into_proximal(blanks, solids, j, lo, hi, step, grow) -> Manifold:
    """What the distal link of joint j sweeps, in the proximal link's frame."""
    within = _bounds_in(blanks[j - 1], solids[j - 1], "dist")
    return distal_sweep(blanks[j - 1], blanks[j], lo, hi, step, grow, within)


def distal_sweep(prox: LinkBlank, dist: LinkBlank, lo, hi, step, grow, within) -> Manifold:
    """What ``dist``'s parts sweep turning lo..hi about their joint, in ``prox``'s link frame.

    ``within``: the box (2, 3), in the joint's frame, that the sweep will be cut from (see
    ``sweep.sweep_parts``). Carving cuts it from the proximal link; the split keeps screw
    heads out of it.
    """
    parts = [part_in_frame(dist, part, "prox") for part in dist.parts]
    swept = sweep_parts(parts, lo, hi, step, grow, within)
    return swept.transform(_affine(frame_to_link(prox, "dist")))


def _sweep_into_distal(blanks, solids, j, lo, hi, step, grow) -> Manifold:
    """What the proximal link of joint j sweeps, seen from the distal link, in its frame."""
    p = blanks[j - 1]
    parts = [part_in_frame(p, part, "dist") for part in p.parts]
    return sweep_parts(parts, -hi, -lo, step, grow, _bounds_in(blanks[j], solids[j], "prox"))


def _healthy(blank: LinkBlank, solid: Manifold) -> bool:
    """One body, and a full wall around every axle bore."""
    if solid.is_empty() or len(solid.decompose()) != 1:
        return False
    bores = [h for h in blank.holes if h.name.startswith("axle")]
    for h in bores:
        for part in blank.parts:
            if not part.axisymmetric or part.frame != h.frame:
                continue
            ring = prism(_disk(h.radius + _BORE_WALL), part.z0, part.z1) - prism(
                _disk(h.radius), part.z0, part.z1
            )
            ring = ring.transform(_affine(frame_to_link(blank, part.frame)))
            full = ring.volume()
            if (ring ^ solid).volume() < 0.99 * full:
                return False
    return True


def _disk(r: float) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=1)


def carve(
    design: ArmDesign,
    resolution_deg: float = 1.0,
    *,
    progress: Callable[[str], None] | None = None,
) -> CarveResult:
    """Carve every link of the design and measure the joint limits the links allow.

    Parameters
    ----------
    design : ArmDesign
    resolution_deg : float
        Largest angle between consecutive poses of a sweep (degrees, 0 < r <= 10).
    progress : callable, optional
        Called with a short label after each step (6 joints' sweeps, 7 links, 6 joints'
        limits, the cable limits).

    Returns
    -------
    CarveResult
    """
    check_carvable(design)
    if not 0.0 < resolution_deg <= 10.0:
        raise ValueError(f"resolution_deg: expected 0 < r <= 10 degrees, got {resolution_deg}")
    step = math.radians(resolution_deg)
    # grown by a hair more than the clearance, and shifted by less than that hair: faces of
    # a cut that would fall exactly on a blank's edge (touching, not crossing) fall beside
    # it, which keeps every carved mesh closed once written as float32 STL
    grow = design.clearance * MM + 2 * _JITTER_MM
    tick = progress or (lambda label: None)
    blanks = [link_blank(design, k) for k in range(7)]
    wall = design.min_wall * MM
    solids = [_without_knife_edges(b, _blank_solid(b), wall) for b in blanks]
    floors = [_wall_floor(design, solid) for solid in solids]  # each link's, measured once
    carve_limits = []
    cut_prox: list[Manifold | None] = [None] * 7  # cut made by the joint at the link's prox end
    cut_dist: list[Manifold | None] = [None] * 7
    # what each link loses to its distal neighbour held still: the least joint k + 1 takes
    rest: list[Manifold | None] = [
        _sweep_into_proximal(blanks, solids, k + 1, 0.0, 0.0, step, grow) if 1 <= k < 6 else None
        for k in range(7)
    ]
    for j in range(1, 7):
        lo, hi = design.joint_limits[j - 1]
        around = (cut_prox[j - 1], rest[j])
        lo, hi, sp, sd = _largest_healthy_range(
            blanks, solids, j, lo, hi, step, grow, around, design, floors[j - 1 : j + 1]
        )
        carve_limits.append((lo, hi))
        cut_dist[j - 1], cut_prox[j] = sp, sd
        tick(f"joint {j} sweeps")
    links = []
    for k in range(7):
        cuts = [c for c in (cut_prox[k], cut_dist[k]) if c is not None]
        solid = solids[k]
        if cuts:
            solid = solid - Manifold.batch_boolean(cuts, OpType.Add).translate(_JITTER)
        solid = solid.simplify(_SLIVER)
        if floors[k] >= wall:
            # a sweep that passes a corridor may leave a sliver the range search's rays
            # missed: opened away as the blank's own were
            solid = _without_knife_edges(blanks[k], solid, wall)
        links.append(CarvedLink(blanks[k], solid))
        tick(f"link l{k} carved")
    meet = []
    for j in range(1, 7):
        meet.append(_links_meet(design, links, j, carve_limits[j - 1]))
        tick(f"joint {j} limits")
    # the cables may stop a joint before its links meet (tendons reads carving: import here)
    from handarm.tendons import cable_limits

    # where carving narrowed a request, the joint stops where carving did: past it the links
    # pass closer than the print clearance (they were not carved for it)
    ranges, why = [], []
    for (angles, stops), carved, asked in zip(meet, carve_limits, design.joint_limits, strict=True):
        lo = carved[0] if carved[0] > asked[0] else angles[0]
        hi = carved[1] if carved[1] < asked[1] else angles[1]
        ranges.append((lo, hi))
        why.append(
            tuple(
                _CARVING_STOP if narrowed else stop
                for stop, narrowed in zip(stops, (lo != angles[0], hi != angles[1]), strict=True)
            )
        )
    cables = cable_limits(design, links, ranges)
    tick("cable limits")
    joints = []
    for j, ((angles, _), stops, clear) in enumerate(zip(meet, why, cables, strict=True), start=1):
        stops = tuple(c or s for c, s in zip(clear["stopped_by"], stops, strict=True))
        joints.append(
            JointReport(
                j,
                design.joint_limits[j - 1],
                carve_limits[j - 1],
                clear["limits"],
                stops,
                angles,
            )
        )
    return CarveResult(design, tuple(links), tuple(joints), resolution_deg)


def _largest_healthy_range(blanks, solids, j, lo, hi, step, grow, around, design, walls):
    """Carve joint j's range if both links survive it, else the largest scaled range that does.

    A link survives when it stays healthy (``_healthy``) and keeps no wall thinner than
    ``min_wall`` (or than its blank's own thinnest wall, if thinner): a range whose sweep
    would leave a skin is not achievable (``walls``: the two links' ``_wall_floor``). Where
    a link keeps a thinner wall than that with the joint held still, it is judged on
    keeping that wall instead (the other link still on its own floor).
    ``around``: (what joint j-1 already took from the proximal link, what the distal
    link's own distal neighbour takes held still), each or None: each link is judged with
    its other cut as well (the distal one with the least it will lose), so a link survives
    its combined cuts.
    Raises ValueError naming the joint, the link and the design field when not even the
    joint held still leaves healthy links.
    """
    prev_cut, next_rest = around
    prox = solids[j - 1] if prev_cut is None else solids[j - 1] - prev_cut
    dist = solids[j] if next_rest is None else solids[j] - next_rest
    carved = (lambda sp: prox - sp, lambda sd: dist - sd)

    def cuts(f):
        sp = _sweep_into_proximal(blanks, solids, j, lo * f, hi * f, step, grow)
        sd = _sweep_into_distal(blanks, solids, j, lo * f, hi * f, step, grow)
        return sp, sd

    def healthy(sp, sd):
        return _healthy(blanks[j - 1], carved[0](sp)) and _healthy(blanks[j], carved[1](sd))

    def walls_kept(sp, sd, floors):
        return all(
            _thinnest(c(cut)) >= w for c, cut, w in zip(carved, (sp, sd), floors, strict=True)
        )

    sp, sd = cuts(1.0)
    if healthy(sp, sd) and walls_kept(sp, sd, walls):
        return lo, hi, sp, sd
    best = cuts(0.0)
    if not healthy(*best):
        k = 0 if not _healthy(blanks[j - 1], carved[0](best[0])) else 1
        blank, solid = blanks[j - 1 + k], carved[k](best[k])
        split = solid.is_empty() or len(solid.decompose()) != 1
        both = k == 1 and next_rest is not None and _healthy(blank, solids[j] - best[1])
        raise ValueError(
            f"{_culprit(design, split)}: joint{f's {j} and {j + 1}' if both else f' {j}'}"
            f" leave{'' if both else 's'} link {blank.name} "
            f"{'in pieces' if split else 'without its bore wall'} even held still; "
            "no printable range exists"
        )
    # a wall the neighbour leaves thin even with the joint held still is the blanks' shape,
    # not the range's: that link's range is judged on keeping that wall (the link's report
    # says where its walls are thin), the other's on min_wall
    held = [_thinnest(c(cut)) for c, cut in zip(carved, best, strict=True)]
    floors = [w if t >= w else t - _WALL_TOL for t, w in zip(held, walls, strict=True)]

    def ok(sp, sd):
        return healthy(sp, sd) and walls_kept(sp, sd, floors)

    if floors != walls and ok(sp, sd):
        return lo, hi, sp, sd
    good, bad = 0.0, 1.0
    for _ in range(10):
        mid = 0.5 * (good + bad)
        trial = cuts(mid)
        if ok(*trial):
            good, best = mid, trial
        else:
            bad = mid
    return lo * good, hi * good, best[0], best[1]


#: What ends a joint's range where carving narrowed the request (``_largest_healthy_range``).
_CARVING_STOP = "carving (a wider range breaks a link or leaves a wall under min_wall)"

#: Walls thinner than the blank's own by more than this (mm) are a cut's (measuring the same
#: wall on two meshes differs by a few micrometres).
_WALL_TOL = 0.01


def _thinnest(solid: Manifold) -> float:
    """Thinnest wall of a solid (mm): ``properties.wall_samples``, as the link reports use."""
    from handarm.carve.properties import wall_samples

    _, dist = wall_samples(solid)
    return float(dist.min()) if len(dist) else math.inf


def _wall_floor(design: ArmDesign, blank: Manifold) -> float:
    """The thinnest wall (mm) carving may leave in a link: ``min_wall``, or the blank's own.

    ``min_wall`` itself, not a hair under it, where the blank keeps it (to within the
    measuring tolerance: the groove's roof, ``min_wall`` under the tongue's face by design,
    measures 1.201 mm): the link reports measure the carved link the same way and call
    anything thinner a miss. A blank's own thinner wall, less that tolerance, otherwise.
    """
    wall, thinnest = design.min_wall * MM, _thinnest(blank)
    return wall if thinnest >= wall - _WALL_TOL else thinnest - _WALL_TOL


def _culprit(design: ArmDesign, split: bool) -> str:
    """The design field most likely to make a carved link unhealthy."""
    if not split:
        return "axle_diameter"
    if 4 * design.hub_radius > min(design.link_lengths):
        return "hub_radius"
    return "clearance"


def _in_joint_frame(link: CarvedLink, which: str) -> Manifold:
    """The carved link expressed in the frame of its proximal or distal joint."""
    m = np.linalg.inv(frame_to_link(link.blank, which))
    return link.solid.transform(_affine(m))


def _touch(prox: Manifold, dist: Manifold, angle: float) -> float:
    return (prox ^ dist.rotate([0.0, 0.0, math.degrees(angle)])).volume()


def _contact_angle(prox: Manifold, dist: Manifold, start: float, sign: float) -> float:
    """First angle beyond ``start`` (towards ``sign``) where the links meet; pi if never."""
    coarse = math.radians(2.0)
    free = start
    while True:
        nxt = free + sign * coarse
        if abs(nxt) >= math.pi:
            if _touch(prox, dist, sign * math.pi) <= _CONTACT_VOLUME:
                return sign * math.pi
            nxt = sign * math.pi
        if _touch(prox, dist, nxt) > _CONTACT_VOLUME:
            hit = nxt
            break
        free = nxt
    while abs(hit - free) > _LIMIT_TOL:
        mid = 0.5 * (hit + free)
        if _touch(prox, dist, mid) > _CONTACT_VOLUME:
            hit = mid
        else:
            free = mid
    return free


def _blocking_features(links, j, prox, dist, angle) -> str:
    """Which parts of the two links meet just past ``angle``."""
    rot = dist.rotate([0.0, 0.0, math.degrees(angle)])
    contact = prox ^ rot
    p_link, d_link = links[j - 1], links[j]
    names = []
    for link, frame_name in ((d_link, "prox"), (p_link, "dist")):
        to_joint = _affine(np.linalg.inv(frame_to_link(link.blank, frame_name)))
        found = []
        for part in link.blank.parts:
            solid = _to_link(link.blank, part).transform(to_joint)
            if link is d_link:
                solid = solid.rotate([0.0, 0.0, math.degrees(angle)])
            if (solid ^ contact).volume() > _CONTACT_VOLUME:
                # "fork plate + at joint 2" and "fork plate - ..." are one feature to a reader
                name = part.name.replace(" + ", " ").replace(" - ", " ")
                if name not in found:
                    found.append(name)
        names.append(f"{link.name} " + (", ".join(found) if found else "body"))
    return f"{names[0]} meets {names[1]}"


def _links_meet(design, links, j, carved) -> tuple[tuple[float, float], tuple[str, str]]:
    """Each way from the carved range, the angle before the links meet, and what meets."""
    prox = _in_joint_frame(links[j - 1], "dist")
    dist = _in_joint_frame(links[j], "prox")
    lo, hi = carved
    angles, stops = [], []
    for start, sign in ((lo, -1.0), (hi, 1.0)):
        angle = _contact_angle(prox, dist, start, sign)
        angles.append(angle)
        if abs(angle) >= math.pi:
            stops.append("nothing (full turn)")
        else:
            stops.append(_blocking_features(links, j, prox, dist, angle + sign * _LIMIT_TOL))
    return (angles[0], angles[1]), (stops[0], stops[1])
