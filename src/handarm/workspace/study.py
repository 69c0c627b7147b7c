"""Joint-limit trade studies: many designs, each carved and scored, on Dask.

A study file (TOML)::

    name = "joints-2-and-5"
    design = "arm.toml"          # optional, relative to the study file; default: the paper's arm
    voxel = 0.02                 # map settings for every design (m, count, index threshold)
    directions = 48
    threshold = 0.5

    [grid]                       # every combination of these
    limit_deg_2 = [120, 135, 150]   # symmetric limit of joint 2, degrees
    limit_deg_5 = [120, 135, 150]
    clearance = [0.0003, 0.0004]    # any numeric ArmDesign field

    [weights]                    # handarm.workspace.scores.DEFAULT_WEIGHTS by name
    mass = 0.5

    [[designs]]                  # and/or explicit designs: a name and field overrides
    name = "wide-5"
    limit_deg_5 = 160

Every design is carved (mass, minimum cross-section, achieved limits) and mapped with the
achieved limits (the limits the printed links really allow, within the requested ones).
Results go to ``OUT/designs/<key>.json`` as each design finishes (atomically), so an
interrupted run loses nothing and a re-run only computes what is missing. The table, the
Pareto front and the pictures are made from those files; the per-joint sensitivity of the
base design goes to ``OUT/sensitivity.json``.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import itertools
import json
import math
import os
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handarm._io import write_bytes_atomic, write_text_atomic
from handarm.design import ArmDesign

__all__ = [
    "Study",
    "load_study",
    "evaluate_design",
    "run_study",
    "study_table",
    "study_sensitivity",
]

_SETTINGS = ("voxel", "directions", "threshold")
_STUDY_KEYS = {"name", "design", "grid", "designs", "weights", *_SETTINGS}


@dataclasses.dataclass(frozen=True)
class Study:
    """A named list of designs with the map settings and score weights they share."""

    name: str
    base: ArmDesign
    designs: tuple[tuple[str, dict, ArmDesign], ...]  # (name, parameters, design)
    voxel: float = 0.02
    directions: int = 48
    threshold: float = 0.5
    weights: dict = dataclasses.field(default_factory=dict)


def _apply(base: ArmDesign, params: dict, where: str) -> ArmDesign:
    limits = list(base.joint_limits)
    fields = {}
    for key, value in params.items():
        if key.startswith("limit_deg_"):
            try:
                k = int(key.removeprefix("limit_deg_"))
            except ValueError:
                k = 0
            if not 1 <= k <= 6:
                raise ValueError(f"{where}: {key!r}: joint number must be 1..6")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0:
                raise ValueError(
                    f"{where}: {key}: expected a positive number of degrees, got {value!r}"
                )
            limits[k - 1] = (-math.radians(value), math.radians(value))
        else:
            fields[key] = value
    try:
        return base.replace(joint_limits=tuple(limits), **fields)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def load_study(path: str | os.PathLike[str]) -> Study:
    """Read and validate a study file (see the module doc)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"study file not found: {path}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    unknown = sorted(set(data) - _STUDY_KEYS)
    if unknown:
        raise ValueError(f"{path}: unknown key {unknown[0]!r}; known: {sorted(_STUDY_KEYS)}")
    base = ArmDesign()
    if "design" in data:
        base = ArmDesign.from_toml((path.parent / data["design"]).resolve())
    designs = []
    grid = data.get("grid", {})
    if not isinstance(grid, dict):
        raise ValueError(f"{path}: grid: expected a table of lists")
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise ValueError(f"{path}: grid.{key}: expected a non-empty list")
    keys = list(grid)
    for combo in itertools.product(*(grid[k] for k in keys)) if keys else []:
        params = dict(zip(keys, combo, strict=True))
        name = ",".join(f"{k}={v}" for k, v in params.items())
        designs.append((name, params, _apply(base, params, f"{path}: grid {name}")))
    for n, entry in enumerate(data.get("designs", [])):
        if not isinstance(entry, dict):
            raise ValueError(f"{path}: designs[{n}]: expected a table")
        params = {k: v for k, v in entry.items() if k != "name"}
        name = str(entry.get("name", f"design{n}"))
        designs.append((name, params, _apply(base, params, f"{path}: designs[{n}] ({name})")))
    if not designs:
        designs.append(("base", {}, base))
    names = [d[0] for d in designs]
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: design names must be distinct")
    settings = {k: data[k] for k in _SETTINGS if k in data}
    study = Study(
        str(data.get("name", path.stem)),
        base,
        tuple(designs),
        **settings,
        weights=dict(data.get("weights", {})),
    )
    if not study.voxel > 0:
        raise ValueError(f"{path}: voxel: must be > 0, got {study.voxel}")
    if not (isinstance(study.directions, int) and study.directions >= 4):
        raise ValueError(f"{path}: directions: expected an integer >= 4, got {study.directions}")
    from handarm.workspace.scores import DEFAULT_WEIGHTS

    for key in study.weights:
        if key not in DEFAULT_WEIGHTS:
            raise ValueError(f"{path}: weights: unknown weight {key!r}")
    return study


