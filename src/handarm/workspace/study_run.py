"""Running a study: each design carved and mapped on Dask, results kept as they finish.

Every design is carved (mass, minimum cross-section, achieved limits) and mapped with the
achieved limits (what the printed links really allow, within the requested ones). Results go
to ``OUT/designs/<key>.json`` as each design finishes (atomically), so an interrupted run
loses nothing and a re-run only computes what is missing.
"""

from __future__ import annotations

import io
import json
import math
import os
import signal
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handarm._io import write_bytes_atomic, write_text_atomic
from handarm._outdir import check_out_dir
from handarm._resources import check_resources
from handarm.carve import carve
from handarm.carve.properties import link_properties
from handarm.design import ArmDesign
from handarm.workspace.maps import reachability_map
from handarm.workspace.plots import sensitivity_picture
from handarm.workspace.scores import design_score, joint_sensitivity, map_scores
from handarm.workspace.study_file import Study, design_key
from handarm.workspace.study_results import study_table

__all__ = ["evaluate_design", "run_study", "study_sensitivity"]


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


def run_study(
    study: Study,
    out: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    stop_after: int | None = None,
) -> dict:
    """Evaluate every design not already on disk, then the table, pictures and report.html.

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
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        raise ValueError(f"workers: expected an integer >= 1, got {workers!r}")
    check_resources(study.base, voxel=study.voxel, directions=study.directions)
    out = check_out_dir(out)
    settings = {"voxel": study.voxel, "directions": study.directions, "threshold": study.threshold}
    pending, reused = [], 0
    for name, params, design in study.designs:
        key = design_key(design, settings)
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
    if rows:
        from handarm.report import write_report  # plotly: loaded only for the report

        write_report(out)
    return {"computed": len(pending), "reused": reused, "rows": rows}


def study_sensitivity(study: Study, out: str | os.PathLike[str]) -> dict:
    """Per-joint sensitivity of the study's base design, at the study's map settings.

    Kept in ``out/sensitivity.json`` (with ``pictures/sensitivity.png``) and reused when the
    base design and settings are unchanged.
    """
    out = Path(out)
    path = out / "sensitivity.json"
    key = design_key(
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
    # dask.distributed takes about a second to import: only when a study runs
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        n = workers or min(2, len(pending))
        # worker processes inherit an ignored SIGINT: Ctrl-C reaches only this process,
        # which closes the cluster, instead of every worker printing a traceback
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=50,
            )
        finally:
            signal.signal(signal.SIGINT, previous)
        client = Client(cluster)
        threads = max(1, (os.cpu_count() or 2) // n)
    else:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise RuntimeError(f"scheduler: cannot reach {scheduler}: {exc}") from None
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
