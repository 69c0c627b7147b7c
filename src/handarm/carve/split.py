"""Printed parts: each carved link cut by planes into parts that print with little support.

A one-piece link needs support in every pose: a fork plate cantilevered above the bed, the
other one hanging under it. ``split_link`` cuts the carved link by planes into parts that
each rest on a flat face, drills the fasteners that join them, and gives every part its
print pose. The schemes, tried in this order:

``whole``
    no cut (l0 and l6 of the paper's arm print as they are);
``slabs``
    two planes square to the proximal axle just outside the tongue's faces: the lower
    plate, the middle (tongue, beam and the bridge's middle) and the upper plate, each
    printed flat; two steel pins through the fork bridge's whole stack line them up and the
    axle clamps them at the hub. Only where the link's two axles are parallel; the upper
    cut is also tried just above each upward step of the bridge (a cable corridor's floor),
    which would face down in the upper plate turned over;
``beam and fork``
    one plane square to the beam at the fork bridge's back face: the fork (bridge and both
    plates) prints standing on the bridge's back and is screwed onto the beam's end with
    one M3 screw through the bridge, located by two dowel pins.

The first scheme whose parts all meet the support target, are one body each, keep the
link's walls near the cuts and hold their fasteners with ``min_wall`` of material round
every hole and between holes is taken (among the slabs' cut levels, the one with the least
support); when none does, the best is taken and its problems are listed, as carving reports
a thin wall. Holes lying across a part's print pose (axle bores, fastener holes, the tool
bore) get a teardrop roof.

Cuts sit ``EPS`` outside the face they follow: a cut exactly on a face leaves flaps of no
thickness, and within the bed tolerance the face it follows still counts as lying on the bed.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence

import numpy as np
from manifold3d import CrossSection, Manifold, OpType

from handarm.carve.carving import (
    CarvedLink,
    CarveResult,
    _corridors,
    _cylinder,
    _lengthened,
    distal_sweep,
)
from handarm.carve.printing import bed_faces, pose_on_bed, print_orientation, support_area
from handarm.carve.properties import to_trimesh, wall_samples
from handarm.carve.sweep import _affine, frame_to_link
from handarm.links import M3_CLEAR, M3_HEAD, M3_PILOT, MM, Hole, _fork_sizes, joint_geometry

__all__ = [
    "Cut",
    "Fastener",
    "PrintedPart",
    "LinkSplit",
    "SUPPORT_TARGET",
    "EPS",
    "split_solid",
    "teardrops",
    "split_link",
    "split_links",
]

#: Support (mm^2) each printed part should stay under (issue 11).
SUPPORT_TARGET = 50.0
#: How far (mm) a cut sits outside the face it follows: more than carving's 2.4e-4 mm shift
#: of the faces, less than the 1e-3 mm within which a face still lies on the bed.
EPS = 5e-4
#: Walls within this distance (mm) of a cut are the cut's.
NEAR_CUT = 2.0
#: A teardrop's tip is this many hole radii from the axis: flanks 50 degrees from level.
TEARDROP_TIP = 1.1 * math.sqrt(2.0)
#: Fasteners as bought: pin diameters tried (largest first), ISO 8734 dowel lengths, M3
#: socket head cap screw lengths (mm).
PIN_DIAMETERS = (2.0, 1.5)
DOWEL_LENGTHS = (4, 5, 6, 8, 10, 12, 14, 16, 18, 20)
SCREW_LENGTHS = (6, 8, 10, 12, 16, 20)
#: Thread an M3 screw cuts into the beam, and length of a dowel in it (mm), at least.
SCREW_BITE, DOWEL_BITE = 6.0, 5.0
#: An M3 socket head's height (mm); its diameter is ``links.M3_HEAD``.
M3_HEAD_HEIGHT = 3.0
#: Spacing (mm) of the sections along a fastener and of the grid its position is chosen on.
_STEP = 0.25
_SLIVER = 1e-2  # mm^3: a body this small is merged into its neighbour


@dataclasses.dataclass(frozen=True)
class Cut:
    """A cutting plane in the link frame: the points x with ``normal . x = offset`` (mm)."""

    normal: tuple[float, float, float]
    offset: float
    label: str


@dataclasses.dataclass(frozen=True)
class Fastener:
    """A bought part joining printed parts, in the link frame (mm).

    It runs from ``start`` (where it goes in: under a screw's head) to ``end``; ``holes``
    are what it needs cut into the parts it ``joins``; ``wall`` is the least material left
    round those holes, to the parts' faces and to the next hole.
    """

    kind: str  # "screw", "dowel pin" (bought to length) or "pin" (cut from rod)
    size: str  # as bought
    diameter: float
    length: float
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    joins: tuple[str, ...]
    holes: tuple[Hole, ...]
    wall: float


@dataclasses.dataclass(frozen=True, eq=False)  # holds solids: identity equality
class PrintedPart:
    """One printed part of a link (link frame, mm).

    ``piece`` is the carved link's share (the pieces of a link make up the link); ``solid``
    is what is printed: the piece less its fastener holes and teardrops, printed with
    ``down`` (unit, link frame) on the bed, leaving ``support`` mm^2 to support.
    """

    name: str
    link: str
    piece: Manifold
    solid: Manifold
    down: np.ndarray
    support: float
    contact: float
    height: float
    min_wall: float
    min_wall_near_cut: float

    @functools.cached_property
    def pose(self) -> np.ndarray:
        """4x4 transform (mm) from the link frame to the part's pose on the bed."""
        return pose_on_bed(self.solid, self.down)

    @property
    def file_name(self) -> str:
        """``l1_lower_plate.stl``: the part's STL file name."""
        return self.name.replace(" ", "_") + ".stl"


@dataclasses.dataclass(frozen=True, eq=False)  # holds solids: identity equality
class LinkSplit:
    """How a carved link prints: its scheme, cuts, parts and fasteners.

    ``unsplit_down``, ``unsplit_support``: the one-piece link's best pose and the support it
    leaves (mm^2). ``problems`` says why the scheme misses the target (empty when it meets
    it).
    """

    link: CarvedLink
    scheme: str
    cuts: tuple[Cut, ...]
    parts: tuple[PrintedPart, ...]
    fasteners: tuple[Fastener, ...]
    unsplit_down: np.ndarray
    unsplit_support: float
    target: float
    problems: tuple[str, ...]

    @property
    def fastener_groups(self) -> dict[tuple[str, str], list[Fastener]]:
        """The fasteners by (kind, size), in the order they come.

        The summary, the bill of materials and the assembly guide all read them.
        """
        groups: dict[tuple[str, str], list[Fastener]] = {}
        for f in self.fasteners:
            groups.setdefault((f.kind, f.size), []).append(f)
        return groups

    @property
    def support(self) -> float:
        """The worst part's support area (mm^2)."""
        return max(p.support for p in self.parts)


# ------------------------------------------------------------------- cutting and teardrops


def split_solid(solid: Manifold, cuts: Sequence[Cut]) -> list[list[Manifold]]:
    """The bodies of a solid between parallel cuts, per slab.

    Parameters
    ----------
    solid : Manifold
    cuts : sequence of Cut
        Parallel planes (unit normals, the same or opposite).

    Returns
    -------
    list of list of Manifold
        ``len(cuts) + 1`` slabs in order of offset along the first cut's normal, each the
        list of its bodies. Bodies under ``1e-2`` mm^3 (what a cut grazing a face leaves)
        are merged into a body they touch.

    Raises
    ------
    ValueError
        If the cuts are not parallel.
    """
    if not cuts:
        return [[solid]]
    n = np.asarray(cuts[0].normal, float)
    offsets = []
    for cut in cuts:
        m = np.asarray(cut.normal, float)
        if abs(abs(float(m @ n)) - 1.0) > 1e-9:
            raise ValueError(f"cuts: {cut.label!r} is not parallel to {cuts[0].label!r}")
        offsets.append(cut.offset * float(m @ n))
    slabs = []
    rest = solid
    for offset in sorted(offsets):
        above, below = rest.split_by_plane(n.tolist(), offset)
        slabs.append(below)
        rest = above
    slabs.append(rest)
    bodies = [[b for b in s.decompose() if b.volume() > 1e-4] for s in slabs]
    for i, slab in enumerate(bodies):
        for small in [b for b in slab if b.volume() <= _SLIVER]:
            slab.remove(small)
            for j in sorted(range(len(bodies)), key=lambda j: abs(j - i)):
                hosts = [b for b in bodies[j] if b.volume() > _SLIVER]
                host = next((b for b in hosts if len((b + small).decompose()) == 1), None)
                if host is not None:
                    bodies[j][bodies[j].index(host)] = host + small
                    break
            else:
                slab.append(small)
    return bodies


def _in_link(blank, hole: Hole) -> tuple[np.ndarray, np.ndarray]:
    m = frame_to_link(blank, hole.frame)
    return (m @ [*hole.start, 1.0])[:3], (m @ [*hole.end, 1.0])[:3]


#: mm a teardrop runs past each open end of its hole (not past a blind hole's floor).
TEARDROP_OVERRUN = 0.05


def teardrops(axes, up) -> Manifold:
    """Teardrop roofs (to cut) of the round holes lying across ``up``.

    Parameters
    ----------
    axes : iterable of (start, end, radius) or (start, end, radius, blind)
        Hole axes (mm) and radii, in the frame of ``up``; holes not square to ``up`` (within
        1e-3) are left as they are. ``blind``: ``start`` is a blind hole's floor, where the
        teardrop stops (running past it would thin the wall behind the floor).
    up : array-like, shape (3,)
        The print's up direction.

    Returns
    -------
    Manifold
        Each hole grown by the hull of its circle and a line ``TEARDROP_TIP`` radii above its
        axis: flanks at 50 degrees, which print without support.
    """
    up = np.asarray(up, float) / np.linalg.norm(up)
    cuts = []
    for start, end, radius, *blind in axes:
        start, end = np.asarray(start, float), np.asarray(end, float)
        axis = (end - start) / np.linalg.norm(end - start)
        if abs(float(axis @ up)) > 1e-3:
            continue
        r = radius / math.cos(math.pi / 32)  # holds the 32-sided hole as cut
        rise = (up - (up @ axis) * axis) * TEARDROP_TIP * r
        # a hair longer than the hole at an open end, a hair short of a blind hole's floor,
        # its polygon turned half a side: an end face on the hole's own (the floor), or a
        # side edge in a plane through the axle (a fork plate's end), left edges of four
        # faces in the written STL
        start, end = _lengthened(start, end, TEARDROP_OVERRUN)
        if blind and blind[0]:
            start = start + 2 * TEARDROP_OVERRUN * axis
        cyl = _cylinder(start, end, r, 48, turn=180.0 / 48)
        verts = np.asarray(cyl.to_mesh().vert_properties)[:, :3]
        cuts.append(Manifold.hull_points(np.vstack([verts, start + rise, end + rise])))
    return Manifold.batch_boolean(cuts, OpType.Add) if cuts else Manifold()


# ------------------------------------------------------------------- sections and walls


def _plane_frame(normal) -> np.ndarray:
    """Rows u, v, n (3x3): a right-handed frame whose third axis is the unit ``normal``."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    ref = np.array([0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    if abs(n[2]) > 0.9:
        ref = np.array([1.0, 0.0, 0.0])
    u = ref - (ref @ n) * n
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(n, u), n])


def _common_section(solid: Manifold, frame: np.ndarray, lo: float, hi: float) -> CrossSection:
    """What every section of the solid between levels lo and hi along frame[2] holds (u, v)."""
    turned = solid.transform(
        _affine(np.vstack([np.column_stack([frame, np.zeros(3)]), [0, 0, 0, 1]]))
    )
    levels = [*np.arange(lo, hi, _STEP), hi]
    return CrossSection.batch_boolean([turned.slice(float(z)) for z in levels], OpType.Intersect)


def _edges(cs: CrossSection) -> np.ndarray:
    """The outline's segments, (m, 2, 2)."""
    segs = [np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in cs.to_polygons() if len(p)]
    return np.concatenate(segs) if segs else np.zeros((0, 2, 2))


def _depth(edges: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Signed distance (mm) of points (n, 2) inside the outline (> 0 inside, even-odd)."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    if len(edges) == 0:
        return np.full(len(pts), -np.inf)
    a, b = edges[:, 0], edges[:, 1]
    ab = b - a
    rel = pts[:, None, :] - a[None]
    t = np.clip(np.einsum("nmk,mk->nm", rel, ab) / np.maximum((ab**2).sum(1), 1e-18), 0, 1)
    dist = np.linalg.norm(rel - t[..., None] * ab[None], axis=2).min(axis=1)
    # even-odd: crossings of a ray towards +u
    y0, y1 = a[:, 1], b[:, 1]
    straddle = (y0[None] > pts[:, 1:2]) != (y1[None] > pts[:, 1:2])
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = a[:, 0][None] + (pts[:, 1:2] - y0[None]) * ab[:, 0][None] / (y1 - y0)[None]
    inside = (np.count_nonzero(straddle & (xc > pts[:, 0:1]), axis=1) % 2) == 1
    return np.where(inside, dist, -dist)


@dataclasses.dataclass(frozen=True, eq=False)
class _Hole2D:
    """A hole's cross-section where it passes one part.

    A circle, or a teardrop when the part prints with the hole lying down (``tip``: from
    the centre to the tip, plane coordinates).
    """

    radius: float
    tip: np.ndarray | None = None

    def flanks(self) -> np.ndarray:
        """Points (k, 2) no more than 0.1 mm apart on the teardrop's flanks (none: a circle)."""
        if self.tip is None:
            return np.zeros((0, 2))
        length = float(np.linalg.norm(self.tip))
        side = math.acos(self.radius / length)  # the flanks touch the circle here
        ahead = math.atan2(self.tip[1], self.tip[0])
        n = max(2, math.ceil(math.sqrt(length**2 - self.radius**2) / 0.1))
        pts = []
        for turn in (side, -side):
            touch = self.radius * np.array([math.cos(ahead + turn), math.sin(ahead + turn)])
            pts.append(touch + np.linspace(0, 1, n)[:, None] * (self.tip - touch))
        return np.concatenate(pts)


def _wall(edges: np.ndarray, hole: _Hole2D, centres: np.ndarray, w: float = -np.inf):
    """Least material (mm) between each centre's hole and the outline (< 0: it breaks out).

    Where the circle alone leaves less than ``w`` that is the answer (flanks unmeasured).
    """
    walls = _depth(edges, centres) - hole.radius
    flank = hole.flanks()
    more = walls >= w
    if len(flank) and more.any():
        pts = (centres[more][:, None, :] + flank[None]).reshape(-1, 2)
        walls[more] = np.minimum(walls[more], _depth(edges, pts).reshape(-1, len(flank)).min(1))
    return walls


def _gap(a: _Hole2D, ca: np.ndarray, b: _Hole2D, cb: np.ndarray) -> np.ndarray:
    """Material (mm) between hole a at centres ca (n, 2) and hole b at cb (n, 2).

    The least of the circles' gap and the gaps of each teardrop's flanks to the other's
    circle: exact for circles and for teardrops pointing the same way (whose flanks face
    each other only where their circles are nearer).
    """
    gap = np.linalg.norm(cb - ca, axis=-1) - a.radius - b.radius
    for (h, ch), (o, co) in (((a, ca), (b, cb)), ((b, cb), (a, ca))):
        flank = h.flanks()
        if len(flank):
            d = np.linalg.norm(ch[:, None, :] + flank[None] - co[:, None, :], axis=2)
            gap = np.minimum(gap, d.min(axis=1) - o.radius)
    return gap


def _grid(edges: np.ndarray, inset: float) -> np.ndarray:
    """Points of the ``_STEP`` lattice at least ``inset`` inside the outline (n, 2)."""
    if len(edges) == 0:
        return np.zeros((0, 2))
    lo = np.floor(edges.reshape(-1, 2).min(0) / _STEP) * _STEP
    hi = edges.reshape(-1, 2).max(0)
    u, v = np.meshgrid(np.arange(lo[0], hi[0], _STEP), np.arange(lo[1], hi[1], _STEP))
    pts = np.column_stack([u.ravel(), v.ravel()])
    return pts[_depth(edges, pts) >= inset]


# ------------------------------------------------------------------- one link


@dataclasses.dataclass(frozen=True, eq=False)
class _Context:
    """What every scheme of one link reads."""

    result: CarveResult
    k: int
    min_wall: float
    link_wall: float
    target: float
    unsplit: tuple[np.ndarray, float]  # the one-piece link's pose and support

    @property
    def link(self) -> CarvedLink:
        return self.result.links[self.k]

    @property
    def design(self):
        return self.result.design

    @functools.cached_property
    def slab_pins(self) -> tuple[tuple[Fastener, ...], tuple[str, ...]]:
        """``_stack_pins`` of the slab scheme: the same for every cut level, found once."""
        names = [f"{self.link.name} {n}".strip() for n in _NAMES["slabs"]]
        fasteners, trouble = _stack_pins(self, names)
        return tuple(fasteners), tuple(trouble)

    def fork(self) -> tuple[float, float]:
        """(x of the fork bridge's back face, x of its distal face), link frame (mm)."""
        a = self.design.link_lengths[self.k] * MM
        length, clear = _fork_sizes(self.design, joint_geometry(self.design, self.k + 1), a)
        return a - length, a - clear

    def bridge_span(self) -> tuple[float, float]:
        """The fork bridge's extent along the link's z (mm): the stack a pin passes."""
        blank = self.link.blank
        part = next(p for p in blank.parts if p.name.startswith("fork bridge"))
        shift = frame_to_link(blank, part.frame)[2, 3]
        return float(part.z0 + shift), float(part.z1 + shift)


def _schemes(ctx: _Context) -> list[list[tuple[str, tuple[Cut, ...]]]]:
    """Candidate schemes of link k, grouped in the order they are tried."""
    out = [[("whole", ())]]
    blank = ctx.link.blank
    if blank.dist_from_prox is None:  # l0 and l6: one joint, nothing to split off
        return out
    xb, xf = ctx.fork()
    t = joint_geometry(ctx.design, ctx.k).tongue_thickness / 2
    if np.allclose(blank.dist_from_prox[:3, :3], np.eye(3)):
        lower = Cut((0.0, 0.0, 1.0), -t - EPS, "under the tongue and beam")
        levels = [(t, "over the tongue and beam")]
        levels += [(z, "over a step in the fork bridge") for z in _bridge_steps(ctx, xb, xf, t)]
        out.append(
            [("slabs", (lower, Cut((0.0, 0.0, 1.0), z + EPS, label))) for z, label in levels]
        )
    back = Cut((1.0, 0.0, 0.0), xb - EPS, "behind the fork bridge")
    out.append([("beam and fork", (back,))])
    return out


def _bridge_steps(ctx: _Context, xb: float, xf: float, t: float) -> list[float]:
    """Levels (mm) of the fork bridge's upward faces above the tongue's face.

    Below the upper plate; with the upper cut under such a face, the upper slab turned
    over would have it facing down.
    """
    mesh = to_trimesh(ctx.link.solid)
    c, n = mesh.triangles_center, mesh.face_normals
    top = ctx.bridge_span()[1] - joint_geometry(ctx.design, ctx.k + 1).cheek
    sel = (c[:, 0] > xb) & (c[:, 0] < xf) & (n[:, 2] > 0.999) & (c[:, 2] > t + 0.01)
    sel &= c[:, 2] < top - 0.01
    return sorted({round(float(z), 4) for z in c[sel, 2]})


def _axes(ctx: _Context, fasteners) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Every round hole of the link and its fasteners: (start, end, radius), link frame."""
    blank = ctx.link.blank
    out = [(*_in_link(blank, h), h.radius) for h in blank.holes]
    out += [
        (np.array(h.start), np.array(h.end), h.radius, h.blind) for f in fasteners for h in f.holes
    ]
    return out


def _printed(ctx: _Context, name: str, piece: Manifold, fasteners, cuts) -> PrintedPart:
    """The piece drilled for its fasteners, given teardrops for its best pose, measured."""
    holes = [_cylinder(h.start, h.end, h.radius) for f in fasteners for h in f.holes]
    drilled = piece - Manifold.batch_boolean(holes, OpType.Add) if holes else piece
    axes = _axes(ctx, fasteners)

    def in_pose(down):
        solid = drilled - teardrops(axes, -down)
        return support_area(to_trimesh(solid), down), solid, down

    down, _ = print_orientation(drilled)
    best = in_pose(down)
    again, _ = print_orientation(best[1])  # teardrops may make another pose the best
    if not np.allclose(again, down, atol=1e-6):
        other = in_pose(again)
        if other[0] < best[0] - 1e-6:
            best = other
    support, solid, down = best
    mesh = to_trimesh(solid)
    contact = float(mesh.area_faces[bed_faces(mesh, down)].sum())
    height = float(np.ptp(mesh.vertices @ down))
    pts, walls = wall_samples(solid)
    near = np.zeros(len(pts), bool)
    for cut in cuts:
        near |= np.abs(pts @ np.asarray(cut.normal) - cut.offset) < NEAR_CUT
    return PrintedPart(
        name,
        ctx.link.name,
        piece,
        solid,
        np.asarray(down, float),
        float(support),
        contact,
        height,
        float(walls.min()) if len(walls) else math.inf,
        float(walls[near].min()) if near.any() else math.inf,
    )


_NAMES = {
    "whole": ("",),
    "slabs": ("lower plate", "middle", "upper plate"),
    "beam and fork": ("beam", "fork"),
}


def _candidate(ctx: _Context, scheme: str, cuts: tuple[Cut, ...]) -> LinkSplit | None:
    """The link split by ``cuts``, its fasteners placed, each part printed and measured.

    None when a cut misses the link (a slab with nothing in it).
    """
    link = ctx.link
    slabs = split_solid(link.solid, cuts)
    if not all(slabs):
        return None
    problems = []
    names = [f"{link.name} {n}".strip() for n in _NAMES[scheme]]
    pieces = []
    for name, bodies in zip(names, slabs, strict=True):
        if len(bodies) != 1:
            problems.append(f"{name}: the cuts leave it in {len(bodies)} bodies")
        pieces.append(Manifold.batch_boolean(bodies, OpType.Add) if bodies else Manifold())
    fasteners: list[Fastener] = []
    if scheme == "slabs":
        fasteners, trouble = list(ctx.slab_pins[0]), ctx.slab_pins[1]
        problems += trouble
    elif scheme == "beam and fork":
        beam_down, _ = print_orientation(pieces[0])
        fasteners, trouble = _screw_and_dowels(ctx, names, cuts[0], beam_down)
        problems += trouble
    parts = tuple(_printed(ctx, n, p, fasteners, cuts) for n, p in zip(names, pieces, strict=True))
    for part in parts:
        if part.support >= ctx.target:
            problems.append(f"{part.name}: {part.support:.1f} mm^2 to support")
        if not to_trimesh(part.solid).is_volume or len(part.solid.decompose()) != 1:
            problems.append(f"{part.name}: not one watertight body")
        if part.min_wall_near_cut < min(ctx.min_wall, ctx.link_wall) - 0.02:
            problems.append(f"{part.name}: a {part.min_wall_near_cut:.2f} mm wall at a cut")
    down, support = ctx.unsplit
    return LinkSplit(
        link, scheme, cuts, parts, tuple(fasteners), down, support, ctx.target, tuple(problems)
    )


def split_link(result: CarveResult, k: int, target: float = SUPPORT_TARGET) -> LinkSplit:
    """How link k prints: the first scheme (see the module) whose parts meet ``target``.

    Parameters
    ----------
    result : CarveResult
    k : int
        Link index, 0..6.
    target : float
        Support area (mm^2) each part should stay under.

    Returns
    -------
    LinkSplit
        When no scheme meets the target, the one with the fewest problems (then the least
        support), its ``problems`` saying what is missed.

    Raises
    ------
    ValueError
        If ``k`` is not 0..6 or ``target`` is not positive.
    """
    if not (isinstance(k, int) and 0 <= k <= 6):
        raise ValueError(f"link: expected 0..6, got {k!r}")
    if not target > 0:
        raise ValueError(f"target: expected a positive area (mm^2), got {target!r}")
    link = result.links[k]
    _, walls = link.walls
    ctx = _Context(
        result,
        k,
        result.design.min_wall * MM,
        float(walls.min()) if len(walls) else math.inf,
        target,
        link.print_orientation,
    )
    tried = []
    for family in _schemes(ctx):
        found = [c for scheme, cuts in family if (c := _candidate(ctx, scheme, cuts))]
        good = [c for c in found if not c.problems]
        if good:
            return min(good, key=lambda c: c.support)
        tried += found
    return min(tried, key=lambda c: (len(c.problems), c.support))


def split_links(result: CarveResult, target: float = SUPPORT_TARGET) -> tuple[LinkSplit, ...]:
    """``split_link`` of every link, l0..l6."""
    return tuple(split_link(result, k, target) for k in range(len(result.links)))


# ------------------------------------------------------------------- fasteners


def _stack_pins(ctx: _Context, names: list[str]) -> tuple[list[Fastener], list[str]]:
    """Two pins through the fork bridge's whole stack (all three slabs), along z.

    The pins' centres keep ``min_wall`` to every section of the bridge along their length,
    and to each other; of the pairs that do, the one farthest apart.
    """
    z0, z1 = ctx.bridge_span()
    frame = _plane_frame((0.0, 0.0, 1.0))
    edges = _edges(_common_section(ctx.link.solid, frame, z0 + 0.05, z1 - 0.05))
    w = ctx.min_wall
    for dia in PIN_DIAMETERS:
        hole = _Hole2D(dia / 2)
        pts = _grid(edges, dia / 2 + w)
        if len(pts) < 2:
            continue
        walls = _wall(edges, hole, pts)
        i, j = np.triu_indices(len(pts), 1)
        gap = _gap(hole, pts[i], hole, pts[j])
        ok = gap >= w
        if not ok.any():
            continue
        spread = np.linalg.norm(pts[i] - pts[j], axis=1)
        worst = np.minimum(np.minimum(walls[i], walls[j]), gap)
        best = np.lexsort((-worst[ok], -np.round(spread[ok], 6)))[0]
        a, b = i[ok][best], j[ok][best]
        length = math.floor(z1 - z0 - 0.4)
        out = []
        for p in (pts[a], pts[b]):
            x, y, _ = (float(v) for v in p[0] * frame[0] + p[1] * frame[1])
            hole3 = Hole("pin hole", "prox", (x, y, z0 - 1.0), (x, y, z1 + 1.0), dia / 2)
            bottom = (z0 + z1 - length) / 2  # centred in the stack
            out.append(
                Fastener(
                    "pin",
                    f"{dia:g} x {length} mm",
                    dia,
                    float(length),
                    (x, y, bottom),
                    (x, y, bottom + length),
                    tuple(names),
                    (hole3,),
                    float(worst[ok][best]),
                )
            )
        return out, []
    return [], [
        f"{ctx.link.name}: no two pins of {min(PIN_DIAMETERS):g} mm or more fit through the "
        f"fork bridge with {w:g} mm of wall"
    ]


def _head_room(ctx: _Context, frame: np.ndarray, xf: float) -> np.ndarray:
    """Outline (edges, plane coordinates) of where an M3 head's centre may not be.

    The head sits on the bridge's distal face; it keeps off the link's own material, its
    cable corridors and what the distal link sweeps over its range (grown by the head's
    radius).
    """
    blank = ctx.link.blank
    design = ctx.design
    nxt = ctx.result.links[ctx.k + 1].blank
    z0, z1 = ctx.bridge_span()
    box = np.array([[xf, -30.0, z0 - 10.0], [xf + M3_HEAD_HEIGHT + 1.0, 30.0, z1 + 10.0]])
    to_dist = np.linalg.inv(frame_to_link(blank, "dist"))
    corners = np.array(
        [[box[i, 0], box[j, 1], box[m, 2], 1.0] for i in (0, 1) for j in (0, 1) for m in (0, 1)]
    )
    local = (corners @ to_dist.T)[:, :3]
    lo, hi = ctx.result.as_built.joint_limits[ctx.k]
    step = math.radians(ctx.result.resolution)
    within = np.array([local.min(0), local.max(0)])
    swept = distal_sweep(blank, nxt, lo, hi, step, design.clearance * MM, within)
    clip = Manifold.cube((box[1] - box[0]).tolist()).translate(box[0].tolist())
    stuff = Manifold.batch_boolean([ctx.link.solid, swept, *_corridors(blank)], OpType.Add) ^ clip
    turned = stuff.transform(
        _affine(np.vstack([np.column_stack([frame, np.zeros(3)]), [0, 0, 0, 1]]))
    )
    levels = np.linspace(xf + 0.05, xf + M3_HEAD_HEIGHT + design.clearance * MM, 5)
    near = CrossSection.batch_boolean([turned.slice(float(x)) for x in levels], OpType.Add)
    return _edges(near.offset(M3_HEAD / 2, 0))


def _screw_and_dowels(
    ctx: _Context, names: list[str], cut: Cut, beam_down: np.ndarray
) -> tuple[list[Fastener], list[str]]:
    """One M3 screw through the fork bridge into the beam's end, two dowel pins beside it.

    The screw passes a clearance hole in the bridge and cuts its thread in a pilot hole in
    the beam; its head sits on the bridge's distal face, clear of the link's own material,
    its cable corridors and the distal link over its range. The dowels pass the bridge and
    sit in blind holes in the beam. Holes the beam prints lying down (``beam_down`` across
    the cut's normal) are teardrops. Of the layouts with ``min_wall`` round every hole and
    between holes, the one whose least wall is largest (then the dowels farthest apart).
    """
    beam, fork = names
    xb, xf = ctx.fork()
    c = cut.offset
    bridge = xf - c
    frame = _plane_frame(cut.normal)
    w = ctx.min_wall
    up = -np.asarray(beam_down, float)
    lying = abs(float(up @ frame[2])) < 1e-3
    tip2 = np.array([up @ frame[0], up @ frame[1]]) if lying else None
    if tip2 is not None:
        tip2 /= np.linalg.norm(tip2)
    # the cut's EPS is no length to buy
    screw_len = next((v for v in SCREW_LENGTHS if v >= bridge + SCREW_BITE - 0.01), None)
    dowel_len = next((v for v in DOWEL_LENGTHS if v >= bridge + DOWEL_BITE - 0.01), None)
    if screw_len is None or dowel_len is None:
        return [], [
            f"{ctx.link.name}: the fork's bridge is {bridge:.1f} mm long at the cut; no M3 "
            f"screw up to {SCREW_LENGTHS[-1]} mm or dowel up to {DOWEL_LENGTHS[-1]} mm "
            "reaches through it into the beam"
        ]
    pilot_depth = screw_len - bridge + 1.0
    dowel_depth = dowel_len - bridge + 0.5
    solid = ctx.link.solid
    in_fork = _edges(_common_section(solid, frame, c + 0.05, xf - 0.05))
    # min_wall past a blind hole's floor is wall too: the sections down to there must hold
    # the hole with its wall (a teardrop stops at the floor: ``teardrops``)
    in_beam = {
        d: _edges(_common_section(solid, frame, c - d - w, c - 0.05))
        for d in (pilot_depth, dowel_depth)
    }
    heads = _head_room(ctx, frame, xf)

    def kinds(r_fork: float, r_beam: float, depth: float):
        beam_hole = _Hole2D(r_beam, None if tip2 is None else tip2 * TEARDROP_TIP * r_beam)
        return [(in_fork, _Hole2D(r_fork)), (in_beam[depth], beam_hole)]

    screw = kinds(M3_CLEAR / 2, M3_PILOT / 2, pilot_depth)
    for dia in PIN_DIAMETERS:
        dowel = kinds(dia / 2, dia / 2, dowel_depth)
        layout = _three_holes(screw, dowel, heads, w)
        if layout is not None:
            break
    else:
        return [], [
            f"{ctx.link.name}: no room for an M3 screw and two dowel pins with {w:g} mm of "
            "wall where the fork meets the beam"
        ]
    (ms, md1, md2), worst = layout
    n = frame[2]

    def place(p2, r_fork, r_beam, depth, kind, size, dia, length) -> Fastener:
        p = p2[0] * frame[0] + p2[1] * frame[1] + c * n
        holes = (
            Hole(f"{kind} hole in the fork", "prox", _pt(p), _pt(p + (bridge + 1.0) * n), r_fork),
            Hole(
                f"{kind} hole in the beam",
                "prox",
                _pt(p - depth * n),
                _pt(p + 0.05 * n),
                r_beam,
                blind=True,
            ),
        )
        start = p + bridge * n  # the bridge's distal face: under the head
        return Fastener(
            kind,
            size,
            dia,
            float(length),
            _pt(start),
            _pt(start - length * n),
            (fork, beam),
            holes,
            worst,
        )

    screw = f"M3 x {screw_len} socket head"
    out = [place(ms, M3_CLEAR / 2, M3_PILOT / 2, pilot_depth, "screw", screw, 3.0, screw_len)]
    size = f"{dia:g} x {dowel_len} mm"
    for p in (md1, md2):
        out.append(place(p, dia / 2, dia / 2, dowel_depth, "dowel pin", size, dia, dowel_len))
    return out, []


def _pt(p) -> tuple[float, float, float]:
    return tuple(float(v) for v in p)


def _three_holes(screw, dowel, heads: np.ndarray, w: float):
    """Screw and two dowels: centres (plane coordinates) whose least wall is largest.

    ``screw`` and ``dowel`` are [(edges, hole), ...] per part they pass; ``heads`` the
    outline where the screw may not be. Returns ((screw, dowel, dowel), least wall), ties
    to the dowels farthest apart, or None when no layout keeps ``w`` everywhere.
    """

    def walls(kind, pts):
        return np.min([_wall(edges, hole, pts, w) for edges, hole in kind], axis=0)

    def gaps(a, pa, b, pb):
        # centres lie on one lattice: measure each offset between them once
        steps, back = np.unique(
            np.round((pb - pa) / _STEP).astype(int), axis=0, return_inverse=True
        )
        offsets = steps * _STEP
        zero = np.zeros_like(offsets)
        each = [_gap(ha, zero, hb, offsets) for (_, ha), (_, hb) in zip(a, b, strict=True)]
        return np.min(each, axis=0)[back.ravel()]

    ms = _grid(screw[0][0], screw[0][1].radius + w)
    if len(ms) and len(heads):
        ms = ms[_depth(heads, ms) < 0]
    md = _grid(dowel[0][0], dowel[0][1].radius + w)
    if len(ms) == 0 or len(md) < 2:
        return None
    wm, wd = walls(screw, ms), walls(dowel, md)
    ms, wm = ms[wm >= w], wm[wm >= w]
    md, wd = md[wd >= w], wd[wd >= w]
    i, j = np.triu_indices(len(md), 1)
    pair = np.minimum(np.minimum(wd[i], wd[j]), gaps(dowel, md[i], dowel, md[j]))
    # pairs best first; a screw can do no better than its own wall or a pair's
    order = np.argsort(-pair, kind="stable")
    i, j, pair = i[order], j[order], np.round(pair[order], 3)
    spread = np.linalg.norm(md[i] - md[j], axis=1)
    si, di = np.meshgrid(np.arange(len(ms)), np.arange(len(md)), indexing="ij")
    to_dowel = gaps(screw, ms[si.ravel()], dowel, md[di.ravel()]).reshape(si.shape)
    best = None
    for s in np.argsort(-wm, kind="stable"):
        floor = w if best is None else best[0]
        if round(float(wm[s]), 3) < floor:
            break
        n = int(np.searchsorted(-pair, -floor, side="right"))
        if n == 0:
            break
        g = to_dowel[s]
        score = np.round(np.minimum(np.minimum(pair[:n], wm[s]), np.minimum(g[i[:n]], g[j[:n]])), 3)
        ties = np.flatnonzero(score == score.max())
        top = int(ties[np.argmax(spread[ties])])
        key = (float(score[top]), float(spread[top]))
        if key[0] >= w and (best is None or key > best[:2]):
            best = (*key, (ms[s], md[i[top]], md[j[top]]))
    if best is None:
        return None
    return best[2], best[0]
