"""A two-design trade study on a coarse map (one worker process).

python examples/small_study.py [OUT_DIR]
"""

import sys
import tempfile
from pathlib import Path

from handarm.workspace.study_file import load_study
from handarm.workspace.study_run import run_study

STUDY = """
name = "elbow-limits"
voxel = 0.05
directions = 16

[grid]
# the printed arm's cables stop joint 5 at about 88 degrees, whatever limit is asked:
# compare limits under that, or both designs carve the same
limit_deg_5 = [60, 85]
"""


def main(out: str | None = None) -> None:
    out = Path(out or tempfile.mkdtemp())
    study_file = out / "study.toml"
    out.mkdir(parents=True, exist_ok=True)
    study_file.write_text(STUDY)
    study = load_study(study_file)
    result = run_study(study, out / "results", workers=1)
    for row in result["rows"]:
        print(
            f"{row['name']:>16}: reachable {row['reachable_volume_m3'] * 1e3:6.2f} L, "
            f"mass {row['mass_kg'] * 1e3:5.1f} g, Pareto {row['pareto']}"
        )
    narrow, wide = sorted(result["rows"], key=lambda r: r["name"])
    assert wide["reachable_volume_m3"] > narrow["reachable_volume_m3"], "the limit changed nothing"
    print(f"results in {out / 'results'}")


if __name__ == "__main__":
    main(*sys.argv[1:])
