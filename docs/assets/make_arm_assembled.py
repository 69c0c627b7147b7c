"""Regenerate docs/assets/arm_assembled.png, the picture the README and docs show.

    python docs/assets/make_arm_assembled.py

It draws the default design's carved links, handle, servos and pulleys with the same code
``handarm build`` uses for ``pictures/arm_assembled.png``, at a small size.
"""

from pathlib import Path

import handarm
from handarm.cad_out.handle_files import (
    _picture,  # noqa: PLC2701 - the build's own drawing
    assembled_meshes,
)
from handarm.carve import carve
from handarm.handle import handle

if __name__ == "__main__":
    design = handarm.ArmDesign()
    carving = carve(design)
    h = handle(design, carving)
    out = Path(__file__).with_name("arm_assembled.png")
    _picture(
        assembled_meshes(h, carving),
        set(),
        out,
        "the default arm with its handle, servos and motor pulleys",
    )
    print(f"wrote {out} ({out.stat().st_size} bytes)")
