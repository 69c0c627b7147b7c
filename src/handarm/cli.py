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

    The design TOML, the summary, the carving (meshes, 3MF plate, link properties, pictures,
    the URDF with meshes and inertials) and the controller files with the achieved limits.
    """
    from handarm.firmware_bridge.export import controller_config

    out.mkdir(parents=True, exist_ok=True)
    written = [design.to_toml(out / "design.toml")]
    summary = out / "summary.txt"
    write_text_atomic(summary, design_summary(design))
    written.append(summary)
    result, paths = carve_to(design, out, quiet=quiet)
    written += paths
    config = controller_config(design, achieved_limits=[j.achieved for j in result.joints])
    written += write_controller_files(config, out / "controller")
    written += workspace_to(design, out / "workspace", quiet=quiet)
    return written


def workspace_to(
    design: ArmDesign,
    out: Path,
    *,
    voxel: float = 0.01,
    directions: int = 100,
    threshold: float = 0.5,
    sensitivity: bool = True,
    quiet: bool = False,
):
    """Map the workspace and write its outputs into ``out``, with a progress bar."""
    from tqdm import tqdm

    from handarm.workspace.report import write_workspace_outputs

    with tqdm(desc="workspace", unit="query", unit_scale=True, disable=quiet, leave=False) as bar:

        def tick(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        return write_workspace_outputs(
            design,
            out,
            voxel=voxel,
            directions=directions,
            threshold=threshold,
            sensitivity=sensitivity,
            progress=tick,
        )


def write_controller_files(config: dict, out: Path) -> list[Path]:
    """controller.json, arm_config.h and ros2_control.xml into ``out``."""
    from handarm.firmware_bridge.export import (
        write_controller_json,
        write_header,
        write_ros2_control,
    )

    return [
        write_controller_json(config, out / "controller.json"),
        write_header(config, out / "arm_config.h"),
        write_ros2_control(config, out / "ros2_control.xml"),
    ]


def carve_to(design: ArmDesign, out: Path, *, resolution: float = 1.0, quiet: bool = False):
    """Carve the design and write the carving outputs into ``out``, with a progress bar.

    Returns the CarveResult and the paths written.
    """
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
        return result, write_carve_outputs(result, out, progress=tick)


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
    _, paths = carve_to(design, out, resolution=args.resolution, quiet=args.quiet)
    for path in paths:
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


def _calibration(args, design, required=True):
    from handarm.firmware_bridge.calibration import Calibration

    if args.calibration is None:
        if required:
            raise UsageError(
                "--calibration: a calibration file is needed "
                "(record one with 'handarm bridge calibrate')"
            )
        return None
    return Calibration.load(args.calibration, design)


def cmd_bridge_export(args: argparse.Namespace) -> int:
    """Write controller.json, arm_config.h and a ros2_control fragment for the servo bus."""
    from handarm.firmware_bridge.export import controller_config

    design = _load_design(args.design)
    achieved = None
    if args.achieved is not None:
        try:
            data = json.loads(Path(args.achieved).read_text())
            achieved = [np.radians(j["achieved_deg"]) for j in data["joints"]]
        except FileNotFoundError:
            raise UsageError(f"--achieved: file not found: {args.achieved}") from None
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise UsageError(f"--achieved: not a handarm carve.json: {exc}") from None
    config = controller_config(
        design,
        _calibration(args, design, required=False),
        achieved,
        max_torque_fraction=args.max_torque,
    )
    for path in write_controller_files(config, Path(args.out)):
        print(path)
    return 0


def cmd_bridge_size(args: argparse.Namespace) -> int:
    """Largest payload of the design, and joint pulley radii that maximise it (cvxpy)."""
    from handarm.firmware_bridge import sizing

    design = _load_design(args.design)
    links = sizing.design_link_masses(design)
    if not args.no_carve:
        from handarm.carve import carve

        links = sizing.carved_link_masses(carve(design, 2.0))
    payload, info = sizing.max_payload(design, links=links, safety=args.safety)
    r_lo, r_hi = (v / 1000.0 for v in args.radius_range)
    sized = sizing.size_pulleys(
        design,
        links=links,
        safety=args.safety,
        radius_range=(r_lo, r_hi),
        min_speed=np.radians(args.min_speed),
    )
    report = {
        "torque_limit_Nm": info["torque_limit_Nm"],
        "link_masses_kg": links.masses.tolist(),
        "link_masses_from": links.source,
        "configurations": info["configurations"],
        "payload_kg": payload,
        "binding_motor": info.get("binding_motor"),
        "sized_joint_pulley_radii_mm": (sized.radii * 1000).tolist(),
        "sized_payload_kg": sized.payload,
        "min_joint_speed_deg_s": args.min_speed,
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(
        f"torque limit per motor: {info['torque_limit_Nm']:.2f} N m "
        f"({args.safety:g} x 6.0 N m stall); link masses from {links.source}"
    )
    print(
        f"(a) largest payload, gravity in any direction, {info['configurations']} "
        f"configurations: {payload:.3f} kg (motor {info.get('binding_motor')} binds)"
    )
    radii = ", ".join(f"{v * 1000:.2f}" for v in sized.radii)
    print(
        f"(b) joint pulley radii {args.radius_range[0]:g}-{args.radius_range[1]:g} mm, each "
        f"joint >= {args.min_speed:g} deg/s: [{radii}] mm -> payload {sized.payload:.3f} kg "
        "(26 gravity directions)"
    )
    return 0


def _bus(args, design):
    from handarm.firmware_bridge.bus import ServoBus

    return ServoBus(args.port, args.baud or design.baud_rate)


def cmd_bridge_apply(args: argparse.Namespace) -> int:
    """Check all six servos, write their EEPROM settings and verify them."""
    from handarm.firmware_bridge.bus import apply_settings

    design = _load_design(args.design)
    calibration = _calibration(args, design, required=False)
    with _bus(args, design) as bus:
        settings = apply_settings(bus, design, calibration)
    for sid, regs in settings.items():
        print(f"servo {sid}: " + ", ".join(f"{k}={v}" for k, v in regs.items()) + " (verified)")
    return 0


def cmd_bridge_calibrate(args: argparse.Namespace) -> int:
    """Record each motor's reading with the arm held at its zero pose (straight)."""
    from handarm.firmware_bridge.bus import record_calibration

    design = _load_design(args.design)
    with _bus(args, design) as bus:
        calibration = record_calibration(bus, design)
    print(calibration.save(args.out))
    return 0


