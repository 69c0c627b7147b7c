"""Check that a `handarm build` folder holds what the README says it writes.

    python .ci/check_build.py BUILD_DIR

EXPECTED lists path patterns relative to the build folder (glob, with the number of matches
required); tests/test_ci.py checks that the README names every one of them. Exit status 1,
with the missing entries listed, if something is not there or is empty.
"""

from __future__ import annotations

import sys
from pathlib import Path

#: (README name, glob pattern, number of files)
EXPECTED = [
    ("design.toml", "design.toml", 1),
    ("summary.txt", "summary.txt", 1),
    ("meshes/l0.stl", "meshes/l?.stl", 7),
    ("parts/l0.stl", "parts/l0.stl", 1),
    ("plate.3mf", "plate.3mf", 1),
    ("links/l0.json", "links/l?.json", 7),
    ("carve.json", "carve.json", 1),
    ("paper_arm.urdf", "paper_arm.urdf", 1),
    ("paper_arm.mjcf.xml", "paper_arm.mjcf.xml", 1),
    ("handle/saddle.stl", "handle/saddle.stl", 1),
    ("handle/bed.stl", "handle/bed.stl", 1),
    ("handle/pulley_flange.stl", "handle/pulley_flange.stl", 1),
    ("handle/pulley_drum.stl", "handle/pulley_drum.stl", 1),
    ("handle/handle.json", "handle/handle.json", 1),
    ("bom.csv", "bom.csv", 1),
    ("assembly.html", "assembly.html", 1),
    ("pictures/arm_assembled.png", "pictures/arm_assembled.png", 1),
    ("pictures/arm_folded.png", "pictures/arm_folded.png", 1),
    ("controller/controller.json", "controller/controller.json", 1),
    ("controller/arm_config.h", "controller/arm_config.h", 1),
    ("workspace/workspace.npz", "workspace/workspace.npz", 1),
    ("workspace/workspace.json", "workspace/workspace.json", 1),
    ("sizing.json", "sizing.json", 1),
    ("report.html", "report.html", 1),
    ("handarm-build.json", "handarm-build.json", 1),
]


def main(folder: str) -> int:
    """Return 0 when every expected file is there and not empty."""
    root = Path(folder)
    missing = []
    for name, pattern, count in EXPECTED:
        found = [p for p in root.glob(pattern) if p.is_file() and p.stat().st_size > 0]
        if len(found) != count:
            missing.append(f"{name}: expected {count} file(s) matching {pattern}, got {len(found)}")
    leftovers = [str(p) for p in root.rglob("*.tmp")]
    if leftovers:
        missing.append(f"half-written files left behind: {leftovers}")
    if (root / ".handarm-incomplete").exists():
        missing.append("the build folder is marked incomplete")
    for line in missing:
        print(f"check_build: {line}", file=sys.stderr)
    if not missing:
        print(f"check_build: {root} holds everything the README lists ({len(EXPECTED)} entries)")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "build"))
