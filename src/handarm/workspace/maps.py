"""Reachability maps: positions on a voxel grid times approach directions, through the IK.

For each voxel centre p and each direction e of a set, the 5-DoF IK counts solution ranges.
Per voxel: the reachability index (fraction of directions with a solution), the mean number
of solution ranges over the directions, and whether the position is reachable with at least
one of the directions.

Symmetries: negating q1..q3 mirrors the arm's kinematics in y (tool point and direction),
negating q4..q6 mirrors it in z. The paper's segment model is mirror-invariant; the printed
links are only when every envelope piece is symmetric about its link's plane, which the
default links are not (each fork carries its idler stack on one side). When the collision
model is mirror-invariant and the limits of joints 1-3 (resp. 4-6) are symmetric, only y > 0
(resp. z > 0) is computed and mirrored. The grid and the direction set are themselves
mirror-symmetric, so the mirrored map equals the full computation (tested).
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handarm._io import write_bytes_atomic
from handarm.collision import envelopes
from handarm.design import ArmDesign
from handarm.ik import count_solutions
from handarm.ik.exact import check_clearance

__all__ = [
    "MIN_WIDTH",
    "ReachabilityMap",
    "direction_set",
    "nearest_direction_counts",
    "reachability_map",
    "symmetries",
]

#: Narrowest solution range (m of the IK's line parameter u) that makes a target reachable.
#: A printed arm cannot hold a range a few nanometres wide (a stretched tip pointing
#: straight up or down): such ranges alias the maps (more directions, less volume). One
#: micrometre is far below any printed tolerance and far above the numerical width of
#: those degenerate ranges (about 4 nm).
MIN_WIDTH = 1e-6


def direction_set(n: int = 100) -> np.ndarray:
    """Exactly ``n`` unit directions, even over the sphere and symmetric under y -> -y, z -> -z.

    m bands of equal area (equal steps in x, by Archimedes' theorem), each with an even number
    k of directions equally spaced around x, every other band turned by half a step: an even
    k maps each band onto itself under both mirrors, and no direction has a near-twin across
    a mirror plane. n = 100 gives 10 bands of 10.

    Only some counts can be made this way (4, 12, 16, 30, 36, 56, 64, 90, 100, ...); any
    other count is refused, never silently rounded.

    Raises
    ------
    ValueError
        If ``n`` is not an integer >= 4 or not a count the construction makes; the message
        names the nearest valid counts.
    """
    check_direction_count(n)
    return _direction_bands(int(n))


def check_direction_count(n) -> None:
    """ValueError naming ``directions`` unless ``direction_set(n)`` makes exactly n directions.

    Arithmetic only (no directions are built), so a huge count is refused at once.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 4:
        raise ValueError(f"directions: expected an integer >= 4, got {n!r}")
    if _band_count(int(n)) != n:
        below, above = nearest_direction_counts(int(n))
        raise ValueError(
            f"directions: {n} directions cannot be spread evenly and mirror-symmetrically; "
            f"nearest valid counts: {below} and {above}"
        )


def nearest_direction_counts(n: int) -> tuple[int, int]:
    """The largest valid direction count <= ``n`` and the smallest >= ``n``.

    Valid counts are products m k of the construction; the candidates near n (m within a
    few of sqrt(n), k even near n / m) hold both neighbours (a test checks this against a
    scan of every count), so any n is answered at once.
    """
    r = math.isqrt(max(n, 4))
    cands = {4}
    for m in range(max(2, r - 4), r + 6):
        for k in range(max(2, 2 * (n // (2 * m)) - 6), 2 * (n // (2 * m)) + 10, 2):
            if _band_count(m * k) == m * k:
                cands.add(m * k)
    return max(c for c in cands if c <= n), min(c for c in cands if c >= max(n, 4))


def _bands(n: int) -> tuple[int, int]:
    """(m bands, k directions per band) of the construction for a requested count n."""
    m = max(2, round(math.sqrt(n)))
    return m, max(2, 2 * round(n / (2 * m)))


def _band_count(n: int) -> int:
    """How many directions ``_direction_bands(n)`` makes: m bands of k (k even)."""
    m, k = _bands(n)
    return m * k


def _direction_bands(n: int) -> np.ndarray:
    m, k = _bands(n)
    x = -1.0 + (2.0 * np.arange(m) + 1.0) / m
    r = np.sqrt(1.0 - x * x)
    out = []
    for i in range(m):
        # azimuths (j + o) / k of a turn, o = 0 or 1/2; the band is mirror-symmetric, so it
        # is built from its first quadrant by sign flips: bit-exact mirror images
        twice_o = i % 2
        points = set()
        for j in range(k):
            quarter = 4 * (2 * j + twice_o)  # 8 (j + o)
            if quarter > 2 * k:  # beyond a quarter turn
                continue
            if quarter == 2 * k:
                c, s_ = 0.0, 1.0
            elif quarter == 0:
                c, s_ = 1.0, 0.0
            else:
                t = 2.0 * math.pi * (j + 0.5 * twice_o) / k
                c, s_ = math.cos(t), math.sin(t)
            for sy in (1.0, -1.0):
                for sz in (1.0, -1.0):
                    points.add((float(x[i]), sy * r[i] * c + 0.0, sz * r[i] * s_ + 0.0))
        out.append(np.array(sorted(points)))
    return np.concatenate(out)


def symmetries(design: ArmDesign) -> tuple[bool, bool]:
    """(mirror in y, mirror in z): whether a map may be computed on one side and mirrored.

    True when joints 1-3 (resp. 4-6) have symmetric limits and the design's collision model
    is mirror-invariant (see the module docstring).
    """
    if not collision_mirror_invariant(design):
        return False, False
    sym = np.isclose(design.lower, -design.upper, rtol=0, atol=1e-15)
    return bool(sym[:3].all()), bool(sym[3:].all())


def collision_mirror_invariant(design: ArmDesign) -> bool:
    """Whether the collision model reflects onto itself when the arm is mirrored.

    The paper's segments lie on the link lines. A printed envelope piece is mirror-invariant
    when its stadium is symmetric about the link's line (the segment's mirror image is the
    segment) and its slab about the link's plane (z range centred on 0). Requiring it of every
    piece is sufficient (it ignores pieces that are mirror images of each other), so it never
    claims a symmetry that is not there.
    """
    if design.collision_model != "printed":
        return True
    tol = 1e-9
    for piece in envelopes(design).pieces:
        seg = piece.segment
        flipped = seg * [1.0, -1.0]
        same = np.abs(flipped - seg).max() <= tol or np.abs(flipped[::-1] - seg).max() <= tol
        if abs(piece.z[0] + piece.z[1]) > tol or not same:
            return False
    return True


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class ReachabilityMap:
    """A reachability map on a cubic grid of voxels (SI units).

    ``index``, ``mean_solutions`` and ``reachable`` have shape (n, n, n) along x, y, z; voxel
    (i, j, k) is centred at ``centres[i], centres[j], centres[k]``. Voxels outside the reach
    sphere are 0 / False. ``collision_model`` is the design's model of what collides
    (``"printed"``: the printed links; ``"paper"``: the paper's segments) that the map used.
    """

    voxel: float
    centres: np.ndarray
    index: np.ndarray
    mean_solutions: np.ndarray
    reachable: np.ndarray
    directions: np.ndarray
    reach: float
    mirrored: tuple[bool, bool]
    queries: int
    seconds: float
    handle: float = 0.0  # length of l0 (m), for pictures
    collision_model: str = "printed"  # the design's collision model the IK used
    min_width: float = 0.0  # narrowest counted solution range (m of u)
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # grid shift (m) added to centres

    def save_npz(self, path: str | os.PathLike[str]) -> Path:
        """Compressed .npz (written atomically)."""
        buf = io.BytesIO()
        np.savez_compressed(
            buf,
            voxel=self.voxel,
            centres=self.centres,
            index=self.index,
            mean_solutions=self.mean_solutions,
            reachable=self.reachable,
            directions=self.directions,
            reach=self.reach,
            mirrored=np.array(self.mirrored),
            handle=self.handle,
            collision_model=self.collision_model,
            min_width=self.min_width,
            offset=np.array(self.offset),
        )
        path = Path(path)
        write_bytes_atomic(path, buf.getvalue())
        return path


def reachability_map(
    design: ArmDesign,
    voxel: float = 0.01,
    directions: int | np.ndarray = 100,
    *,
    use_symmetry: bool = True,
    progress: Callable[[int, int], None] | None = None,
    chunk_queries: int = 400_000,
    min_width: float = MIN_WIDTH,
    offset=(0.0, 0.0, 0.0),
    rotation=None,
    scene=None,
    clearance: float = 0.0,
) -> ReachabilityMap:
    """Reachability map of the design.

    Parameters
    ----------
    design : ArmDesign
    voxel : float
        Voxel edge (m).
    directions : int or array-like, shape (m, 3)
        Number of approach directions (``direction_set``), or the directions themselves
        (symmetry is then used only if the set is mirror-symmetric).
    use_symmetry : bool
        Mirror the map where the limits allow it.
    progress : callable, optional
        ``progress(done, total)`` in IK queries, after each chunk.
    chunk_queries : int
        IK queries per batch (bounds memory).
    min_width : float
        Solution ranges narrower than this (m of u) do not count (default ``MIN_WIDTH``).
    offset : array-like, shape (3,)
        Shift of the voxel grid (m), for jittered repeats; voxel (i, j, k) is then centred
        at ``centres[[i, j, k]] + offset``. A shifted grid is not mirror-symmetric, so the
        map is computed in full.
    rotation : array-like, shape (3, 3), optional
        Rotation applied to the direction set, for rotated repeats.
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame): a target counts as reached by the ranges that keep
        ``clearance`` (m) from them (``count_solutions(..., scene=)``). A scene is in general
        not mirror-symmetric, so the map is then computed in full.
    clearance : float

    Raises
    ------
    ValueError
        If ``voxel`` is not positive, the direction count is not a valid one (see
        ``direction_set``), ``offset`` or ``rotation`` is malformed.
    """
    import time

    if isinstance(voxel, bool) or not isinstance(voxel, (int, float)) or not voxel > 0:
        raise ValueError(f"voxel: expected a positive number of metres, got {voxel!r}")
    check_clearance(clearance, scene)
    off = np.asarray(offset, float)
    if off.shape != (3,) or not np.isfinite(off).all():
        raise ValueError(f"offset: expected 3 finite numbers (m), got {offset!r}")
    dirs = direction_set(directions) if np.isscalar(directions) else np.asarray(directions, float)
    if rotation is not None:
        rot = np.asarray(rotation, float)
        if rot.shape != (3, 3) or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-9):
            raise ValueError("rotation: expected a 3x3 rotation matrix")
        dirs = dirs @ rot.T
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    reach = float(np.sum(design.lengths[1:]))
    half = math.ceil(reach / voxel)
    centres = (np.arange(2 * half) - half + 0.5) * voxel
    sym_y, sym_z = symmetries(design) if use_symmetry else (False, False)
    sym_y = sym_y and _mirror_symmetric(dirs, 1)
    sym_z = sym_z and _mirror_symmetric(dirs, 2)
    if off.any() or scene:
        sym_y = sym_z = False
    gx, gy, gz = np.meshgrid(centres + off[0], centres + off[1], centres + off[2], indexing="ij")
    inside = gx**2 + gy**2 + gz**2 <= (reach + voxel * math.sqrt(3) / 2) ** 2
    todo = inside.copy()
    if sym_y:
        todo &= gy > 0
    if sym_z:
        todo &= gz > 0
    idx = np.flatnonzero(todo)
    pts = np.stack([gx.flat[idx], gy.flat[idx], gz.flat[idx]], axis=1)
    m = len(dirs)
    counts = np.empty((len(idx), m), np.int64)
    per_chunk = max(1, chunk_queries // m)
    total = len(idx) * m
    t0 = time.perf_counter()
    for s in range(0, len(idx), per_chunk):
        block = pts[s : s + per_chunk]
        P = np.repeat(block, m, axis=0)
        E = np.tile(dirs, (len(block), 1))
        counts[s : s + len(block)] = count_solutions(
            design, P, E, min_width=min_width, scene=scene, clearance=clearance
        ).reshape(len(block), m)
        if progress is not None:
            progress(min(total, (s + len(block)) * m), total)
    seconds = time.perf_counter() - t0
    index = np.zeros(inside.shape, np.float32)
    mean = np.zeros(inside.shape, np.float32)
    index.flat[idx] = (counts > 0).mean(axis=1)
    mean.flat[idx] = counts.mean(axis=1)
    # mirror: voxel j <-> 2 half - 1 - j along y and z
    if sym_y:
        index = np.maximum(index, index[:, ::-1, :])
        mean = np.maximum(mean, mean[:, ::-1, :])
    if sym_z:
        index = np.maximum(index, index[:, :, ::-1])
        mean = np.maximum(mean, mean[:, :, ::-1])
    return ReachabilityMap(
        voxel,
        centres,
        index,
        mean,
        index > 0,
        dirs,
        reach,
        (sym_y, sym_z),
        total,
        seconds,
        float(design.lengths[0]),
        design.collision_model,
        float(min_width),
        tuple(float(v) for v in off),
    )


def _mirror_symmetric(dirs: np.ndarray, axis: int) -> bool:
    flipped = dirs.copy()
    flipped[:, axis] *= -1
    a = np.round(dirs, 12)
    b = np.round(flipped, 12)
    return {tuple(v) for v in a} == {tuple(v) for v in b}
