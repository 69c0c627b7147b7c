"""Size and time of a build's report.html, broken down, against the files it shows.

    python benchmarks/bench_report.py BUILD_DIR

BUILD_DIR is what `handarm build` wrote (the default build: `handarm build --out build`).
The report is rewritten from the folder (nothing recomputed) and measured: the page, the
embedded plotly.js, the arm (meshes and collision data), the workspace figures; peers are the
build's STL files and PNG pictures. Target: the page under 15 MB.
"""

import re
import sys
import time
from pathlib import Path

from plotly.offline import get_plotlyjs

from handarm.report import write_report


def main(folder: str) -> None:
    folder = Path(folder)
    t = time.perf_counter()
    page = write_report(folder)
    seconds = time.perf_counter() - t
    text = page.read_text()
    scripts = re.findall(
        r"\(function\(\) \{ const f = (.*?);\nPlotly.newPlot\(\"(\w+)\"", text, re.S
    )
    figures = {div: len(spec.encode()) for spec, div in scripts}
    arm_js = max((len(s.encode()) for s in re.findall(r"const M = (.*?);\n", text)), default=0)
    rows = [
        ("report.html (whole page)", page.stat().st_size),
        ("  plotly.js embedded", len(get_plotlyjs().encode())),
        ("  3D arm figure", figures.get("arm3d", 0)),
        ("  arm model for the sliders (meshes, chain, collision data)", arm_js),
        ("  workspace figures", sum(v for k, v in figures.items() if k.startswith("ws"))),
        ("peer: meshes/*.stl", sum(p.stat().st_size for p in folder.glob("meshes/*.stl"))),
        ("peer: all *.png pictures", sum(p.stat().st_size for p in folder.rglob("*.png"))),
    ]
    print(f"report of {folder} written in {seconds:.1f} s (no recomputation)")
    print(f"{'item':<62} {'MB':>8}")
    for name, size in rows:
        print(f"{name:<62} {size / 1e6:8.3f}")
    print(f"target: page < 15 MB -> {'met' if rows[0][1] < 15e6 else 'NOT met'}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "build")
