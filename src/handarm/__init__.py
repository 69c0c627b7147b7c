"""handarm: design, carve, solve and drive small coupled-tendon robot arms.

The arm family is the handheld 6-DoF arm of Gregg-Smith & Mayol-Cuevas (ICRA 2016).
Everything in the Python API is SI: metres, radians, kg, N m.
"""

from handarm.design import PAPER_LIMITS_DEG, ArmDesign
from handarm.kinematics import (
    forward,
    forward_matrix,
    is_valid,
    joint_frames,
    joint_positions,
    link_crossings,
    within_limits,
)

__version__ = "0.1.0"

__all__ = [
    "ArmDesign",
    "PAPER_LIMITS_DEG",
    "forward",
    "forward_matrix",
    "is_valid",
    "joint_frames",
    "joint_positions",
    "link_crossings",
    "within_limits",
    "__version__",
]
