"""The printed-link collision model: conservative envelopes of the links the build prints.

Every link is described once, by the convex prism Parts of ``handarm.links``. Each Part is
covered by a *slab stadium*: a segment in the plane of its joint frame grown by a radius (a
stadium, which contains the Part's polygon) times the Part's range along the joint axle.
Parts of one link in one frame are merged where the merged cover is no larger than the two
covers it replaces. Carving only removes material from the Parts, so the envelope of a link
contains its carved mesh (a test checks this against the meshes of several designs).

Links l0-l2 and the proximal part of l3 lie in the base plane (their axles are vertical);
the distal part of l3 (its fork at joint 4) and l4-l6 lie in the tip plane, which contains
l3's line L and the vertical. Two pieces in the same plane collide when their segments come
closer than the sum of their radii and the clearance, and their slabs overlap. A base piece
and a tip piece collide when, along L, the stretch of the base piece inside the tip piece's
slab overlaps the stretch of the tip piece inside the base piece's slab (each stretch is
grown by its radius, so the test contains the true intersection of the two solids).

``is_valid(design, q)`` uses this model when ``design.collision_model == "printed"`` (the
default); ``"paper"`` keeps the paper's zero-thickness segments. All 15 non-adjacent link
pairs are checked; adjacent pairs are governed by the joint limits, which carving makes
collision-free.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math

import numpy as np

from handarm.design import ArmDesign
from handarm.links import link_blank

__all__ = [
    "LINK_PAIRS",
    "Envelopes",
    "Piece",
    "collision_free",
    "envelopes",
    "printed_collisions",
    "stadium_cover",
]

#: The 15 non-adjacent link pairs, (a, b) with a < b; index into ``colliding_pairs``' output.
LINK_PAIRS = tuple((a, b) for a, b in itertools.combinations(range(7), 2) if b - a > 1)

BASE, TIP = 0, 1
#: Merge two pieces of one frame when the merged cover is at most this times the larger.
_MERGE = 1.1
_MM = 1e-3
#: Batches smaller than this are checked on the calling thread (the parallel kernels' thread
#: pool costs tens of milliseconds to wake on a busy machine).
_PARALLEL_FROM = 2048


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class Piece:
    """One slab stadium of a link's envelope (SI units).

    Attributes
    ----------
    link : int
        Link index 0..6.
    frame : int
        0: the link's proximal joint frame (the base frame for l0); 1: its distal joint frame.
    plane : int
        0: base plane (axle vertical), 1: tip plane.
    segment : ndarray, shape (2, 2)
        Segment endpoints in the frame's x, y (m).
    radius : float
        Stadium radius (m).
    z : tuple of float
        Slab range along the frame's z axis, the joint axle (m).
    parts : tuple of str
        Names of the link Parts this piece covers.
    """

    link: int
    frame: int
    plane: int
    segment: np.ndarray
    radius: float
    z: tuple[float, float]
    parts: tuple[str, ...]

    @property
    def area(self) -> float:
        """Area of the stadium (m^2): the piece's footprint in its plane."""
        length = float(np.linalg.norm(self.segment[1] - self.segment[0]))
        return 2.0 * self.radius * length + math.pi * self.radius**2

    @property
    def volume(self) -> float:
        """Volume of the slab stadium (m^3)."""
        length = float(np.linalg.norm(self.segment[1] - self.segment[0]))
        area = 2.0 * self.radius * length + math.pi * self.radius**2
        return area * (self.z[1] - self.z[0])


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class Envelopes:
    """The envelope pieces of a design's seven links, with the arrays the kernels read.

    Attributes
    ----------
    pieces : tuple of Piece
    link, frame, plane : ndarray of int, shape (n,)
    seg : ndarray, shape (n, 4)
        x0, y0, x1, y1 of each piece's segment in its frame (m).
    radius : ndarray, shape (n,)
    z : ndarray, shape (n, 2)
    sphere : ndarray, shape (n,)
        Radius of each piece's bounding sphere, centred on the middle of its segment and
        slab.
    rows : ndarray of int, shape (m, 2)
        Every piece pair that can collide: pieces of non-adjacent links, except pieces in one
        plane whose slabs are farther apart than the clearance; grouped by ``groups``.
    groups : ndarray of int, shape (g, 4)
        Per group: two bounding pieces (each contains every piece of one side of a link, a
        side being the pieces of one joint frame; a side of one piece is its own bounding
        piece) and the range of ``rows`` pairing pieces of those two sides. A group whose
        bounding pieces are apart is apart; a group with an empty range is the one pair of
        its bounding pieces.
    lp_groups : ndarray of int, shape (15, 2)
        The range of ``groups`` of each link pair of ``LINK_PAIRS``.
    pieces_count : int
        Pieces ``0 .. pieces_count - 1`` are the envelope; the rest are bounding pieces.
    clearance : float
        The design's clearance (m), added to every test.
    pi, pf : ndarray
        The same packed for the kernels: (n, 4) link, frame, plane, slides along its segment
        (an l3 piece along L); (n, 8) segment, radius, z, sphere radius.
    """

    pieces: tuple[Piece, ...]
    link: np.ndarray
    frame: np.ndarray
    plane: np.ndarray
    seg: np.ndarray
    radius: np.ndarray
    z: np.ndarray
    sphere: np.ndarray
    rows: np.ndarray
    groups: np.ndarray
    lp_groups: np.ndarray
    pieces_count: int
    clearance: float
    pi: np.ndarray
    pf: np.ndarray


