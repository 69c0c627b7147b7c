"""Everything ``handarm workspace`` writes for one design.

::

    OUT/workspace.npz          the map (compressed): index, mean solutions, reachable, grid
    OUT/workspace.json         scores, the paper's minimum-reach check, per-joint sensitivity
    OUT/pictures/workspace_xy.png, workspace_xz.png, sensitivity.png
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from handarm._io import write_text_atomic
from handarm.design import ArmDesign
from handarm.workspace.maps import reachability_map
from handarm.workspace.plots import sensitivity_picture, slice_picture
from handarm.workspace.scores import map_scores, min_reach_check
from handarm.workspace.sensitivity import global_sensitivity

__all__ = ["write_workspace_outputs"]


def makes_sensitivity(sensitivity: bool, scene) -> bool:
    """Whether the workspace outputs make the sensitivity screen: asked for, and no scene.

    In a scene the screen is not made: it is a question about the arm, not about its
    surroundings (and would map the design 28 more times around the obstacles).
    """
    return bool(sensitivity) and not scene


def write_workspace_outputs(
    design: ArmDesign,
    out: str | Path,
    *,
    voxel: float = 0.01,
    directions: int = 100,
    threshold: float = 0.5,
    sensitivity: bool = True,
    sensitivity_voxel: float | None = None,
    sensitivity_directions: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    sensitivity_progress: Callable[[int, int], None] | None = None,
    scene=None,
    clearance: float = 0.0,
) -> list[Path]:
    """Map, scores and pictures of ``design`` into ``out``; returns the paths written.

    The sensitivity screen maps the design 28 more times: by default at no finer than 30 mm
    and 36 directions (``sensitivity_voxel``, ``sensitivity_directions`` override), the
    settings it used recorded beside it in ``workspace.json``. ``progress(done, total)``
    counts the map's queries, ``sensitivity_progress(done, total)`` the screen's maps.
    With a ``scene`` (obstacles the links keep ``clearance`` from) the map counts only the
    ranges clear of it, ``workspace.json`` records the scene, and the sensitivity screen
    (a question about the arm, not about its surroundings) is not made.
    """
    out = Path(out)
    in_scene = bool(scene)
    sensitivity = makes_sensitivity(sensitivity, scene)
    wmap = reachability_map(
        design, voxel, directions, progress=progress, scene=scene, clearance=clearance
    )
    written = [wmap.save_npz(out / "workspace.npz")]
    report = {
        "design": design.name,
        "collision_model": wmap.collision_model,
        "joint_limits_rad": [list(pair) for pair in design.joint_limits],
        "voxel_m": voxel,
        "directions": len(wmap.directions),
        "min_width_m": wmap.min_width,
        "mirrored_y_z": list(wmap.mirrored),
        "ik_queries": wmap.queries,
        "ik_queries_per_second": wmap.queries / max(wmap.seconds, 1e-9),
        "scores": map_scores(wmap, threshold),
        "min_reach_check": min_reach_check(design),
    }
    if in_scene:
        report["scene"] = {
            "obstacles": list(scene.names),
            "clearance_m": clearance,
            "rows": scene.obstacles.tolist(),  # handarm.scene's layout, for the report
        }
    if sensitivity:
        s_voxel = max(voxel, 0.03) if sensitivity_voxel is None else sensitivity_voxel
        s_dirs = min(directions, 36) if sensitivity_directions is None else sensitivity_directions
        report["sensitivity_settings"] = {"voxel_m": s_voxel, "directions": s_dirs}
        report["sensitivity"] = global_sensitivity(
            design,
            voxel=s_voxel,
            directions=s_dirs,
            threshold=threshold,
            progress=sensitivity_progress,
        )
        written.append(
            sensitivity_picture(report["sensitivity"], out / "pictures" / "sensitivity.png")
        )
    path = out / "workspace.json"
    write_text_atomic(path, json.dumps(report, indent=2) + "\n")
    written.append(path)
    for plane in ("xy", "xz"):
        written.append(slice_picture(wmap, plane, out / "pictures" / f"workspace_{plane}.png"))
    return written
