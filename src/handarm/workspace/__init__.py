"""Reachability maps, workspace scores and trade studies on top of the batch IK.

``reachability_map(design)`` maps what the arm reaches with how many approach directions;
``map_scores`` turns a map into volumes; ``load_study`` / ``run_study`` evaluate many
designs on Dask. The modules (``maps``, ``scores``, ``plots``, ``report``, ``study_file``,
``study_run``, ``study_results``) load on first use.
"""

from __future__ import annotations

from handarm._lazy import lazy_attributes

_MODULES = frozenset(
    {"maps", "scores", "plots", "report", "study_file", "study_run", "study_results"}
)
_NAMES = {
    "ReachabilityMap": "maps",
    "direction_set": "maps",
    "reachability_map": "maps",
    "map_scores": "scores",
    "min_reach_check": "scores",
    "joint_sensitivity": "scores",
    "Study": "study_file",
    "load_study": "study_file",
    "run_study": "study_run",
}

__all__ = sorted(_NAMES)


__getattr__, __dir__ = lazy_attributes(__name__, _MODULES, _NAMES)
