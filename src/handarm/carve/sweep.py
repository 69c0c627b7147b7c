"""Conservative swept volumes of prism parts turning about a joint axle.

A convex prism turning about an axle parallel to it sweeps the extrusion of the 2D area its
polygon sweeps. That area is covered by the union of the convex hulls of consecutive poses
(at most ``step`` apart) grown by the sagitta R (1 - cos(step / 2)), the most an arc of radius
R strays from its chord: the result covers the true swept volume (tested against a dense
union of rotated copies).

Cable runs (``sweep_runs``) are swept in polar form instead: at each distance r from the
axle a run covers a range of angles, and turning widens that range by the turn. Rings of
``_RING`` mm take the range's ends over the ring, so the cover is exact to within a ring and
costs one polygon per piece of run instead of a union of hulls per degree.
"""

from __future__ import annotations

import math

import numpy as np
from manifold3d import CrossSection, JoinType, Manifold, OpType

from handarm.links import LinkBlank, Part

__all__ = ["prism", "part_in_frame", "sweep_parts", "sweep_runs", "frame_to_link"]


def frame_to_link(blank: LinkBlank, frame: str) -> np.ndarray:
    """4x4 transform from one of the link's joint frames into its link frame (mm)."""
    if frame == "prox" or blank.dist_from_prox is None:
        return np.eye(4)
    return blank.dist_from_prox


def _affine(m: np.ndarray) -> list[list[float]]:
    return [list(map(float, row)) for row in m[:3, :4]]


def prism(polygon: np.ndarray, z0: float, z1: float) -> Manifold:
    """Extrusion of a convex polygon from z0 to z1."""
    cs = CrossSection.hull_points(np.asarray(polygon, dtype=float))
    return cs.extrude(z1 - z0).translate([0.0, 0.0, z0])


def part_in_frame(blank: LinkBlank, part: Part, frame: str) -> Part:
    """The part as a prism in another joint frame of its link.

    Where the two axles cross (on l3) it is the bounding prism, which contains the part.
    """
    if part.frame == frame:
        return part
    to_link_src = frame_to_link(blank, part.frame)
    to_link_dst = frame_to_link(blank, frame)
    m = np.linalg.solve(to_link_dst, to_link_src)
    rot = m[:3, :3]
    if np.allclose(rot, np.eye(3)):
        poly = part.polygon + m[:2, 3]
        return Part(part.name, frame, poly, part.z0 + m[2, 3], part.z1 + m[2, 3])
    corners = np.concatenate(
        [np.column_stack([part.polygon, np.full(len(part.polygon), z)]) for z in (part.z0, part.z1)]
    )
    pts = corners @ rot.T + m[:3, 3]
    hull = CrossSection.hull_points(pts[:, :2]).to_polygons()[0]
    return Part(part.name, frame, np.asarray(hull), float(pts[:, 2].min()), float(pts[:, 2].max()))


