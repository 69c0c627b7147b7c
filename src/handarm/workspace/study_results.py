"""Results of a study: the table, the Pareto front, pictures and a summary."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path

import numpy as np

from handarm._io import write_text_atomic
from handarm.workspace.maps import ReachabilityMap
from handarm.workspace.plots import pareto_picture, slice_picture
from handarm.workspace.scores import design_score
from handarm.workspace.study_file import Study, design_key, study_settings

__all__ = ["pareto_front", "study_table"]


#: (row key, direction) of the study's Pareto front: physical units, none normalised
PARETO_OBJECTIVES = (
    ("reachable_volume_m3", 1),
    ("dexterous_volume_m3", 1),
    ("mass_kg", -1),
    ("min_cross_section_m2", 1),
)


def pareto_front(rows) -> list[bool]:
    """Which rows are not dominated in ``PARETO_OBJECTIVES``.

    Volumes and the minimum cross-section up, mass down; a row is dominated when another
    is at least as good in every objective and better in one.
    """
    pts = np.array([[s * r[k] for k, s in PARETO_OBJECTIVES] for r in rows]).reshape(
        len(rows), len(PARETO_OBJECTIVES)
    )
    return [not any(np.all(o >= p) and np.any(o > p) for o in pts) for p in pts]


def study_table(study: Study, out: str | os.PathLike[str]) -> list[dict]:
    """Rows of the finished designs (in study order); writes results.csv and the pictures."""
    out = Path(out)
    settings = study_settings(study)
    rows, maps = [], {}
    for name, _params, design in study.designs:
        path = out / "designs" / f"{design_key(design, settings)}.json"
        if path.exists():
            row = json.loads(path.read_text())
            # the score is recomputed from the measurements with today's weights
            row["score"] = design_score(
                row, row["mass_kg"], row["min_cross_section_m2"], study.weights
            )
            rows.append(row)
            maps[name] = path.with_suffix(".npz")
    if not rows:
        return rows
    for row, front in zip(rows, pareto_front(rows), strict=True):
        row["pareto"] = front
    params = sorted({k for r in rows for k in r["params"]})
    columns = [
        "name",
        *params,
        "reachable_volume_m3",
        "dexterous_volume_m3",
        "mean_index",
        "mass_kg",
        "min_cross_section_m2",
        "score",
        "pareto",
    ]
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(columns)
    for r in rows:
        writer.writerow(
            [
                r["name"],
                *[r["params"].get(p, "") for p in params],
                *[r[c] for c in columns[1 + len(params) :]],
            ]
        )
    write_text_atomic(out / "results.csv", buf.getvalue())
    pareto_picture(rows, out / "pictures" / "pareto.png")
    best = max(rows, key=lambda r: r["score"])
    with np.load(maps[best["name"]]) as z:
        wmap = ReachabilityMap(
            float(z["voxel"]),
            z["centres"],
            z["index"],
            z["index"],
            z["index"] > 0,
            np.zeros((0, 3)),
            float(z["reach"]),
            (False, False),
            0,
            0.0,
            float(z["handle"]),
        )
    for plane in ("xy", "xz"):
        slice_picture(
            wmap,
            plane,
            out / "pictures" / f"best_{plane}.png",
            title=f"best design {best['name']!r}: {plane} slice",
        )
    summary = {
        "study": study.name,
        "designs": len(study.designs),
        "finished": len(rows),
        "best": best["name"],
        "best_score": best["score"],
        "pareto": [r["name"] for r in rows if r["pareto"]],
    }
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    return rows
