"""The ``handarm`` command: argument parsing only; every action is a library call.

A user mistake (missing file, bad TOML, bad value) prints one line and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from handarm import __version__
from handarm._io import write_text_atomic
from handarm.cad_out.urdf import write_urdf
from handarm.design import ArmDesign
from handarm.summary import design_summary


class UsageError(Exception):
    """A mistake in what the user asked for; reported as one line, exit status 2."""


def _load_design(path: str | None) -> ArmDesign:
    return ArmDesign() if path is None else ArmDesign.from_toml(path)


def _add_design_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "design", nargs="?", metavar="DESIGN.toml", help="arm design (default: the paper's arm)"
    )


# -- subcommands -------------------------------------------------------------------------------


def cmd_build(args: argparse.Namespace) -> int:
    """Everything for one design: design TOML, URDF, summary."""
    design = _load_design(args.design)
    out = Path(args.out)
    written = build(design, out, quiet=args.quiet)
    for path in written:
        print(path)
    return 0


def build(design: ArmDesign, out: Path, *, quiet: bool = False) -> list[Path]:
    """Write every output of ``handarm build`` for ``design`` into ``out``; returns the paths.

    The design TOML, the summary, and the carving (meshes, 3MF plate, link properties,
    pictures, and the URDF with meshes and inertials).
    """
    out.mkdir(parents=True, exist_ok=True)
    written = [design.to_toml(out / "design.toml")]
    summary = out / "summary.txt"
    write_text_atomic(summary, design_summary(design))
    written.append(summary)
    written += carve_to(design, out, quiet=quiet)
    return written


def carve_to(design: ArmDesign, out: Path, *, resolution: float = 1.0, quiet: bool = False):
    """Carve the design and write the carving outputs into ``out``, with a progress bar."""
    from tqdm import tqdm

    from handarm.cad_out.carve_files import OUTPUT_STEPS, write_carve_outputs
    from handarm.carve import CARVE_STEPS, carve, check_carvable

    check_carvable(design)
    with tqdm(
        total=CARVE_STEPS + OUTPUT_STEPS, desc="carving", unit="step", disable=quiet, leave=False
    ) as bar:

        def tick(label: str) -> None:
            bar.set_postfix_str(label)
            bar.update()

        result = carve(design, resolution, progress=tick)
        return write_carve_outputs(result, out, progress=tick)


def cmd_ik(args: argparse.Namespace) -> int:
    """Every inverse-kinematics solution of one target (angles in degrees)."""
    from handarm import ik

    design = _load_design(args.design)
    current = None if args.current is None else np.radians(args.current)
    try:
        result = ik.solve(design, args.pos, args.dir, current=current, degrade=not args.exact)
    except ValueError as exc:
        # the library names its arguments; say the option the user typed
        msg = str(exc)
        for arg, option in (("p:", "--pos:"), ("e:", "--dir:"), ("current:", "--current:")):
            if msg.startswith(arg):
                msg = option + msg[len(arg) :]
        raise UsageError(msg) from None
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(ik.format_result(result), end="")
    return 0 if result.count else 1


def cmd_carve(args: argparse.Namespace) -> int:
    """Carve the links: STL per link, a 3MF plate, properties, pictures, URDF with meshes."""
    design = _load_design(args.design)
    out = Path(args.out)
    for path in carve_to(design, out, resolution=args.resolution, quiet=args.quiet):
        if path.name == "carve.json":
            _print_limits(path)
    print(f"wrote {out}")
    return 0


def _print_limits(path: Path) -> None:
    data = json.loads(path.read_text())
    print("joint  requested (deg)     achieved (deg)      stopped by (upper side)")
    for j in data["joints"]:
        req, ach = j["requested_deg"], j["achieved_deg"]
        print(
            f"{j['joint']:>5}  {req[0]:7.2f} {req[1]:7.2f}     {ach[0]:7.2f} {ach[1]:7.2f}     "
            f"{j['stopped_by']['upper']}"
        )
    print(f"total link mass {data['total_mass_kg'] * 1e3:.1f} g")


def cmd_urdf(args: argparse.Namespace) -> int:
    """Write the design as URDF."""
    design = _load_design(args.design)
    print(write_urdf(design, args.out))
    return 0


# -- parser ------------------------------------------------------------------------------------


def make_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``handarm`` command."""
    parser = argparse.ArgumentParser(
        prog="handarm",
        description="Design, carve, solve and drive small coupled-tendon robot arms.",
    )
    parser.add_argument("--version", action="version", version=f"handarm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser(
        "build", help="everything for one design (the main job)", description=cmd_build.__doc__
    )
    _add_design_arg(p)
    p.add_argument("--out", default="build", help="output folder (default: build)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_build)

    p = sub.add_parser(
        "carve",
        help="carve printable links and measure their joint limits",
        description=cmd_carve.__doc__,
    )
    _add_design_arg(p)
    p.add_argument("--out", default="build/carve", help="output folder (default: build/carve)")
    p.add_argument(
        "--resolution",
        type=float,
        default=1.0,
        metavar="DEG",
        help="largest angle between swept poses, degrees (default 1)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_carve)

    p = sub.add_parser(
        "ik",
        help="solve the inverse kinematics of one target",
        description=(cmd_ik.__doc__ + " Exit status 1 when there is no solution at all."),
    )
    p.add_argument(
        "--pos",
        nargs=3,
        type=float,
        required=True,
        metavar=("X", "Y", "Z"),
        help="tool point in metres, base frame",
    )
    p.add_argument(
        "--dir",
        nargs=3,
        type=float,
        required=True,
        metavar=("DX", "DY", "DZ"),
        help="tool direction (any length but zero)",
    )
    p.add_argument("--design", metavar="DESIGN.toml", help="arm design (default: the paper's arm)")
    p.add_argument(
        "--current", nargs=6, type=float, metavar="Q", help="present joint angles, degrees"
    )
    p.add_argument("--exact", action="store_true", help="no graceful degradation")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=cmd_ik)

    p = sub.add_parser("urdf", help="write the design as URDF", description=cmd_urdf.__doc__)
    _add_design_arg(p)
    p.add_argument("--out", required=True, metavar="FILE", help="URDF file to write")
    p.set_defaults(func=cmd_urdf)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = make_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (UsageError, ValueError, OSError) as exc:
        print(f"handarm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"handarm {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
