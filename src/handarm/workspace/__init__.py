"""Reachability maps, workspace scores and trade studies on top of the batch IK.

``reachability_map(design)`` maps what the arm reaches with how many approach directions;
``map_scores`` turns a map into volumes; ``load_study`` / ``run_study`` evaluate many
designs on Dask; ``load_opt`` / ``run_optimization`` search a design space on Optuna
(``handarm optimize``); ``global_sensitivity`` screens the joint limits. The modules load on
first use.
"""

from __future__ import annotations

from handarm._lazy import lazy_attributes

_MODULES = frozenset(
    {
        "maps",
        "scores",
        "plots",
        "report",
        "study_file",
        "study_run",
        "study_results",
        "opt_file",
        "optimize",
        "opt_plots",
        "sensitivity",
    }
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
    "load_opt": "opt_file",
    "run_optimization": "optimize",
    "global_sensitivity": "sensitivity",
    "paper_3r_section_check": "sensitivity",
}

__all__ = sorted(_NAMES)


__getattr__, __dir__ = lazy_attributes(__name__, _MODULES, _NAMES)
