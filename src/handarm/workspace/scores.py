"""Workspace scores, the paper's claims checked, and per-joint sensitivity.

Scores of a map: reachable volume (voxels reached with at least one direction), dexterous
volume (reachability index at least ``threshold``), mean index over the reachable voxels.
One scalar design score combines them with the carved links' mass and strength::

    score = w_reachable V_r / 1 L + w_dexterous V_d / 1 L + w_mean_index I
            - w_mass m / 0.1 kg + w_strength A_min / 50 mm^2

Every reference is a fixed physical unit: no term is divided by the design's own size
(dividing by the reach sphere rewarded small arms).
"""

from __future__ import annotations

import math

import numpy as np

from handarm.design import ArmDesign
from handarm.kinematics import is_valid, joint_positions
from handarm.workspace.maps import ReachabilityMap, reachability_map

__all__ = [
    "DEFAULT_WEIGHTS",
    "map_scores",
    "design_score",
    "min_reach_check",
    "joint_sensitivity",
]

DEFAULT_WEIGHTS = {
    "reachable": 1.0,
    "dexterous": 1.0,
    "mean_index": 0.0,
    "mass": 0.5,
    "strength": 0.0,
}
_MASS_REF = 0.1  # kg
_AREA_REF = 50e-6  # m^2
_VOLUME_REF = 1e-3  # m^3 (one litre)


def map_scores(wmap: ReachabilityMap, threshold: float = 0.5) -> dict:
    """Reachable and dexterous volume (m^3), mean index, from a map."""
    if not 0.0 < threshold <= 1.0:
        raise ValueError(f"threshold: expected 0 < t <= 1, got {threshold}")
    cell = wmap.voxel**3
    reached = wmap.reachable
    return {
        "reachable_volume_m3": float(reached.sum() * cell),
        "dexterous_volume_m3": float((wmap.index >= threshold).sum() * cell),
        "mean_index": float(wmap.index[reached].mean()) if reached.any() else 0.0,
        "mean_solutions": float(wmap.mean_solutions[reached].mean()) if reached.any() else 0.0,
        "reference_volume_m3": 4.0 / 3.0 * math.pi * wmap.reach**3,
        "threshold": threshold,
    }


def design_score(scores: dict, mass: float, min_cross_section: float, weights=None) -> float:
    """The scalar score (see module doc); ``weights`` override DEFAULT_WEIGHTS by name."""
    w = dict(DEFAULT_WEIGHTS)
    for key, value in (weights or {}).items():
        if key not in w:
            raise ValueError(f"weights: unknown weight {key!r}; known: {sorted(w)}")
        w[key] = float(value)
    v_ref = _VOLUME_REF
    return (
        w["reachable"] * scores["reachable_volume_m3"] / v_ref
        + w["dexterous"] * scores["dexterous_volume_m3"] / v_ref
        + w["mean_index"] * scores["mean_index"]
        - w["mass"] * mass / _MASS_REF
        + w["strength"] * min_cross_section / _AREA_REF
    )


def min_reach_check(design: ArmDesign, samples: int = 200_000, seed: int = 0) -> dict:
    """The paper's minimum reach of a 3R section, 2 a sin((pi - theta2max) / 2), checked.

    For equal links a1 = a2 (a5 = a4) the closest joint 3 (joint 4) gets to joint 1 (joint 6)
    over valid configurations is measured by sampling, and compared with the formula (and
    with the law of cosines for unequal links).
    """
    rng = np.random.default_rng(seed)
    q = rng.uniform(design.lower, design.upper, (samples, 6))
    # the paper's extreme pose, joint 2 (joint 5) at its limit, is included on purpose
    for k, lim in ((1, design.upper[1]), (4, design.upper[4])):
        q[: samples // 10, k] = lim
    q = q[is_valid(design, q)]
    pos = joint_positions(design, q)
    a = design.lengths
    out = {}
    for name, (i, j), (la, lb), lim in (
        ("base", (1, 3), (a[1], a[2]), max(abs(design.lower[1]), design.upper[1])),
        ("tip", (6, 4), (a[5], a[4]), max(abs(design.lower[4]), design.upper[4])),
    ):
        measured = float(np.linalg.norm(pos[:, j] - pos[:, i], axis=1).min())
        cosines = math.sqrt(la * la + lb * lb + 2 * la * lb * math.cos(lim))
        paper = 2 * la * math.sin((math.pi - lim) / 2) if math.isclose(la, lb) else None
        out[name] = {
            "theta_max_deg": math.degrees(lim),
            "paper_formula_m": paper,
            "law_of_cosines_m": cosines,
            "measured_m": measured,
            "agrees": bool(abs(measured - cosines) < 1e-3 * (la + lb)),
        }
    return out


def joint_sensitivity(
    design: ArmDesign,
    delta_deg: float = 10.0,
    voxel: float = 0.02,
    directions: int = 56,
    threshold: float = 0.5,
) -> dict:
    """How much each joint's limit matters: volumes lost per degree of limit taken away.

    Each joint's symmetric limit is reduced by ``delta_deg`` in turn (coarse maps); the
    paper says joints 2 and 5 matter most, and the result says whether that holds here.
    """
    base = map_scores(reachability_map(design, voxel, directions), threshold)
    rows = []
    for k in range(6):
        lo, hi = design.joint_limits[k]
        d = math.radians(delta_deg)
        limits = list(design.joint_limits)
        limits[k] = (min(lo + d, 0.0), max(hi - d, 0.0))
        s = map_scores(
            reachability_map(design.replace(joint_limits=limits), voxel, directions), threshold
        )
        rows.append(
            {
                "joint": k + 1,
                "reachable_m3_per_deg": (base["reachable_volume_m3"] - s["reachable_volume_m3"])
                / delta_deg,
                "dexterous_m3_per_deg": (base["dexterous_volume_m3"] - s["dexterous_volume_m3"])
                / delta_deg,
            }
        )
    # the two joints that lose the most; joints that lose nothing are not ranked
    top_reach = [
        r
        for r in sorted(rows, key=lambda r: -r["reachable_m3_per_deg"])[:2]
        if r["reachable_m3_per_deg"] > 0
    ]
    top_dex = [
        r
        for r in sorted(rows, key=lambda r: -r["dexterous_m3_per_deg"])[:2]
        if r["dexterous_m3_per_deg"] > 0
    ]
    return {
        "delta_deg": delta_deg,
        "voxel_m": voxel,
        "directions": directions,
        "joints": rows,
        "most_sensitive_reachable": sorted(r["joint"] for r in top_reach),
        "most_sensitive_dexterous": sorted(r["joint"] for r in top_dex),
        "paper_claim_joints_2_and_5": {
            "reachable": sorted(r["joint"] for r in top_reach) == [2, 5],
            "dexterous": sorted(r["joint"] for r in top_dex) == [2, 5],
        },
    }