def cmd_bridge_read(args: argparse.Namespace) -> int:
    """Print the joint angles (degrees) from the motor encoders."""
    from handarm.firmware_bridge.bus import read_joint_angles

    design = _load_design(args.design)
    calibration = _calibration(args, design)
    with _bus(args, design) as bus:
        q = read_joint_angles(bus, design, calibration)
    print(" ".join(f"{v:.2f}" for v in np.degrees(q)))
    return 0


def cmd_bridge_goto(args: argparse.Namespace) -> int:
    """Send joint targets (degrees, as 'handarm ik' prints them) in one SYNC_WRITE."""
    from handarm.firmware_bridge.bus import goal_ticks, goto

    design = _load_design(args.design)
    calibration = _calibration(args, design)
    q = np.radians(args.q)
    goal_ticks(design, calibration, q)  # refuse before opening the port
    with _bus(args, design) as bus:
        ticks = goto(bus, design, calibration, q)
    print("sent ticks: " + " ".join(str(int(t)) for t in ticks))
    return 0


def cmd_bridge_emulate(args: argparse.Namespace) -> int:
    """Run a software bus of MX-64T servos on a pseudo-terminal until Ctrl-C."""
    import time

    from handarm.firmware_bridge.emulator import EmulatedBus

    design = _load_design(args.design)
    with EmulatedBus(design.servo_ids) as bus:
        print(f"emulated MX-64T bus (IDs {list(design.servo_ids)}) on {bus.port}", flush=True)
        while True:
            time.sleep(1.0)


def cmd_workspace(args: argparse.Namespace) -> int:
    """Reachability map, workspace scores, the paper's claims checked, pictures."""
    design = _load_design(args.design)
    paths = workspace_to(
        design,
        Path(args.out),
        voxel=args.voxel,
        directions=args.directions,
        threshold=args.threshold,
        sensitivity=not args.no_sensitivity,
        quiet=args.quiet,
    )
    report = json.loads(next(p for p in paths if p.name == "workspace.json").read_text())
    sc = report["scores"]
    print(
        f"reachable volume {sc['reachable_volume_m3'] * 1e3:.2f} L, dexterous volume "
        f"(index >= {sc['threshold']:g}) {sc['dexterous_volume_m3'] * 1e3:.2f} L, "
        f"mean index {sc['mean_index']:.3f}"
    )
    print(f"{report['ik_queries']} IK queries at {report['ik_queries_per_second']:,.0f}/s")
    if "sensitivity" in report:
        print(
            "most sensitive joints (reachable, dexterous): "
            f"{report['sensitivity']['most_sensitive_reachable']}, "
            f"{report['sensitivity']['most_sensitive_dexterous']}"
        )
    print(f"wrote {args.out}")
    return 0


