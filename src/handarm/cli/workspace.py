"""``handarm workspace`` and ``handarm study``: reachability maps and trade studies."""

from __future__ import annotations

import argparse
import json

from handarm.cli._common import (
    MAP_OPTIONS,
    add_design_arg,
    add_limits,
    add_map_options,
    add_quiet,
    add_scene_options,
    limits,
    load_design,
    load_scene,
    number,
    option_error,
)

_WORKSPACE_OPTIONS = {**MAP_OPTIONS, "threshold": "--threshold"}


def cmd_workspace(args: argparse.Namespace) -> int:
    """Reachability map, workspace scores, the paper's claims checked, pictures."""
    from handarm.pipeline import map_workspace

    design = load_design(args.design)
    scene, clearance = load_scene(args)
    try:
        paths = map_workspace(
            design,
            args.out,
            voxel=args.voxel,
            directions=args.directions,
            threshold=args.threshold,
            sensitivity=not args.no_sensitivity,
            progress=not args.quiet,
            scene=scene,
            clearance=clearance,
            **limits(args),
        )
    except ValueError as exc:
        raise option_error(exc, _WORKSPACE_OPTIONS) from None
    report = json.loads(next(p for p in paths if p.name == "workspace.json").read_text())
    sc = report["scores"]
    print(
        f"reachable volume {sc['reachable_volume_m3'] * 1e3:.2f} L, dexterous volume "
        f"(index >= {sc['threshold']:g}) {sc['dexterous_volume_m3'] * 1e3:.2f} L, "
        f"mean index {sc['mean_index']:.3f}"
    )
    print(f"{report['ik_queries']} IK queries at {report['ik_queries_per_second']:,.0f}/s")
    if "scene" in report:
        print(
            f"in a scene of {len(report['scene']['obstacles'])} obstacles, "
            f"{report['scene']['clearance_m'] * 1e3:g} mm kept from them"
        )
    if "sensitivity" in report:
        print(
            "joints by Morris mu* (reachable, dexterous): "
            f"{report['sensitivity']['ranking_reachable']}, "
            f"{report['sensitivity']['ranking_dexterous']}"
        )
    print(f"wrote {args.out}")
    return 0


def cmd_study(args: argparse.Namespace) -> int:
    """Trade study: carve and score every design of STUDY.toml (resumable, on Dask)."""
    from tqdm import tqdm

    from handarm._outdir import check_out_dir
    from handarm.workspace._dask import check_scheduler
    from handarm.workspace.study_file import load_study
    from handarm.workspace.study_run import run_study

    study = load_study(args.study)
    try:
        check_scheduler(args.scheduler)
        check_out_dir(args.out)  # before the bars: a refusal is one line
    except ValueError as exc:
        raise option_error(exc, {"out": "--out", "scheduler": "--scheduler"}) from None
    with (
        tqdm(total=len(study.designs), desc=study.name, unit="design", disable=args.quiet) as bar,
        tqdm(desc="sensitivity", unit="map", disable=args.quiet, leave=False) as sens_bar,
    ):

        def tick(done: int, total: int) -> None:
            bar.update(done - bar.n)

        def sens_tick(done: int, total: int) -> None:
            sens_bar.total = total
            sens_bar.update(done - sens_bar.n)

        try:
            result = run_study(
                study,
                args.out,
                scheduler=args.scheduler,
                workers=args.workers,
                progress=tick,
                sensitivity_progress=sens_tick,
            )
        except ValueError as exc:
            raise option_error(
                exc, {"scheduler": "--scheduler", "workers": "--workers", "out": "--out"}
            ) from None
    rows = result["rows"]
    print(f"{result['computed']} designs computed, {result['reused']} found on disk")
    best = max(rows, key=lambda r: r["score"])
    print(
        f"best: {best['name']} (score {best['score']:.4f}); Pareto front: "
        + ", ".join(r["name"] for r in rows if r["pareto"])
    )
    print(f"wrote {args.out}")
    return 0


def register(sub) -> None:
    """Add the subcommands to the ``handarm`` parser."""
    p = sub.add_parser(
        "workspace",
        help="reachability map and workspace scores",
        description="Reachability map, workspace scores, the paper's claims checked, pictures.",
    )
    add_design_arg(p)
    p.add_argument(
        "--out", default="build/workspace", help="output folder (default build/workspace)"
    )
    add_map_options(p)
    p.add_argument(
        "--threshold",
        type=number(low=1e-9, high=1.0),
        default=0.5,
        help="reachability index counted as dexterous, (0, 1] (0.5)",
    )
    add_limits(p)
    p.add_argument(
        "--no-sensitivity",
        action="store_true",
        help="skip per-joint sensitivity (never made with --scene)",
    )
    add_scene_options(p)
    add_quiet(p)
    p.set_defaults(func=cmd_workspace)

    p = sub.add_parser(
        "study",
        help="joint-limit trade study (Dask)",
        description="Trade study: carve and score every design of STUDY.toml (resumable, on Dask).",
    )
    p.add_argument("study", metavar="STUDY.toml", help="study file")
    p.add_argument(
        "--out", default="build/study", help="output folder, resumable (default build/study)"
    )
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:8786",
        help="a Dask scheduler to run on (default: local processes)",
    )
    p.add_argument(
        "--workers", type=number(int, low=1, high=64), help="local worker processes (default 2)"
    )
    add_quiet(p)
    p.set_defaults(func=cmd_study)
