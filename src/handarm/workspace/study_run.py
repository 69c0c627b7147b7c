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
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handarm._io import write_bytes_atomic, write_text_atomic
from handarm._outdir import check_out_dir
from handarm._resources import check_resources
from handarm.carve import carve
from handarm.carve.properties import link_properties
from handarm.design import ArmDesign
from handarm.workspace._dask import check_scheduler, close_client, open_client
from handarm.workspace.maps import reachability_map
from handarm.workspace.plots import sensitivity_picture
from handarm.workspace.scores import map_scores
from handarm.workspace.sensitivity import global_sensitivity
from handarm.workspace.study_file import Study, design_key, study_settings
from handarm.workspace.study_results import study_table

__all__ = ["evaluate_design", "run_study", "study_sensitivity"]


def evaluate_design(
    name: str,
    params: dict,
    design_dict: dict,
    settings: dict,
    threads: int | None = None,
) -> dict:
    """Carve one design and map it with the limits the carved links allow (a Dask task).

    Only measurements are returned (and stored): the score is computed from them with the
    study's current weights whenever the table is made, so it is never stale.
    """
    if threads is not None:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))

    design = ArmDesign.from_dict(design_dict)
    carved = carve(design, 2.0)
    props = [link_properties(link, design.density) for link in carved.links]
    mass = sum(p["mass_kg"] for p in props)
    strength = min(p["min_cross_section_m2"] for p in props)
    # map with what the printed links really allow, within what was asked
    wmap = reachability_map(
        carved.as_built,
        settings["voxel"],
        settings["directions"],
        min_width=settings["min_width"],
    )
    scores = map_scores(wmap, settings["threshold"])
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
        "collision_model": wmap.collision_model,
        "mass_kg": mass,
        "min_cross_section_m2": strength,
        "achieved_limits_deg": [[math.degrees(v) for v in j.achieved] for j in carved.joints],
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
    sensitivity_progress: Callable[[int, int], None] | None = None,
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
    sensitivity_progress : callable, optional
        ``progress(done, total)`` over the maps of the global sensitivity of the base design
        (``workspace.sensitivity``), which runs on the same cluster.

    Returns
    -------
    dict
        ``computed`` (designs evaluated now), ``reused`` (found on disk), ``rows``.
    """
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        raise ValueError(f"workers: expected an integer >= 1, got {workers!r}")
    coarser = "per design: give the study file a coarser voxel or fewer directions"
    check_resources(
        study.base, voxel=study.voxel, directions=study.directions, remedy=(coarser, coarser)
    )
    check_scheduler(scheduler)
    out = check_out_dir(out)
    settings = study_settings(study)
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
    sens_path, sens_key = out / "sensitivity.json", design_key(study.base, settings)
    sens = json.loads(sens_path.read_text()) if sens_path.exists() else {}
    need_sens = sens.get("key") != sens_key and stop_after is None
    if pending or need_sens:
        client, cluster, threads, _slots = open_client(
            scheduler, workers, min(2, max(1, len(pending))), out=out
        )
        try:
            if pending:
                _compute(client, threads, pending, settings, out, progress, done, total)
            if need_sens:
                sens = study_sensitivity(study, out, client, sensitivity_progress)
        finally:
            close_client(client, cluster, out)
    rows = study_table(study, out)
    if rows:
        from handarm.report import write_report  # plotly: loaded only for the report

        write_report(out)
    return {"computed": len(pending), "reused": reused, "rows": rows, "sensitivity": sens}


def study_sensitivity(
    study: Study,
    out: str | os.PathLike[str],
    client=None,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Global sensitivity of the study's base design, at the study's map settings.

    Kept in ``out/sensitivity.json`` (with ``pictures/sensitivity.png``); runs the maps on
    ``client`` when given.
    """
    out = Path(out)
    settings = study_settings(study)
    data = global_sensitivity(
        study.base,
        voxel=study.voxel,
        directions=study.directions,
        threshold=study.threshold,
        min_width=settings["min_width"],
        client=client,
        progress=progress,
    )
    data["key"] = design_key(study.base, settings)
    data["design"] = study.base.name
    write_text_atomic(out / "sensitivity.json", json.dumps(data, indent=2) + "\n")
    sensitivity_picture(data, out / "pictures" / "sensitivity.png")
    return data


def _compute(client, threads, pending, settings, out, progress, done, total) -> int:
    from dask.distributed import as_completed

    futures = [
        client.submit(
            evaluate_design,
            name,
            params,
            design.to_dict(),
            settings,
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
    return done