def cmd_study(args: argparse.Namespace) -> int:
    """Trade study: carve and score every design of STUDY.toml (resumable, on Dask)."""
    from tqdm import tqdm

    from handarm.workspace.study import load_study, run_study

    study = load_study(args.study)
    with tqdm(total=len(study.designs), desc=study.name, unit="design", disable=args.quiet) as bar:

        def tick(done: int, total: int) -> None:
            bar.update(done - bar.n)

        result = run_study(
            study, Path(args.out), scheduler=args.scheduler, workers=args.workers, progress=tick
        )
    rows = result["rows"]
    print(f"{result['computed']} designs computed, {result['reused']} found on disk")
    best = max(rows, key=lambda r: r["score"])
    print(
        f"best: {best['name']} (score {best['score']:.4f}); Pareto front: "
        + ", ".join(r["name"] for r in rows if r["pareto"])
    )
    print(f"wrote {args.out}")
    return 0


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

    bridge = sub.add_parser(
        "bridge",
        help="servo controller: export, sizing, live bus",
        description="Firmware bridge to six Dynamixel MX-64T servos.",
    )
    bsub = bridge.add_subparsers(dest="bridge_command", metavar="ACTION")
    bsub.required = True
    p = bsub.add_parser(
        "export",
        help="controller.json, arm_config.h, ros2_control.xml",
        description=cmd_bridge_export.__doc__,
    )
    _add_design_arg(p)
    p.add_argument("--out", default="build/controller", help="output folder")
    p.add_argument("--calibration", metavar="FILE", help="calibration JSON to include")
    p.add_argument(
        "--achieved",
        metavar="CARVE_JSON",
        help="carve.json from 'handarm carve': export the achieved limits",
    )
    p.add_argument(
        "--max-torque",
        type=float,
        default=1.0,
        metavar="FRACTION",
        help="Max Torque register as a fraction of 1023 (default 1)",
    )
    p.set_defaults(func=cmd_bridge_export)
    p = bsub.add_parser(
        "size", help="payload and pulley sizing (cvxpy)", description=cmd_bridge_size.__doc__
    )
    _add_design_arg(p)
    p.add_argument(
        "--safety",
        type=float,
        default=0.5,
        help="fraction of the 6.0 N m stall torque a motor may use (default 0.5)",
    )
    p.add_argument(
        "--min-speed",
        type=float,
        default=180.0,
        metavar="DEG_S",
        help="slowest acceptable joint speed, deg/s (default 180)",
    )
    p.add_argument(
        "--radius-range",
        type=float,
        nargs=2,
        default=(4.0, 20.0),
        metavar=("MIN_MM", "MAX_MM"),
        help="manufacturable pulley radii, mm",
    )
    p.add_argument(
        "--no-carve",
        action="store_true",
        help="estimate link masses from the design instead of carving",
    )
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_bridge_size)
    for name, func, needs_cal in (
        ("apply", cmd_bridge_apply, False),
        ("calibrate", cmd_bridge_calibrate, False),
        ("read", cmd_bridge_read, True),
        ("goto", cmd_bridge_goto, True),
    ):
        p = bsub.add_parser(
            name,
            help=func.__doc__[0].lower() + func.__doc__.split(".")[0][1:],
            description=func.__doc__,
        )
        if name == "goto":
            p.add_argument("q", nargs=6, type=float, metavar="Q", help="joint targets, degrees")
            p.add_argument("--design", metavar="DESIGN.toml", help="arm design")
        else:
            _add_design_arg(p)
        p.add_argument("--port", required=True, help="serial port, e.g. /dev/ttyUSB0")
        p.add_argument("--baud", type=int, help="bit rate (default: the design's)")
        if name == "calibrate":
            p.add_argument("--out", default="calibration.json", help="calibration file to write")
        else:
            p.add_argument(
                "--calibration",
                metavar="FILE",
                required=needs_cal,
                help="calibration JSON from 'handarm bridge calibrate'",
            )
        p.set_defaults(func=func)
    p = bsub.add_parser(
        "emulate",
        help="software MX-64T bus on a pseudo-terminal",
        description=cmd_bridge_emulate.__doc__,
    )
    _add_design_arg(p)
    p.set_defaults(func=cmd_bridge_emulate)

    p = sub.add_parser(
        "workspace", help="reachability map and workspace scores", description=cmd_workspace.__doc__
    )
    _add_design_arg(p)
    p.add_argument("--out", default="build/workspace", help="output folder")
    p.add_argument("--voxel", type=float, default=0.01, metavar="M", help="voxel edge, m (0.01)")
    p.add_argument("--directions", type=int, default=100, help="approach directions (100)")
    p.add_argument(
        "--threshold", type=float, default=0.5, help="reachability index counted as dexterous (0.5)"
    )
    p.add_argument("--no-sensitivity", action="store_true", help="skip per-joint sensitivity")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_workspace)

    p = sub.add_parser(
        "study", help="joint-limit trade study (Dask)", description=cmd_study.__doc__
    )
    p.add_argument("study", metavar="STUDY.toml", help="study file")
    p.add_argument("--out", default="build/study", help="output folder (resumable)")
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:8786",
        help="a Dask scheduler to run on (default: local processes)",
    )
    p.add_argument("--workers", type=int, help="local worker processes (default 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_study)

    p = sub.add_parser("urdf", help="write the design as URDF", description=cmd_urdf.__doc__)
    _add_design_arg(p)
    p.add_argument("--out", required=True, metavar="FILE", help="URDF file to write")
    p.set_defaults(func=cmd_urdf)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = make_parser()
    args = parser.parse_args(argv)
    name = " ".join(filter(None, (args.command, getattr(args, "bridge_command", None))))
    try:
        return args.func(args)
    except (UsageError, ValueError, OSError) as exc:
        print(f"handarm {name}: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # the servo bus (BusError) or a solver said no
        print(f"handarm {name}: error: {exc}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print(f"handarm {name}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
