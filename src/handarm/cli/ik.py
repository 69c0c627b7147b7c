"""``handarm ik``: every solution of one target."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from handarm.cli._common import (
    add_scene_options,
    load_design,
    load_scene,
    number,
    option_error,
    out_file,
)

_OPTIONS = {"p": "--pos", "e": "--dir", "current": "--current", "clearance": "--clearance"}


def cmd_ik(args: argparse.Namespace) -> int:
    """Every inverse-kinematics solution of one target (angles in degrees)."""
    from handarm import ik

    design = load_design(args.design)
    current = None if args.current is None else np.radians(args.current)
    scene, clearance = load_scene(args)
    picture = _picture_path(args.picture)
    try:
        result = ik.solve(
            design,
            args.pos,
            args.dir,
            current=current,
            degrade=not args.exact,
            scene=scene,
            clearance=clearance,
        )
    except ValueError as exc:
        raise option_error(exc, _OPTIONS) from None
    if scene is not None and result.blocked_by and not args.json:
        print(f"no exact solution keeps clear of: {', '.join(result.blocked_by)}")
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(ik.format_result(result), end="")
    if picture is not None:
        from handarm.cad_out.scene_picture import scene_picture
        from handarm.scene import Scene

        scene_picture(design, Scene.empty() if scene is None else scene, result, picture)
        if not args.json:
            print(f"wrote {picture}")
    return 0 if result.count else 1


def _picture_path(value: str | None) -> Path | None:
    """--picture checked before any work: a .png in an existing folder, not a folder."""
    return None if value is None else out_file(value, "--picture", ".png")


def register(sub) -> None:
    """Add the subcommand to the ``handarm`` parser."""
    p = sub.add_parser(
        "ik",
        help="solve the inverse kinematics of one target",
        description="Every inverse-kinematics solution of one target (angles in degrees). "
        "Exit status 1 when there is no solution at all.",
    )
    p.add_argument(
        "--pos",
        nargs=3,
        type=number(low=-10.0, high=10.0),
        required=True,
        metavar=("X", "Y", "Z"),
        help="tool point in metres, base frame",
    )
    p.add_argument(
        "--dir",
        nargs=3,
        type=number(low=-1e6, high=1e6),
        required=True,
        metavar=("DX", "DY", "DZ"),
        help="tool direction (any length but zero)",
    )
    p.add_argument("--design", metavar="DESIGN.toml", help="arm design (default: the paper's arm)")
    p.add_argument(
        "--current",
        nargs=6,
        type=number(low=-360, high=360),
        metavar="Q",
        help="present joint angles, degrees",
    )
    p.add_argument("--exact", action="store_true", help="no graceful degradation")
    add_scene_options(p)
    p.add_argument(
        "--picture",
        metavar="FILE.png",
        help="draw the arm along every range (and the scene's obstacles) into this PNG",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=cmd_ik)