def _key(design: ArmDesign, settings: dict) -> str:
    blob = json.dumps({"design": design.to_dict(), "settings": settings}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def evaluate_design(
    name: str,
    params: dict,
    design_dict: dict,
    settings: dict,
    weights: dict,
    threads: int | None = None,
) -> dict:
    """Carve one design and map it with the limits the carved links allow (a Dask task)."""
    if threads is not None:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    from handarm.cad_out.meshes import link_properties
    from handarm.carve import carve
    from handarm.workspace.maps import reachability_map
    from handarm.workspace.scores import design_score, map_scores

    design = ArmDesign.from_dict(design_dict)
    carved = carve(design, 2.0)
    props = [link_properties(link, design.density) for link in carved.links]
    mass = sum(p["mass_kg"] for p in props)
    strength = min(p["min_cross_section_m2"] for p in props)
    # map with what the printed links really allow, within what was asked
    achieved = tuple(
        (max(lo, j.achieved[0]), min(hi, j.achieved[1]))
        for (lo, hi), j in zip(design.joint_limits, carved.joints, strict=True)
    )
    wmap = reachability_map(
        design.replace(joint_limits=achieved), settings["voxel"], settings["directions"]
    )
    scores = map_scores(wmap, settings["threshold"])
    v_ref = scores["reference_volume_m3"]
    buf = io.BytesIO()
    np.savez_compressed(
        buf,
        index=wmap.index,
        centres=wmap.centres,
        voxel=wmap.voxel,
        reach=wmap.reach,
        handle=wmap.handle,
    )
    return {
        "name": name,
        "params": params,
        "design": design_dict,
        "settings": settings,
        **scores,
        "workspace_score": (scores["reachable_volume_m3"] + scores["dexterous_volume_m3"]) / v_ref,
        "mass_kg": mass,
        "min_cross_section_m2": strength,
        "achieved_limits_deg": [[math.degrees(v) for v in j.achieved] for j in carved.joints],
        "score": design_score(scores, mass, strength, weights),
        "map_npz": buf.getvalue(),
    }


def _pareto(rows) -> list[bool]:
    """Which rows are not dominated in (workspace score up, mass down).

    A row is dominated when another has at least its workspace score and at most its mass,
    one of them strictly.
    """
    out = []
    for r in rows:
        dominated = any(
            o["workspace_score"] >= r["workspace_score"]
            and o["mass_kg"] <= r["mass_kg"]
            and (o["workspace_score"] > r["workspace_score"] or o["mass_kg"] < r["mass_kg"])
            for o in rows
        )
        out.append(not dominated)
    return out


def run_study(
    study: Study,
    out: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    stop_after: int | None = None,
) -> dict:
    """Evaluate every design not already on disk, then write the table and pictures.

    Parameters
    ----------
    study : Study
    out : path
        Output folder; ``out/designs/`` keeps one JSON (and map) per finished design.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); default: a local cluster of
        processes started and stopped here.
    workers : int, optional
        Local worker processes (default: 2, or the number of designs if smaller).
    progress : callable, optional
        ``progress(done, total)`` as designs finish.
    stop_after : int, optional
        Stop after this many new designs (what an interruption looks like; for tests).

    Returns
    -------
    dict
        ``computed`` (designs evaluated now), ``reused`` (found on disk), ``rows``.
    """
    out = Path(out)
    settings = {"voxel": study.voxel, "directions": study.directions, "threshold": study.threshold}
    pending, reused = [], 0
    for name, params, design in study.designs:
        key = _key(design, settings)
        if (out / "designs" / f"{key}.json").exists():
            reused += 1
        else:
            pending.append((key, name, params, design))
    if stop_after is not None:
        pending = pending[:stop_after]
    total = len(study.designs)
    done = reused
    if progress:
        progress(done, total)
    if pending:
        done = _compute(
            pending, settings, study.weights, out, scheduler, workers, progress, done, total
        )
    rows = study_table(study, out)
    study_sensitivity(study, out)
    return {"computed": len(pending), "reused": reused, "rows": rows}


def study_sensitivity(study: Study, out: str | os.PathLike[str]) -> dict:
    """Per-joint sensitivity of the study's base design, at the study's map settings.

    Kept in ``out/sensitivity.json`` (with ``pictures/sensitivity.png``) and reused when the
    base design and settings are unchanged.
    """
    from handarm.workspace.plots import sensitivity_picture
    from handarm.workspace.scores import joint_sensitivity

    out = Path(out)
    path = out / "sensitivity.json"
    key = _key(
        study.base,
        {"voxel": study.voxel, "directions": study.directions, "threshold": study.threshold},
    )
    if path.exists():
        data = json.loads(path.read_text())
        if data.get("key") == key:
            return data
    data = joint_sensitivity(
        study.base, voxel=study.voxel, directions=study.directions, threshold=study.threshold
    )
    data["key"] = key
    data["design"] = study.base.name
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")
    sensitivity_picture(data, out / "pictures" / "sensitivity.png")
    return data


def _compute(pending, settings, weights, out, scheduler, workers, progress, done, total) -> int:
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        n = workers or min(2, len(pending))
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=40,
        )
        client = Client(cluster)
        threads = max(1, (os.cpu_count() or 2) // n)
    else:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise RuntimeError(f"--scheduler: cannot reach {scheduler}: {exc}") from None
        threads = None
    try:
        futures = [
            client.submit(
                evaluate_design,
                name,
                params,
                design.to_dict(),
                settings,
                weights,
                threads,
                key=f"handarm-{key}",
                pure=False,
            )
            for key, name, params, design in pending
        ]
        keys = {f.key: key for f, (key, *_rest) in zip(futures, pending, strict=True)}
        for fut in as_completed(futures):
            row = fut.result()
            key = keys[fut.key]
            write_bytes_atomic(out / "designs" / f"{key}.npz", row.pop("map_npz"))
            write_text_atomic(out / "designs" / f"{key}.json", json.dumps(row, indent=2) + "\n")
            done += 1
            if progress:
                progress(done, total)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return done


def study_table(study: Study, out: str | os.PathLike[str]) -> list[dict]:
    """Rows of the finished designs (in study order); writes results.csv and the pictures."""
    from handarm.workspace.maps import ReachabilityMap
    from handarm.workspace.plots import pareto_picture, slice_picture

    out = Path(out)
    settings = {"voxel": study.voxel, "directions": study.directions, "threshold": study.threshold}
    rows, maps = [], {}
    for name, _params, design in study.designs:
        path = out / "designs" / f"{_key(design, settings)}.json"
        if path.exists():
            row = json.loads(path.read_text())
            rows.append(row)
            maps[name] = path.with_suffix(".npz")
    if not rows:
        return rows
    for row, front in zip(rows, _pareto(rows), strict=True):
        row["pareto"] = front
    params = sorted({k for r in rows for k in r["params"]})
    columns = [
        "name",
        *params,
        "reachable_volume_m3",
        "dexterous_volume_m3",
        "mean_index",
        "workspace_score",
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