def _rotate(poly: np.ndarray, t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return poly @ np.array([[c, s], [-s, c]])


def sweep_parts(parts, lo: float, hi: float, step: float, grow: float, within=None) -> Manifold:
    """Union of the volumes the parts sweep turning from ``lo`` to ``hi`` (rad) about z.

    Parameters
    ----------
    parts : iterable of Part
        Prisms in the joint frame (their axle is z).
    lo, hi : float
        Rotation range (rad).
    step : float
        Largest angle between consecutive poses (rad).
    grow : float
        Extra margin (mm) in every direction: the print clearance.
    within : array-like, shape (2, 3), optional
        Bounding box (mm) of what the sweep will be cut from: the sweep is clipped to it
        (grown by 1 mm), which keeps the meshes small and changes no cut.
    """
    n = max(1, math.ceil((hi - lo) / step - 1e-9))
    angles = np.linspace(lo, hi, n + 1)
    sag_factor = 1.0 - math.cos((hi - lo) / n / 2.0)
    box, clip = _clip_box(within)
    by_height: dict[tuple[float, float], list[CrossSection]] = {}
    for part in parts:
        z0, z1 = part.z0 - grow, part.z1 + grow
        if within is not None and (z1 < box[0, 2] - 1.0 or z0 > box[1, 2] + 1.0):
            continue
        poly = np.asarray(part.polygon, dtype=float)
        if part.axisymmetric:
            area = CrossSection.hull_points(poly).offset(grow, JoinType.Round)
        else:
            pieces = [
                CrossSection.hull_points(np.vstack([_rotate(poly, a), _rotate(poly, b)]))
                for a, b in zip(angles[:-1], angles[1:], strict=True)
            ]
            area = CrossSection.batch_boolean(pieces, OpType.Add)
            sag = float(np.max(np.linalg.norm(poly, axis=1))) * sag_factor
            area = area.offset(sag + grow, JoinType.Round)
        if clip is not None:
            area = area ^ clip
        by_height.setdefault((z0, z1), []).append(area)
    return _extruded(by_height)


def _clip_box(within) -> tuple[np.ndarray | None, CrossSection | None]:
    """The box (2, 3) a sweep will be cut from and its plan grown by 1 mm (or None, None)."""
    if within is None:
        return None, None
    box = np.asarray(within, dtype=float)
    return box, CrossSection.square(box[1, :2] - box[0, :2] + 2.0).translate(box[0, :2] - 1.0)


def _extruded(by_height: dict[tuple[float, float], list[CrossSection]]) -> Manifold:
    """The union of each (z0, z1) band's areas extruded from z0 to z1."""
    solids = []
    for (z0, z1), areas in by_height.items():
        area = CrossSection.batch_boolean(areas, OpType.Add)
        if not area.is_empty():
            # each band grown a hair more than the one before: two bands whose outlines
            # share a corner (a fork's plate and bridge at the end of a range) then do not
            # touch there, where the cut would pinch the link it is taken from
            area = area.offset(_BAND_GROW * len(solids), JoinType.Miter)
            solids.append(area.extrude(z1 - z0).translate([0.0, 0.0, z0]))
    return Manifold.batch_boolean(solids, OpType.Add) if solids else Manifold()


#: mm: how much more each band of a sweep is grown than the one before (see ``_extruded``);
#: a few micrometres in all, against a clearance of tenths of a millimetre.
_BAND_GROW = 5e-4


#: Largest rise (mm) along the axle of one piece of a cable run: each piece is swept as a
#: prism from its lowest to its highest point, so this is how much a sloping run is
#: over-covered at its top and bottom.
RUN_PIECE_RISE = 0.25
#: Width (mm) of the rings in which a run piece's polar sweep takes its extreme angles.
_RING = 0.2
_ARC_SEGMENTS = 96  # per full turn


def _ring_angles(poly: np.ndarray, radii: np.ndarray, ref: float) -> tuple[np.ndarray, np.ndarray]:
    """Least and greatest angle (rad, from ``ref``) of a convex polygon in each ring.

    Parameters
    ----------
    poly : ndarray, shape (n, 2)
        Convex polygon (mm) not holding the origin, within half a turn of ``ref``.
    radii : ndarray, shape (m + 1,)
        Increasing ring bounds (mm): ring i runs from radii[i] to radii[i + 1].
    ref : float
        Direction (rad) the angles are measured from.

    Returns
    -------
    low, high : ndarray, shape (m,)
        Along a straight edge the angle changes monotonically, so the extremes in a ring
        lie at the polygon's vertices in it or where its edges cross the ring's circles.
    """
    n = len(radii) - 1
    low, high = np.full(n, np.inf), np.full(n, -np.inf)

    def add(pts, ring):
        ok = (ring >= 0) & (ring < n)
        ang = (np.arctan2(pts[ok, 1], pts[ok, 0]) - ref + np.pi) % (2 * np.pi) - np.pi
        np.minimum.at(low, ring[ok], ang)
        np.maximum.at(high, ring[ok], ang)

    add(poly, np.searchsorted(radii, np.linalg.norm(poly, axis=1), side="right") - 1)
    p, d = poly, np.roll(poly, -1, axis=0) - poly
    a = np.einsum("ij,ij->i", d, d)[:, None]
    b = 2 * np.einsum("ij,ij->i", p, d)[:, None]
    c = np.einsum("ij,ij->i", p, p)[:, None] - radii[None, :] ** 2
    disc = b * b - 4 * a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    for sign in (-1.0, 1.0):
        t = (-b + sign * root) / (2 * np.where(a > 0, a, 1.0))
        hit = (disc >= 0) & (a > 0) & (t >= 0) & (t <= 1)
        edge, k = np.nonzero(hit)
        pts = p[edge] + t[edge, k][:, None] * d[edge]
        add(pts, k - 1)  # on the circle radii[k]: both rings beside it
        add(pts, k)
    return low, high


def _nearest(poly: np.ndarray) -> float:
    """Distance (mm) from the origin to a convex counter-clockwise polygon (0 inside it)."""
    p, d = poly, np.roll(poly, -1, axis=0) - poly
    if np.all(d[:, 0] * -p[:, 1] - d[:, 1] * -p[:, 0] >= 0.0):
        return 0.0
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(-np.einsum("ij,ij->i", p, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    return float(np.min(np.linalg.norm(p + t[:, None] * d, axis=1)))


def _arc(r: float, a0: float, a1: float, outside: bool) -> np.ndarray:
    """Points (n, 2) on an arc (mm, rad), its chords outside radius r or on its inside."""
    n = max(1, math.ceil(abs(a1 - a0) / (2 * math.pi / _ARC_SEGMENTS)))
    t = np.linspace(a0, a1, n + 1)
    rr = r / math.cos(abs(a1 - a0) / n / 2) if outside else r
    return np.stack([rr * np.cos(t), rr * np.sin(t)], axis=1)


def _ring(r0: float, r1: float) -> CrossSection:
    """The annulus r0 <= r <= r1 (mm), as a polygon holding it."""
    outer = CrossSection([_arc(r1, 0.0, 2 * math.pi, True)[:-1]])
    return outer - CrossSection([_arc(r0, 0.0, 2 * math.pi, False)[:-1]]) if r0 > 0 else outer


def _polar_sweep(poly: np.ndarray, lo: float, hi: float) -> CrossSection:
    """A polygon holding what a convex polygon sweeps turning from lo to hi about the origin.

    At radius r the polygon covers angles a(r) .. b(r); turned through lo .. hi it sweeps
    a(r) + lo .. b(r) + hi, the whole circle where that spans a turn. Each ring of width
    ``_RING`` takes the least and greatest angles in it: the outline is a staircase of
    radial edges and arcs, each arc on the side of the ring it bounds (``_side``).
    """
    poly = np.asarray(poly, dtype=float)
    r_near = _nearest(poly)
    r_far = float(np.max(np.linalg.norm(poly, axis=1)))
    if r_near <= 1e-9:
        return _ring(0.0, r_far)
    c = poly.mean(axis=0)
    ref = math.atan2(c[1], c[0])
    n = max(1, math.ceil((r_far - r_near) / _RING))
    radii = np.linspace(r_near, r_far, n + 1)
    low, high = _ring_angles(poly, radii, ref)
    low, high = low + lo + ref, high + hi + ref
    full = high - low >= 2 * math.pi
    pieces = []
    i = 0
    while i < n:  # runs of consecutive rings that sweep the whole turn, or not
        j = i
        while j + 1 < n and full[j + 1] == full[i]:
            j += 1
        if full[i]:
            pieces.append(_ring(radii[i], radii[j + 1]))
        else:
            pieces.append(_star(radii[i : j + 2], low[i : j + 1], high[i : j + 1]))
        i = j + 1
    return CrossSection.batch_boolean(pieces, OpType.Add) if len(pieces) > 1 else pieces[0]


def _side(radii: np.ndarray, angles: np.ndarray, low_side: bool) -> np.ndarray:
    """One side of ``_star``'s outline, outwards: radial edges and the arcs joining them.

    Ring i spans radii[i] .. radii[i + 1] at ``angles[i]``; the rings cover the angles
    above ``angles`` (the low side) or below them (the high side). Where two rings meet,
    the arc between their angles bounds the one that covers it: it lies outside the circle
    (circumscribed chords) when that is the inner ring, on the circle when it is the outer.
    Returns the outline's points, shape (k, 2), mm.
    """
    n = len(angles)
    r0, r1 = radii[:-1], radii[1:]
    delta = np.append(angles[1:], angles[-1]) - angles
    inner_owns = delta > 0 if low_side else delta < 0
    segs = np.maximum(1, np.ceil(np.abs(delta) / (2 * np.pi / _ARC_SEGMENTS))).astype(int)
    # per ring: its radial edge (2 points), then the arc to the next ring: all its points
    # when they lie outside the circle, else only those between the two radial edges' ends
    counts = 2 + np.where(inner_owns, segs + 1, segs - 1)
    counts[-1] = 2
    ring = np.repeat(np.arange(n), counts)
    k = np.arange(len(ring)) - np.repeat(np.cumsum(counts) - counts, counts)
    r = np.where(k == 0, r0[ring], r1[ring])
    a = angles[ring].copy()
    on_arc = k >= 2
    step = np.where(inner_owns[ring], k - 2, k - 1) / segs[ring]
    a[on_arc] += (step * delta[ring])[on_arc]
    chord = r1[ring] / np.cos(np.abs(delta[ring]) / segs[ring] / 2)
    r[on_arc] = np.where(inner_owns[ring], chord, r1[ring])[on_arc]
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


def _star(radii: np.ndarray, lows: np.ndarray, highs: np.ndarray) -> CrossSection:
    """The rings radii[i] .. radii[i + 1] between angles lows[i] .. highs[i] (mm, rad)."""
    outline = [
        _side(radii, lows, True),
        _arc(radii[-1], lows[-1], highs[-1], True),
        _side(radii, highs, False)[::-1],
        _arc(radii[0], highs[0], lows[0], False),
    ]
    return CrossSection([np.vstack(outline)])


def _run_pieces(runs, radius: float) -> list[tuple[np.ndarray, float, float]]:
    """Prisms containing cable runs: cylinders of ``radius`` round each axis (start, end).

    Each run is cut into pieces that rise at most ``RUN_PIECE_RISE`` along z. A piece lies
    in the hull of the circles of ``radius`` round its ends seen along z, and within its
    ends' heights +- ``radius``. Returns (polygon (n, 2), z0, z1) per piece, mm.
    """
    t = (np.arange(16) + 0.5) * 2 * math.pi / 16
    disc = radius / math.cos(math.pi / 16) * np.stack([np.cos(t), np.sin(t)], axis=1)
    out = []
    for a, b in runs:
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = max(1, math.ceil(abs(b[2] - a[2]) / RUN_PIECE_RISE))
        pts = a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)
        for p, q in zip(pts[:-1], pts[1:], strict=True):
            hull = CrossSection.hull_points(np.vstack([p[:2] + disc, q[:2] + disc]))
            poly = np.asarray(hull.to_polygons()[0], dtype=float)
            out.append((poly, min(p[2], q[2]) - radius, max(p[2], q[2]) + radius))
    return out


def sweep_runs(runs, radius: float, lo: float, hi: float, grow: float, within=None) -> Manifold:
    """What cable runs sweep turning from ``lo`` to ``hi`` (rad) about z, grown by ``grow``.

    A run sweeps, at each distance from the axle, the angles it covers there widened by the
    turn (``_polar_sweep``), which is cheaper and tighter than unions of turned copies.
    Growing a run's radius by ``grow`` grows its sweep by ``grow`` (a turned disc is the
    same disc). Each run is cut into pieces that rise at most ``RUN_PIECE_RISE``, each
    covered from its lowest to its highest point.

    Parameters
    ----------
    runs : iterable of (start, end)
        Cable axes, array-like shape (3,) each, mm, in the joint frame (the axle is z).
    radius : float
        The cable's radius plus clearance (mm): what each run keeps clear round its axis.
    lo, hi : float
        Rotation range (rad).
    grow : float
        Extra margin (mm) in every direction: the print clearance.
    within : array-like, shape (2, 3), optional
        Bounding box (mm) of what the sweep will be cut from (see ``sweep_parts``).

    Returns
    -------
    Manifold
        A volume (mm) holding every place the runs' cylinders take, grown by ``grow``.
    """
    box, clip = _clip_box(within)
    by_height: dict[tuple[float, float], list[CrossSection]] = {}
    for poly, z0, z1 in _run_pieces(runs, radius + grow):
        if clip is not None and (z1 < box[0, 2] - 1.0 or z0 > box[1, 2] + 1.0):
            continue
        by_height.setdefault((z0, z1), []).append(_polar_sweep(poly, lo, hi))
    if clip is not None:
        by_height = {
            band: [CrossSection.batch_boolean(areas, OpType.Add) ^ clip]
            for band, areas in by_height.items()
        }
    return _extruded(by_height)
