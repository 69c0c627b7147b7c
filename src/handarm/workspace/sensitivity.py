"""Global sensitivity of the workspace to the joint limits (SALib's Morris method).

The symmetric limit of each joint varies over a stated range (default 90..170 degrees, all
six at once); Morris elementary effects on the reachable and dexterous volumes (L) rank the
joints, each effect with a bootstrap confidence interval. The maps run on a Dask client
when one is given.

The paper's own claim is about a 3R section, not the whole arm: in the joint plane, the
area the end of a section (joints 1-3) reaches shrinks most when joint 2's limit is
narrowed. ``paper_3r_section_check`` measures that separately and by name.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from handarm.design import ArmDesign

__all__ = ["global_sensitivity", "paper_3r_section_check"]


def _volumes(design_dict: dict, limits_deg: list, settings: dict) -> tuple[float, float]:
    from handarm.workspace.maps import reachability_map
    from handarm.workspace.scores import map_scores

    design = ArmDesign.from_dict(design_dict).with_limits_deg(limits_deg)
    wmap = reachability_map(
        design, settings["voxel"], settings["directions"], min_width=settings["min_width"]
    )
    sc = map_scores(wmap, settings["threshold"])
    return sc["reachable_volume_m3"] * 1e3, sc["dexterous_volume_m3"] * 1e3


def global_sensitivity(
    design: ArmDesign,
    *,
    voxel: float,
    directions: int,
    threshold: float = 0.5,
    min_width: float | None = None,
    low_deg: float = 90.0,
    high_deg: float = 170.0,
    trajectories: int = 4,
    levels: int = 4,
    seed: int = 0,
    client=None,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Morris screening of the six joint limits over [low_deg, high_deg].

    Parameters
    ----------
    design : ArmDesign
        Every field but the joint limits is kept.
    voxel, directions, threshold, min_width
        Map settings (m, count, index, m of u; ``min_width`` default ``maps.MIN_WIDTH``).
    low_deg, high_deg : float
        Range of each symmetric joint limit (degrees).
    trajectories, levels : int
        Morris trajectories (r; the run costs r x 7 maps) and grid levels.
    seed : int
    client : dask.distributed.Client, optional
        Run the maps on this client; default: here, one after another.
    progress : callable, optional
        ``progress(done, total)`` in maps.

    Returns
    -------
    dict
        ``method``, ``range_deg``, settings, ``joints``: per joint ``mu_star`` and
        ``mu_star_conf`` (95 %) of both volumes (L), ``ranking_reachable`` and
        ``ranking_dexterous`` (joints by mu_star, largest first), and
        ``paper_3r_section_check``.
    """
    from SALib.analyze import morris as analyze
    from SALib.sample import morris as sample

    from handarm.workspace.maps import MIN_WIDTH, direction_set

    if not 0 < low_deg < high_deg <= 180:
        raise ValueError(
            f"range: expected 0 < low < high <= 180 degrees, got {low_deg}, {high_deg}"
        )
    if isinstance(trajectories, bool) or not isinstance(trajectories, int) or trajectories < 2:
        raise ValueError(f"trajectories: expected an integer >= 2, got {trajectories!r}")
    direction_set(directions)  # a bad count is refused before any work
    settings = {
        "voxel": voxel,
        "directions": directions,
        "threshold": threshold,
        "min_width": MIN_WIDTH if min_width is None else min_width,
    }
    problem = {
        "num_vars": 6,
        "names": [f"limit_deg_{k}" for k in range(1, 7)],
        "bounds": [[low_deg, high_deg]] * 6,
    }
    x = sample.sample(problem, trajectories, num_levels=levels, seed=seed)
    total = len(x)
    y = np.zeros((total, 2))
    dd = design.to_dict()
    if client is None:
        for i, row in enumerate(x):
            y[i] = _volumes(dd, row.tolist(), settings)
            if progress:
                progress(i + 1, total)
    else:
        from dask.distributed import as_completed

        futures = [client.submit(_volumes, dd, row.tolist(), settings, pure=False) for row in x]
        index = {f.key: i for i, f in enumerate(futures)}
        for done, fut in enumerate(as_completed(futures), 1):
            y[index[fut.key]] = fut.result()
            if progress:
                progress(done, total)
    result = {
        "method": f"Morris (SALib), {trajectories} trajectories, {levels} levels",
        "range_deg": [low_deg, high_deg],
        "maps": total,
        **{k: settings[k] for k in ("voxel", "directions", "threshold", "min_width")},
        "joints": [{"joint": k} for k in range(1, 7)],
    }
    for col, name in enumerate(("reachable", "dexterous")):
        res = analyze.analyze(problem, x, y[:, col], num_levels=levels, seed=seed)
        for k, row in enumerate(result["joints"]):
            row[f"{name}_mu_star_L"] = float(res["mu_star"][k])
            row[f"{name}_mu_star_conf_L"] = float(res["mu_star_conf"][k])
            row[f"{name}_sigma_L"] = float(res["sigma"][k])
        order = np.argsort(-np.asarray(res["mu_star"]), kind="stable")
        result[f"ranking_{name}"] = [int(k) + 1 for k in order]
    result["paper_3r_section_check"] = paper_3r_section_check(design)
    return result


def paper_3r_section_check(
    design: ArmDesign, delta_deg: float = 10.0, cell: float = 0.002, samples: int = 1_000_000
) -> dict:
    """The paper's claim on a 3R section: narrowing joint 2 costs the most reachable area.

    The end of the base section (joints 1-3, links a1, a2 and a3, planar) is sampled over
    the design's limits and rasterised on ``cell`` (m) squares; each joint's limit is then
    narrowed by ``delta_deg`` on both sides in turn. Collisions are not modelled (the
    paper's argument is geometric).

    Returns
    -------
    dict
        ``area_mm2`` at the design's limits, ``area_lost_mm2`` per joint (1, 2, 3) and
        ``joint_2_dominates`` (joint 2 loses strictly the most).
    """
    rng = np.random.default_rng(0)
    a = design.lengths[1:4]
    lo, hi = design.lower[:3].copy(), design.upper[:3].copy()
    q = rng.uniform(lo, hi, (samples, 3))
    t = np.cumsum(q, axis=1)
    ij = np.floor(
        np.stack([(a * np.cos(t)).sum(axis=1), (a * np.sin(t)).sum(axis=1)], axis=1) / cell
    ).astype(np.int64)
    key = ij[:, 0] * 1_000_003 + ij[:, 1]
    mm2 = cell * cell * 1e6
    base = np.unique(key)
    lost = []
    d = math.radians(delta_deg)
    for k in range(3):
        # the narrowed section is the same samples, those within the narrowed limits: the
        # cells only the others reach are lost (a subset, so never negative)
        keep = (q[:, k] >= min(lo[k] + d, 0.0)) & (q[:, k] <= max(hi[k] - d, 0.0))
        lost.append((len(base) - len(np.unique(key[keep]))) * mm2)
    return {
        "delta_deg": delta_deg,
        "area_mm2": len(base) * mm2,
        "cell_m": cell,
        "area_lost_mm2": {str(k + 1): v for k, v in enumerate(lost)},
        "joint_2_dominates": bool(lost[1] > max(lost[0], lost[2])),
    }