def _plane(link: int, frame: int) -> int:
    return BASE if link <= 2 or (link == 3 and frame == 0) else TIP


def _dist_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(points)) if den == 0.0 else np.clip((points - a) @ ab / den, 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def stadium_cover(points) -> tuple[np.ndarray, float]:
    """A stadium (segment grown by a radius) containing the points, of small area.

    Parameters
    ----------
    points : array-like, shape (n, 2)
        Vertices of a convex polygon (any unit).

    Returns
    -------
    segment : ndarray, shape (2, 2)
    radius : float
        Every point lies within ``radius`` of the segment (so the polygon does).

    Notes
    -----
    Points that all lie about as far from their centre (a disk's polygon) get a point and
    that distance. Otherwise the candidate axes are the principal axis and the four longest
    edges; along each, the segment runs across the middle of the polygon and its ends are
    found by a grid search refined three times. A rectangle gets a segment on its long
    middle line.
    """
    from handarm._collide import stadium  # numba: compiled on first use, not at import

    x0, y0, x1, y1, r = stadium(np.ascontiguousarray(points, dtype=float))
    return np.array([[x0, y0], [x1, y1]]), r


def _piece(link, frame, verts, z, names) -> tuple[Piece, np.ndarray]:
    seg, r = stadium_cover(verts)
    piece = Piece(
        link, frame, _plane(link, frame), seg * _MM, r * _MM, (z[0] * _MM, z[1] * _MM), names
    )
    return piece, verts


def _link_pieces(design: ArmDesign, k: int) -> list[Piece]:
    blank = link_blank(design, k)
    todo = []
    for part in blank.parts:
        frame = 0 if (part.frame == "prox" or blank.dist_from_prox is None) else 1
        verts = np.asarray(part.polygon, dtype=float)
        piece, verts = _piece(k, frame, verts, (part.z0, part.z1), (part.name,))
        todo.append((piece, verts, piece.area))
    # merge two pieces of one frame where the merged cover is hardly larger than the larger
    # of the two (a cheek inside its plate's cover): fewer pieces, no looser envelope. Each
    # piece's area is computed once: the rounds asked for it ~90 times per link.
    tried = {}  # (parts, parts) -> merged piece: each pair is covered once, not every round
    while True:
        best = None
        for (i, (pa, va, aa)), (j, (pb, vb, ab)) in itertools.combinations(enumerate(todo), 2):
            if pa.frame != pb.frame:
                continue
            key = (pa.parts, pb.parts)
            if key not in tried:
                z = (min(pa.z[0], pb.z[0]) / _MM, max(pa.z[1], pb.z[1]) / _MM)
                piece, verts = _piece(k, pa.frame, np.vstack([va, vb]), z, pa.parts + pb.parts)
                tried[key] = (piece, verts, piece.area)
            merged = tried[key]
            ratio = merged[2] / max(aa, ab)
            if ratio <= _MERGE and (best is None or ratio < best[0]):
                best = (ratio, i, j, merged)
        if best is None:
            break
        _, i, j, merged = best
        todo = [t for n, t in enumerate(todo) if n not in (i, j)] + [merged]
    return [p for p, _, _ in todo]


@functools.lru_cache(maxsize=64)
def envelopes(design: ArmDesign) -> Envelopes:
    """The envelope pieces of the design's links (cached per design).

    Parameters
    ----------
    design : ArmDesign

    Returns
    -------
    Envelopes
    """
    pieces = [p for k in range(7) for p in _link_pieces(design, k)]
    n = len(pieces)
    sides = sorted({(p.link, p.frame) for p in pieces})
    members = {
        side: [i for i, p in enumerate(pieces) if (p.link, p.frame) == side] for side in sides
    }
    # a side of one piece is its own bounding piece
    bounds, bound_of = [], {}
    for side in sides:
        if len(members[side]) == 1:
            bound_of[side] = members[side][0]
        else:
            bound_of[side] = n + len(bounds)
            bounds.append(_bounding_piece([pieces[i] for i in members[side]]))
    everything = pieces + bounds
    link = np.array([p.link for p in everything], np.int64)
    frame = np.array([p.frame for p in everything], np.int64)
    plane = np.array([p.plane for p in everything], np.int64)
    seg = np.array([p.segment.reshape(-1) for p in everything], dtype=float)
    radius = np.array([p.radius for p in everything], dtype=float)
    z = np.array([p.z for p in everything], dtype=float)
    half = 0.5 * np.linalg.norm(seg[:, 2:] - seg[:, :2], axis=1)
    sphere = np.hypot(half + radius, 0.5 * (z[:, 1] - z[:, 0])) * (1.0 + 1e-12)
    c = design.clearance
    rows, groups, lp_groups = [], [], []
    for la, lb in LINK_PAIRS:
        first = len(groups)
        for sa, sb in itertools.product(sides, sides):
            if sa[0] != la or sb[0] != lb:
                continue
            start = len(rows)
            for i in range(n):
                if (pieces[i].link, pieces[i].frame) != sa:
                    continue
                for j in range(n):
                    if (pieces[j].link, pieces[j].frame) != sb:
                        continue
                    if plane[i] == plane[j] and (z[i, 0] - z[j, 1] >= c or z[j, 0] - z[i, 1] >= c):
                        continue  # parallel slabs that never come within the clearance
                    rows.append((i, j))
            if len(rows) == start:
                continue
            if len(rows) == start + 1 and len(members[sa]) == len(members[sb]) == 1:
                rows.pop()  # one pair of one-piece sides: the group is that pair
            groups.append((bound_of[sa], bound_of[sb], start, len(rows)))
        lp_groups.append((first, len(groups)))
    arrays = [link, frame, plane, seg, radius, z, sphere]
    arrays += [np.array(x, np.int64).reshape(-1, w) for x, w in ((rows, 2), (groups, 4))]
    arrays.append(np.array(lp_groups, np.int64))
    if len(groups) > 63:  # the IK keeps the unsure groups of a stretch in one int64 mask
        raise ValueError(f"design: {len(groups)} groups of envelope pieces, at most 63 supported")
    for arr in arrays:
        arr.flags.writeable = False
    # l3 only slides along L, its frames' x axis: a piece whose segment runs along x sweeps
    # exactly its segment lengthened by the slide (``handarm._collide._swept``)
    slides = (link == 3) & (np.abs(seg[:, 3] - seg[:, 1]) <= 1e-12)
    pi = np.ascontiguousarray(np.stack([link, frame, plane, slides.astype(np.int64)], axis=1))
    pf = np.ascontiguousarray(np.column_stack([seg, radius, z, sphere]))
    for arr in (pi, pf):
        arr.flags.writeable = False
    return Envelopes(tuple(pieces), *arrays, n, c, pi, pf)


def _bounding_piece(side: list[Piece]) -> Piece:
    """One slab stadium containing every piece of one side (one frame) of a link."""
    ends = np.concatenate([p.segment for p in side])
    seg, _ = stadium_cover(ends)
    r = max(float(_dist_to_segment(p.segment, seg[0], seg[1]).max()) + p.radius for p in side)
    z = (min(p.z[0] for p in side), max(p.z[1] for p in side))
    first = side[0]
    return Piece(first.link, first.frame, first.plane, seg, r * (1 + 1e-12), z, ("bound",))


def kernel_env(design: ArmDesign) -> tuple:
    """The envelopes as the numba kernels take them: (pi, pf, groups, lp_groups, rows, c)."""
    env = envelopes(design)
    return (env.pi, env.pf, env.groups, env.lp_groups, env.rows, env.clearance)


def collision_free(design: ArmDesign, q) -> np.ndarray:
    """Whether no two printed links collide, shape (...,) bool (joint limits not checked).

    Parameters
    ----------
    design : ArmDesign
    q : array-like, shape (..., 6)
        Joint angles (rad).

    Returns
    -------
    ndarray of bool, shape (...,)
        False where the envelopes of a non-adjacent link pair come within the clearance.
    """
    from handarm import _collide  # numba: compiled on first use, not at import

    q = np.asarray(q, dtype=float)
    flat = np.ascontiguousarray(q.reshape(-1, 6))
    out = np.empty(len(flat), np.bool_)
    pi, pf, groups, _, rows, c = kernel_env(design)
    if len(flat) < _PARALLEL_FROM:  # waking the thread pool costs more than a few poses
        _collide.free_rows(flat, design.lengths, pi, pf, groups, rows, c, out, 0, len(flat))
    else:
        _collide.free_many(flat, design.lengths, pi, pf, groups, rows, c, out)
    return out.reshape(q.shape[:-1])


def printed_collisions(design: ArmDesign, q) -> np.ndarray:
    """Which of the 15 non-adjacent link pairs (``LINK_PAIRS``) collide, shape (..., 15) bool."""
    from handarm import _collide

    q = np.asarray(q, dtype=float)
    flat = np.ascontiguousarray(q.reshape(-1, 6))
    out = np.empty((len(flat), 15), np.bool_)
    if len(flat) < _PARALLEL_FROM:
        _collide.colliding_rows(flat, design.lengths, *kernel_env(design), out, 0, len(flat))
    else:
        _collide.colliding_many(flat, design.lengths, *kernel_env(design), out)
    return out.reshape(q.shape[:-1] + (15,))


@functools.lru_cache(maxsize=64)
def kernel_far(design: ArmDesign) -> np.ndarray:
    """``far_thresholds`` of the design, cached and read-only, as the kernels take them."""
    far = far_thresholds(design)
    far.flags.writeable = False
    return far


def link_reach(design: ArmDesign, env: Envelopes | None = None) -> dict[int, float]:
    """How far the envelope of l0, l1, l2 reaches from joint 1, and of l4, l5, l6 from joint 6.

    Whatever the configuration, every piece of l0, l1 or l2, bounding sphere included, lies
    within ``reach[k]`` of joint 1, and every piece of l4, l5 or l6 within ``reach[k]`` of
    joint 6: l0 is fixed to joint 1, l1 turns about it, l2 about joint 2 (at ``a1`` from
    joint 1); l6 is fixed to joint 6, l5 turns about it, l4 about joint 5 (at ``a5`` from
    joint 6).

    Parameters
    ----------
    design : ArmDesign
    env : Envelopes, optional

    Returns
    -------
    dict
        Link index (0, 1, 2, 4, 5, 6) -> metres.
    """
    env = envelopes(design) if env is None else env
    a = design.lengths
    # per side (link, frame): where the joint it turns about sits in the side's frame, and
    # that joint's distance from joint 1 or 6
    anchor = {
        (0, 0): (0.0, 0.0),
        (1, 0): (0.0, 0.0),
        (1, 1): (-a[1], 0.0),
        (2, 0): (0.0, a[1]),
        (2, 1): (-a[2], a[1]),
        (4, 0): (a[4], a[5]),
        (4, 1): (0.0, a[5]),
        (5, 0): (a[5], 0.0),
        (5, 1): (0.0, 0.0),
        (6, 0): (0.0, 0.0),
    }
    mid = 0.5 * (env.seg[:, :2] + env.seg[:, 2:])
    reach: dict[int, float] = {}
    for i in range(len(env.link)):
        side = (int(env.link[i]), int(env.frame[i]))
        if side not in anchor:
            continue
        ax, offset = anchor[side]
        centre = np.array([mid[i, 0] - ax, mid[i, 1], env.z[i].mean()])
        r = float(np.linalg.norm(centre)) + float(env.sphere[i]) + offset
        reach[side[0]] = max(reach.get(side[0], 0.0), float(r) * (1.0 + 1e-12))
    return reach


def far_thresholds(design: ArmDesign, env: Envelopes | None = None) -> np.ndarray:
    """Per group, a distance of joint 6 from joint 1 beyond which the group never meets.

    For a group between l0..l2 and l4..l6: the two links' ``link_reach`` and the clearance.
    Joint 6 is fixed by the target (p - a6 e), so when it lies farther from joint 1 than
    that, every piece pair of the group has its bounding spheres apart at every
    configuration, and the IK need not test the group on any branch.

    Parameters
    ----------
    design : ArmDesign
    env : Envelopes, optional

    Returns
    -------
    ndarray, shape (g,)
        Metres; inf for the other groups.
    """
    env = envelopes(design) if env is None else env
    reach = link_reach(design, env)
    far = np.full(len(env.groups), np.inf)
    for g, (bi, bj, _, _) in enumerate(env.groups):
        la, lb = int(env.link[bi]), int(env.link[bj])
        if la <= 2 and lb >= 4:
            far[g] = (reach[la] + reach[lb] + env.clearance) * (1.0 + 1e-12)
    return far


@functools.lru_cache(maxsize=64)
def kernel_coefficients(design: ArmDesign) -> np.ndarray:
    """``motion_coefficients`` of the design, cached and read-only, as the kernels take them."""
    coef = motion_coefficients(design)
    coef.flags.writeable = False
    return coef


def motion_coefficients(design: ArmDesign, env: Envelopes | None = None) -> np.ndarray:
    """How far each piece can move, as coefficients of the chain's motion, shape (n, 2, 5).

    Along one branch of the IK the arm moves with joint 4's coordinate u. Over a stretch of
    u, let ``du`` be half its length and ``dt1, dt2, ds4, ds5`` the largest change (from the
    stretch's middle) of the absolute angles of l1, l2 (base plane) and l4, l5 (tip plane),
    each monotone on the stretch. Every point of piece i then moves at most
    ``min(coef[i, 0] @ D, coef[i, 1] @ D)`` with ``D = (du, dt1, dt2, ds4, ds5)``: l3 slides
    along L (|d joint 3| = |d joint 4| = du), l1 and l5 turn about joints fixed in space, l2
    and l4 move with either of their joints (two bounds, the smaller holds).
    """
    env = envelopes(design) if env is None else env
    a = design.lengths
    coef = np.zeros((len(env.link), 2, 5))
    for i in range(len(env.link)):
        k, f = int(env.link[i]), int(env.frame[i])
        ends = env.seg[i].reshape(2, 2)

        def reach(offset, ends=ends):
            return float(np.linalg.norm(ends + np.asarray(offset, float), axis=1).max())

        if k == 1:
            coef[i, :, 1] = reach((0.0, 0.0)) if f == 0 else reach((a[1], 0.0))
        elif k == 2:
            if f == 0:  # origin joint 2 (on l1's arc) or joint 3 (on L)
                coef[i, 0, 1], coef[i, 0, 2] = a[1], reach((0.0, 0.0))
                coef[i, 1, 0], coef[i, 1, 2] = 1.0, reach((-a[2], 0.0))
            else:
                coef[i, 0, 0], coef[i, 0, 2] = 1.0, reach((0.0, 0.0))
                coef[i, 1, 1], coef[i, 1, 2] = a[1], reach((a[2], 0.0))
        elif k == 3:
            coef[i, :, 0] = 1.0
        elif k == 4:
            if f == 0:  # origin joint 4 (on L) or joint 5 (on l5's arc about joint 6)
                coef[i, 0, 0], coef[i, 0, 3] = 1.0, reach((0.0, 0.0))
                coef[i, 1, 4], coef[i, 1, 3] = a[5], reach((-a[4], 0.0))
            else:
                coef[i, 0, 4], coef[i, 0, 3] = a[5], reach((0.0, 0.0))
                coef[i, 1, 0], coef[i, 1, 3] = 1.0, reach((a[4], 0.0))
        elif k == 5:
            coef[i, :, 4] = reach((-a[5], 0.0)) if f == 0 else reach((0.0, 0.0))
    coef *= 1.0 + 1e-12
    return coef


#: Link pairs two links apart, whose model status depends on the two joints between them
#: alone: each gets a joint-space table (``pair_tables``). Index into ``LINK_PAIRS``.
TABLE_PAIRS = tuple(LINK_PAIRS.index((k, k + 2)) for k in range(5))
_TABLE_NODES = 1 << 19
#: The tables' finest cells (rad a side): 1.4 degrees. Finer cells decide more stretches
#: near a contact and cost more nodes to build (``pair_tables``).
TABLE_CELL = 2.0 * math.pi / 256


def pair_reach(env: Envelopes, design: ArmDesign, pieces: np.ndarray, joint: str) -> np.ndarray:
    """How far each piece reaches from its link's proximal or distal joint (m), shape (n,).

    ``joint`` is "prox" or "dist": the largest distance from that joint (a point on its
    axle) to a point of the piece: a segment end, its radius, its slab's far face.
    """
    a = design.lengths
    out = np.empty(len(pieces))
    for n, i in enumerate(pieces):
        k, frame = int(env.link[i]), int(env.frame[i])
        ends = env.seg[i].reshape(2, 2).copy()
        if joint == "prox" and frame == 1:
            ends[:, 0] += a[k]  # the distal frame lies a_k along the link's x
        elif joint == "dist" and frame == 0:
            ends[:, 0] -= a[k]
        flat = float(np.linalg.norm(ends, axis=1).max()) + float(env.radius[i])
        out[n] = math.hypot(flat, float(np.abs(env.z[i]).max()))
    return out * (1.0 + 1e-12)


def _table_coefficients(env: Envelopes, design: ArmDesign, k: int):
    """Pieces of links k and k + 2, and how far each moves per radian of joints k+1, k+2.

    The frame held still keeps every piece in its plane (``handarm._pairtable``).
    """
    a = design.lengths
    pieces = np.flatnonzero((env.link == k) | (env.link == k + 2))
    ci, cj = np.zeros(len(pieces)), np.zeros(len(pieces))
    near = env.link[pieces] == k
    if k == 1:  # l3 still: l1 turns about joint 3 (a2 away) and joint 2
        r = pair_reach(env, design, pieces[near], "dist")
        ci[near], cj[near] = r, a[2] + r
    elif k == 2:  # l3 still: l2 turns about joint 3, l4 about joint 4
        ci[near] = pair_reach(env, design, pieces[near], "dist")
        cj[~near] = pair_reach(env, design, pieces[~near], "prox")
    else:  # l_k still: l_k+2 turns about joint k + 1 (a_k+1 away) and joint k + 2
        r = pair_reach(env, design, pieces[~near], "prox")
        ci[~near], cj[~near] = a[k + 1] + r, r
    return pieces, ci, cj


@functools.lru_cache(maxsize=64)
def pair_tables(design: ArmDesign) -> tuple:
    """The joint-space tables of the five link pairs two links apart, as the kernels take them.

    Returns ``(nodes, offsets, domains)``: every table's quadtree in one int32 array
    (``handarm._pairtable``), where each starts (5,), and each one's joint rectangle (5, 4)
    in radians (the design's limits of joints k + 1 and k + 2, a hair wider). The tables
    are built once per design; a table that would need more than 2**19 nodes is one MIXED
    leaf (it proves nothing).
    """
    from handarm import _pairtable  # numba: compiled on first use, not at import

    env = envelopes(design)
    a = design.lengths
    masks = _table_masks(design)
    parts, offsets, domains = [], [], []
    total = 0
    for k in range(len(TABLE_PAIRS)):
        pieces, ci, cj = _table_coefficients(env, design, k)
        dom = np.array(
            [design.lower[k] - 1e-9, design.upper[k] + 1e-9,
             design.lower[k + 1] - 1e-9, design.upper[k + 1] + 1e-9]
        )  # fmt: skip
        nodes = _pairtable.build_table(
            k, *dom, a, pieces, ci, cj, env.pi, env.pf, env.groups, env.rows,
            int(masks[k]), env.clearance, TABLE_CELL, _TABLE_NODES,
        )  # fmt: skip
        parts.append(nodes)
        offsets.append(total)
        domains.append(dom)
        total += len(nodes)
    out = (
        np.concatenate(parts).astype(np.int32),
        np.array(offsets, np.int64),
        np.array(domains, dtype=float),
    )
    for arr in out:
        arr.flags.writeable = False
    return out


def kernel_tables(design: ArmDesign) -> tuple:
    """``pair_tables`` and each table's groups as a bit mask, as the IK kernels take them.

    Returns (nodes, offsets, domains, masks): masks (5,) int64, bit g for group g of the
    table's link pair.
    """
    return (*pair_tables(design), _table_masks(design))


@functools.lru_cache(maxsize=64)
def _table_masks(design: ArmDesign) -> np.ndarray:
    env = envelopes(design)
    masks = np.zeros(len(TABLE_PAIRS), np.int64)
    for k, lp in enumerate(TABLE_PAIRS):
        for g in range(*env.lp_groups[lp]):
            masks[k] |= 1 << int(g)
    masks.flags.writeable = False
    return masks
