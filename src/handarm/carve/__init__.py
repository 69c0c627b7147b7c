"""Space carving of link geometry (paper II-A.2): blanks, swept neighbours, achieved limits.

``carve(design)`` returns the seven carved links (manifold3d solids, mm, link frames) and, per
joint, the requested, carved and achieved limits with what stops each side.
"""

from handarm._lazy import lazy_attributes
from handarm.carve.carving import CarvedLink, CarveResult, JointReport, carve, check_carvable
from handarm.links import joint_geometry, link_blank

__all__ = [
    "CarveResult",
    "CarvedLink",
    "JointReport",
    "carve",
    "check_carvable",
    "joint_geometry",
    "link_blank",
    "CARVE_STEPS",
]

#: Progress ticks ``carve`` makes (for a progress bar's total).
CARVE_STEPS = 6 + 7 + 6 + 1

__getattr__, __dir__ = lazy_attributes(__name__, {"carving", "properties", "sweep"})
