"""handarm: design, carve, solve and drive small coupled-tendon robot arms.

The arm family is the handheld 6-DoF arm of Gregg-Smith & Mayol-Cuevas (ICRA 2016).
Everything in the Python API is SI: metres, radians, kg, N m.

The design and the kinematics are imported at once; the subpackages (``ik``, ``carve``,
``workspace``, ``firmware_bridge``, ``cad_out``, ...) and ``build`` load on first use
(PEP 562), so ``import handarm`` stays light and ``handarm.ik.solve(...)`` works without
importing ``handarm.ik`` first.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from handarm import _jitcache  # noqa: F401  (first: it stamps every kernel's cache)
from handarm._lazy import lazy_attributes
from handarm.design import PAPER_LIMITS_DEG, ArmDesign
from handarm.kinematics import (
    colliding_pairs,
    forward,
    forward_matrix,
    is_valid,
    joint_frames,
    joint_positions,
    link_crossings,
    within_limits,
)

if TYPE_CHECKING:  # pragma: no cover
    from handarm import cad_out, carve, collision, firmware_bridge, ik, transmission, workspace
    from handarm.pipeline import BuildResult, build

__version__ = "0.2.0"

_SUBMODULES = frozenset(
    {
        "cad_out",
        "carve",
        "collision",
        "firmware_bridge",
        "ik",
        "kinematics",
        "links",
        "pipeline",
        "scene",
        "report",
        "servo",
        "summary",
        "transmission",
        "workspace",
    }
)
_LAZY = {"build": "handarm.pipeline", "BuildResult": "handarm.pipeline"}

__all__ = [
    "ArmDesign",
    "BuildResult",
    "PAPER_LIMITS_DEG",
    "build",
    "cad_out",
    "carve",
    "colliding_pairs",
    "collision",
    "firmware_bridge",
    "forward",
    "forward_matrix",
    "ik",
    "is_valid",
    "joint_frames",
    "joint_positions",
    "link_crossings",
    "transmission",
    "within_limits",
    "workspace",
    "__version__",
]


__getattr__, __dir__ = lazy_attributes(__name__, _SUBMODULES, _LAZY)
