"""File writers for what the design and the carving make: URDF, STL, 3MF, GLB, pictures."""

from handarm.cad_out.urdf import urdf_string, write_urdf

__all__ = ["urdf_string", "write_urdf"]
