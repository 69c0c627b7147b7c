"""File writers for what the design and the carving make: URDF, STL, 3MF, pictures.

``write_urdf`` / ``urdf_string`` need only the design; ``carve_files``, ``meshes`` and
``pictures`` (loaded on first use) write what ``handarm.carve`` makes.
"""

from __future__ import annotations

from handarm._lazy import lazy_attributes
from handarm.cad_out.urdf import urdf_string, write_urdf

_MODULES = frozenset({"carve_files", "meshes", "pictures", "urdf"})

__all__ = ["urdf_string", "write_urdf"]


__getattr__, __dir__ = lazy_attributes(__name__, _MODULES)
