"""Resource estimates made before heavy work, and the limits that refuse a job up front.

The workspace map holds, for a cube of ``(2 ceil(reach / voxel))^3`` voxels, three float64
coordinate grids plus masks and two float32 maps (about 34 bytes a voxel), and one int64
count per (voxel inside the reach sphere, direction) pair; its time is the number of IK
queries over a conservative query rate. Carving time grows with the number of swept poses,
``1 / resolution``. The rates are rough (measured on a 2-core machine, rounded down) and
only decide whether to refuse: an estimate is printed in the refusal.
"""

from __future__ import annotations

import math

from handarm.design import ArmDesign

__all__ = ["estimate", "check_resources", "DEFAULT_MAX_MEMORY", "DEFAULT_MAX_SECONDS"]

#: Largest estimated peak memory a job may take unless the caller raises it (bytes).
DEFAULT_MAX_MEMORY = 4 * 2**30
#: Largest estimated run time a job may take unless the caller raises it (s).
DEFAULT_MAX_SECONDS = 3600.0

_BYTES_PER_CELL = 34
_QUERIES_PER_SECOND = 2e5  # workspace IK queries, conservative
_CARVE_SECONDS_AT_1_DEG = 10.0  # whole carving at 1 degree, conservative


def estimate(
    design: ArmDesign,
    *,
    voxel: float | None = None,
    directions: int | None = None,
    resolution_deg: float | None = None,
) -> tuple[float, float]:
    """Estimated peak memory (bytes) and time (s) of a map and/or a carving.

    Parameters
    ----------
    design : ArmDesign
    voxel, directions : float, int, optional
        Workspace map settings (m, count); both or neither.
    resolution_deg : float, optional
        Carving resolution (degrees).

    Returns
    -------
    memory, seconds : float
    """
    memory = seconds = 0.0
    if voxel is not None and directions is not None:
        reach = float(sum(design.link_lengths[1:]))
        side = 2.0 * math.ceil(reach / voxel)
        inside = 4.0 / 3.0 * math.pi * (reach / voxel + 1.0) ** 3
        queries = min(inside, side**3) * directions
        memory += side**3 * _BYTES_PER_CELL + queries * 8
        seconds += queries / _QUERIES_PER_SECOND
    if resolution_deg is not None:
        seconds += _CARVE_SECONDS_AT_1_DEG / resolution_deg
    return memory, seconds


#: A map's voxel edge is at most the arm's reach over this (a map 8 voxels across at least).
_VOXELS_ACROSS = 4


def check_voxel(design: ArmDesign, voxel: float, name: str = "voxel") -> None:
    """ValueError naming ``name`` if the voxel is coarser than the arm's reach over 4.

    A voxel given in millimetres (30 for 0.03) made a map of one voxel, all scores 0.
    """
    reach = float(sum(design.lengths[1:]))
    if voxel > reach / _VOXELS_ACROSS:
        raise ValueError(
            f"{name}: {voxel:g} m is coarser than the arm's reach ({reach:.3f} m) over "
            f"{_VOXELS_ACROSS}; the edge is in metres (0.01 is 1 cm)"
        )


def _minutes(seconds: float) -> str:
    """Minutes to two significant figures below ten (0.34, 2.5), whole above (12, 130)."""
    minutes = seconds / 60
    return f"{minutes:.0f}" if minutes >= 10 else f"{minutes:.2g}"


def check_resources(
    design: ArmDesign,
    *,
    voxel: float | None = None,
    directions: int | None = None,
    resolution_deg: float | None = None,
    max_memory: float = DEFAULT_MAX_MEMORY,
    max_seconds: float = DEFAULT_MAX_SECONDS,
    time_factor: float = 1.0,
    remedy: tuple[str, str] = (
        "raise it with max_memory / --max-memory",
        "raise it with max_seconds / --max-minutes",
    ),
) -> None:
    """Refuse (ValueError naming the setting, with the estimate) a job over the limits.

    ``time_factor``: the whole job's time over the estimated one's (a map with its
    sensitivity screen, in a scene), so that the message quotes the job against the limit
    the user gave. ``remedy``: what the message suggests for memory and for time (the
    options of the caller that has them).
    """
    _check_settings(voxel, directions, resolution_deg)
    if voxel is not None:
        check_voxel(design, voxel)
    memory, seconds = estimate(
        design, voxel=voxel, directions=directions, resolution_deg=resolution_deg
    )
    seconds *= time_factor
    what = "resolution_deg"
    if voxel is not None:
        # name the setting that drives the size: directions when the per-query counts dominate
        what = "directions" if directions and directions > 100 else "voxel"
    if memory > max_memory:
        raise ValueError(
            f"{what}: the job needs about {memory / 2**30:.1f} GiB of memory, over the "
            f"{max_memory / 2**30:g} GiB limit ({remedy[0]})"
        )
    if seconds > max_seconds:
        raise ValueError(
            f"{what}: the job needs about {_minutes(seconds)} min, over the "
            f"{max_seconds / 60:g} min limit ({remedy[1]})"
        )


def _check_settings(voxel, directions, resolution_deg) -> None:
    if voxel is not None:
        if isinstance(voxel, bool) or not isinstance(voxel, (int, float)):
            raise ValueError(f"voxel: expected a number of metres, got {voxel!r}")
        if not (math.isfinite(voxel) and voxel > 0):
            raise ValueError(f"voxel: must be finite and > 0, got {voxel}")
    if directions is not None:
        if isinstance(directions, bool) or not isinstance(directions, int) or directions < 4:
            raise ValueError(f"directions: expected an integer >= 4, got {directions!r}")
        from handarm.workspace.maps import check_direction_count

        check_direction_count(directions)  # a count the bands cannot make, named, here
    if resolution_deg is not None and not (
        isinstance(resolution_deg, (int, float)) and 0.0 < resolution_deg <= 10.0
    ):
        raise ValueError(f"resolution_deg: expected 0 < r <= 10 degrees, got {resolution_deg}")
