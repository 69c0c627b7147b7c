"""``handarm bridge ...``: the servo controller (export, sizing, the live bus, an emulator)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

from handarm.cli._common import (
    UsageError,
    add_design_arg,
    add_scene_options,
    load_design,
    load_scene,
    number,
    option_error,
)

#: The bridge library's argument names and the options that set them: an error naming
#: ``timeout`` is reported as ``--timeout``.
OPTIONS = {
    "timeout": "--timeout",
    "max_torque_fraction": "--max-torque",
    "joint": "--joint",
    "calibration": "--calibration",
    "rate": "--rate",
    "baud": "--baud",
    "port": "--port",
    "out": "--out",
    "source": "--source",
}


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


def _achieved_limits(path):
    from handarm.cad_out.carve_files import read_achieved_limits

    if path is None:
        return None
    try:
        return read_achieved_limits(path)
    except (OSError, ValueError) as exc:
        raise UsageError(f"--achieved: {exc}") from None


def _live_design(args: argparse.Namespace):
    """The design a live command drives: its limits narrowed to ``--achieved``'s, if given.

    Without ``--achieved`` the limits are the design's as requested, which the printed parts
    may not allow (a cable meeting a link first; the bridge guide says so).
    """
    design = load_design(args.design)
    achieved = _achieved_limits(args.achieved)
    if achieved is None:
        return design
    try:
        return design.limited_to(achieved)
    except ValueError as exc:
        raise UsageError(f"--achieved: {exc}") from None


def cmd_export(args: argparse.Namespace) -> int:
    """Write controller.json and arm_config.h."""
    from handarm.pipeline import export_controller

    design = load_design(args.design)
    achieved = _achieved_limits(args.achieved)
    try:
        paths = export_controller(
            design,
            args.out,
            calibration=_calibration(args, design, required=False),
            achieved_limits=achieved,
            max_torque_fraction=args.max_torque,
        )
    except ValueError as exc:
        raise option_error(exc, OPTIONS) from None
    for path in paths:
        print(path)
    return 0


def cmd_size(args: argparse.Namespace) -> int:
    """Largest payload of the design, and joint pulley radii that maximise it (cvxpy)."""
    from handarm.firmware_bridge import sizing

    design = load_design(args.design)
    lo_mm, hi_mm = args.radius_range
    if not lo_mm < hi_mm:
        raise UsageError(f"--radius-range: expected MIN_MM < MAX_MM, got {lo_mm:g} {hi_mm:g}")
    try:
        report = sizing.sizing_report(
            design,
            safety=args.safety,
            radius_range=(args.radius_range[0] / 1000.0, args.radius_range[1] / 1000.0),
            min_speed=math.radians(args.min_speed),
            carve_links=not args.no_carve,
        )
    except ValueError as exc:
        raise option_error(
            exc,
            {"safety": "--safety", "radius_range": "--radius-range", "min_speed": "--min-speed"},
        ) from None
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(
        f"torque limit per motor: {report['torque_limit_Nm']:.2f} N m ({args.safety:g} x "
        f"{design.servo.stall_torque:g} N m stall); link masses from "
        f"{report['link_masses_from']}"
    )
    print(
        f"(a) largest payload, gravity in any direction, {report['configurations']} "
        f"configurations: {report['payload_kg']:.3f} kg (motor {report['binding_motor']} binds)"
    )
    radii = ", ".join(f"{v:.2f}" for v in report["sized_joint_pulley_radii_mm"])
    print(
        f"(b) joint pulley radii {args.radius_range[0]:g}-{args.radius_range[1]:g} mm, each "
        f"joint >= {args.min_speed:g} deg/s: [{radii}] mm -> payload "
        f"{report['sized_payload_kg']:.3f} kg ({report['sizing_gravity']})"
    )
    return 0


def _bus(args, design):
    from handarm.firmware_bridge.bus import ServoBus

    return ServoBus(args.port, args.baud or design.baud_rate, args.timeout)


def cmd_apply(args: argparse.Namespace) -> int:
    """Check all six servos, write their settings and verify them."""
    from handarm.firmware_bridge.bus import apply_settings

    design = _live_design(args)
    calibration = _calibration(args, design, required=False)
    with _bus(args, design) as bus:
        settings = apply_settings(bus, design, calibration, args.max_torque)
    for sid, regs in settings.items():
        print(f"servo {sid}: " + ", ".join(f"{k}={v}" for k, v in regs.items()) + " (verified)")
    return 0


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Record each motor's reading with the arm held at its zero pose (straight)."""
    from handarm.firmware_bridge.bus import record_calibration

    design = load_design(args.design)
    if not args.out.strip():
        raise UsageError("--out: expected a file name for the calibration, got ''")
    if os.path.lexists(args.out) and not args.force:
        raise UsageError(f"--out: {args.out} exists; add --force to overwrite it")
    with _bus(args, design) as bus:
        calibration = record_calibration(bus, design)
    print(calibration.save(args.out))
    return 0


def cmd_read(args: argparse.Namespace) -> int:
    """Print the joint angles (degrees); refuse a pose the calibration cannot explain."""
    from handarm.firmware_bridge.bus import check_servos, present_pose

    design = load_design(args.design)
    calibration = _calibration(args, design)
    with _bus(args, design) as bus:
        check_servos(bus, design)
        q = present_pose(bus, design, calibration)
    print(" ".join(f"{v:.2f}" for v in np.degrees(q)))
    return 0


def _check_rate(args) -> None:
    from handarm.firmware_bridge.motion import check_rate

    try:
        check_rate(args.rate)
    except ValueError as exc:
        raise option_error(exc, OPTIONS) from None


def _limits(args, design):
    from handarm.firmware_bridge.motion import MotionLimits

    try:
        return MotionLimits(design, args.speed, args.acceleration)
    except ValueError as exc:
        raise option_error(exc, {"speed_fraction": "--speed", "acceleration": "--accel"}) from None


def cmd_goto(args: argparse.Namespace) -> int:
    """Move to joint targets (degrees) along a collision-free timed path."""
    from handarm.firmware_bridge.bus import goal_ticks, goto
    from handarm.firmware_bridge.motion import PlanningError, check_clear, check_timing

    design = _live_design(args)
    calibration = _calibration(args, design)
    scene, clearance = load_scene(args)
    q = np.radians(args.q)
    goal_ticks(design, calibration, q)  # refuse before opening the port
    check_clear(design, q, scene, clearance, "goal")  # refuse before opening the port
    limits = _limits(args, design)
    _check_rate(args)
    try:
        check_timing()  # an extra missing on a plain install: before the port is opened
    except PlanningError as exc:
        raise UsageError(str(exc)) from None
    with _bus(args, design) as bus:
        samples = goto(
            bus,
            design,
            calibration,
            q,
            rate=args.rate,
            limits=limits,
            max_torque_fraction=args.max_torque,
            scene=scene,
            clearance=clearance,
        )
    print(
        f"moved in {len(samples) - 1} steps of {1000 / args.rate:g} ms to "
        + " ".join(f"{v:.2f}" for v in np.degrees(samples[-1]))
    )
    return 0


def cmd_torque(args: argparse.Namespace) -> int:
    """Turn the torque of all six servos on (holding the present pose) or off."""
    from handarm.firmware_bridge.bus import check_state, set_torque

    design = load_design(args.design)
    with _bus(args, design) as bus:
        if args.state == "on":
            calibration = _calibration(args, design)
            check_state(bus, design, calibration, args.max_torque)
        set_torque(bus, design, args.state == "on")
    print(f"torque {args.state}")
    return 0


def cmd_stop(args: argparse.Namespace) -> int:
    """Hold the present position of every servo."""
    from handarm.firmware_bridge.bus import check_servos, hold

    design = load_design(args.design)
    with _bus(args, design) as bus:
        check_servos(bus, design)
        ticks = hold(bus, design)
    print("holding ticks: " + " ".join(str(int(t)) for t in ticks))
    return 0


def _ids(text):
    lo, _, hi = text.partition("-")
    try:
        lo, hi = int(lo), int(hi or lo)
    except ValueError:
        raise UsageError(f"--ids: expected N or N-M, got {text!r}") from None
    if not (0 <= lo <= 253 and 0 <= hi <= 253):
        raise UsageError(f"--ids: expected IDs within 0..253, got {text!r}")
    if lo > hi:
        raise UsageError(f"--ids: {text!r} runs backwards; give the lower ID first ({hi}-{lo})")
    return range(lo, hi + 1)


def _bauds(values):
    from handarm.firmware_bridge.mx64 import BAUD_VALUES

    for b in values or ():
        if b not in BAUD_VALUES:
            raise UsageError(
                f"--baud: {b} is not a rate the MX-64 and the SDK share; choose from "
                f"{sorted(BAUD_VALUES)}"
            )
    return values or None


def cmd_scan(args: argparse.Namespace) -> int:
    """List every servo that answers, at each baud the MX-64 supports."""
    from handarm.firmware_bridge.bus import scan

    found = scan(args.port, _bauds(args.baud), _ids(args.ids), args.timeout)
    for f in found:
        note = "  DUPLICATE: two servos answer to this ID" if f["duplicate"] else ""
        print(
            f"ID {f['id']:3d}  {f['baud']:>9d} bit/s  model {f['model_number']}  "
            f"firmware {f['firmware']}{note}"
        )
    if not found:
        print("no servo answered")
        return 5  # as a bus failure: check power, wiring and --port
    return 4 if any(f["duplicate"] for f in found) else 0


def cmd_setup(args: argparse.Namespace) -> int:
    """Give the one connected servo the ID and baud of a joint, with read-back."""
    from handarm.firmware_bridge.bus import setup_servo

    design = load_design(args.design)
    result = setup_servo(
        args.port, design, args.joint, _bauds(args.baud), _ids(args.ids), args.timeout
    )
    was = result["was"]
    print(
        f"joint {args.joint}: ID {was['id']} at {was['baud']} bit/s -> ID {result['id']} at "
        f"{result['baud']} bit/s (read back)"
    )
    return 0


def cmd_follow(args: argparse.Namespace) -> int:
    """Keep the tool on a stream of targets while the handle moves (JSON lines)."""
    from handarm.firmware_bridge.follow import (
        JUMP_RAMP,
        JUMP_SPEED,
        check_source_lines,
        follow,
        open_source,
    )

    design = _live_design(args)
    calibration = _calibration(args, design)
    limits = _limits(args, design)
    scene, clearance = load_scene(args)
    _check_rate(args)
    source = open_source(args.source)
    try:
        check_source_lines(design, source)  # a file's every line, before anything else
    except ValueError:
        source.close()
        raise
    # the warm-up compiles for minutes on a fresh install, silently but for this line
    print(
        "handarm bridge follow: preparing the IK kernels before torque goes on (minutes on a "
        "fresh install, about a second once numba's cache holds them)",
        file=sys.stderr,
        flush=True,
    )
    with _bus(args, design) as bus:
        stats = follow(
            bus,
            design,
            calibration,
            source,
            rate=args.rate,
            limits=limits,
            max_torque_fraction=args.max_torque,
            scene=scene,
            clearance=clearance,
        )
    print(
        f"followed {stats['targets']} targets in {stats['periods']} periods "
        f"({stats['rate']:.1f} Hz achieved; kernels prepared in {stats['warm_up_s']:.1f} s "
        "before torque on)"
    )
    if stats["slowed_periods"]:
        print(
            f"{stats['slowed_periods']} periods ran below the speed limit (from {JUMP_SPEED:g} of "
            f"it, back up over {JUMP_RAMP:g} s): the answer swung to another family of "
            "configurations (a far target, or the family the arm was on ended)"
        )
    if stats["blocked_by"]:
        print(f"held before targets blocked by: {', '.join(stats['blocked_by'])}")
    if stats["stalled"]:
        print(
            "handarm bridge follow: error: the arm held short of the last target: the straight "
            "step towards it meets a link or an obstacle, and follow does not plan around "
            "them ('handarm bridge goto' does)",
            file=sys.stderr,
        )
        return 3
    return 0


def cmd_emulate(args: argparse.Namespace) -> int:
    """Run a software bus of MX-64T servos on a pseudo-terminal until Ctrl-C."""
    import time

    from handarm.firmware_bridge.emulator import EmulatedBus

    design = load_design(args.design)
    with EmulatedBus(design.servo_ids) as bus:
        print(f"emulated MX-64T bus (IDs {list(design.servo_ids)}) on {bus.port}", flush=True)
        print(
            f"(a software bus: pass --timeout {bus.timeout_ms:g} to the commands that use it)",
            flush=True,
        )
        while True:
            time.sleep(1.0)


_LIVE = (
    ("apply", cmd_apply, "write and verify the servos' settings", False),
    ("calibrate", cmd_calibrate, "record the encoder offsets at the zero pose", False),
    ("read", cmd_read, "print the joint angles from the encoders", True),
    ("goto", cmd_goto, "move to joint targets (degrees) along a collision-free path", True),
    ("torque", cmd_torque, "torque on (holding the pose) or off", False),
    ("stop", cmd_stop, "hold the present position", False),
    ("follow", cmd_follow, "keep the tool on streamed targets (JSON lines)", True),
)


def _port_name(text: str) -> str:
    """An argparse ``type``: a port name, not empty (which failed as a bus fault, exit 5)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a serial port, e.g. /dev/ttyUSB0, got ''")
    return text


def _port_args(p) -> None:
    p.add_argument("--port", type=_port_name, required=True, help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=int, help="bit rate (default: the design's)")
    p.add_argument(
        "--timeout", type=float, metavar="MS", help="status timeout, ms (default: the SDK's)"
    )


def register(sub) -> None:
    """Add ``bridge`` and its actions to the ``handarm`` parser."""
    bridge = sub.add_parser(
        "bridge",
        help="servo controller: export, sizing, live bus",
        description="Firmware bridge to six Dynamixel MX-64T servos.",
    )
    bsub = bridge.add_subparsers(dest="bridge_command", metavar="ACTION")
    bsub.required = True
    p = bsub.add_parser(
        "export",
        help="controller.json, arm_config.h",
        description="Write controller.json and arm_config.h (no ros2_control: see the guide).",
    )
    add_design_arg(p)
    p.add_argument("--out", default="build/controller", help="output folder")
    p.add_argument("--calibration", metavar="FILE", help="calibration JSON to include")
    p.add_argument(
        "--achieved",
        metavar="CARVE_JSON",
        help="carve.json from 'handarm carve': export the achieved limits",
    )
    p.add_argument(
        "--max-torque",
        type=number(low=0.0, high=1.0),
        default=1.0,
        metavar="FRACTION",
        help="Max Torque register as a fraction of 1023 (default 1)",
    )
    p.set_defaults(func=cmd_export)

    p = bsub.add_parser(
        "size",
        help="payload and pulley sizing (cvxpy)",
        description="Largest payload of the design, and joint pulley radii that maximise it.",
    )
    add_design_arg(p)
    p.add_argument(
        "--safety",
        type=number(low=0.01, high=1.0),
        default=0.5,
        help="fraction of the servo's stall torque a motor may use (default 0.5)",
    )
    p.add_argument(
        "--min-speed",
        type=number(low=0.0, high=1e4),
        default=180.0,
        metavar="DEG_S",
        help="slowest acceptable joint speed, deg/s (default 180)",
    )
    p.add_argument(
        "--radius-range",
        type=number(low=0.1, high=1000.0),
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
    p.set_defaults(func=cmd_size)

    for name, func, help_text, needs_cal in _LIVE:
        p = bsub.add_parser(name, help=help_text, description=help_text[0].upper() + help_text[1:])
        if name == "goto":
            p.add_argument(
                "q",
                nargs=6,
                type=number(low=-360, high=360),
                metavar="Q",
                help="joint targets, degrees",
            )
            p.add_argument("--design", metavar="DESIGN.toml", help="arm design")
        elif name == "torque":
            p.add_argument("state", choices=("on", "off"), help="on or off")
            p.add_argument("--design", metavar="DESIGN.toml", help="arm design")
        else:
            add_design_arg(p)
        _port_args(p)
        if name in ("apply", "goto", "torque", "follow"):
            p.add_argument(
                "--max-torque",
                type=float,
                default=1.0,
                metavar="FRACTION",
                help="Max Torque as a fraction of 1023, as given to apply (default 1)",
            )
        if name in ("apply", "goto", "follow"):
            p.add_argument(
                "--achieved",
                metavar="CARVE_JSON",
                help="carve.json from 'handarm build' or 'handarm carve': keep the joints "
                "within the limits the printed parts allow",
            )
        if name in ("goto", "follow"):
            add_scene_options(p)
            p.add_argument("--rate", type=float, default=50.0, help="control rate, Hz")
            p.add_argument(
                "--speed",
                type=float,
                default=0.5,
                metavar="FRACTION",
                help="motor speed limit as a fraction of no-load speed (default 0.5)",
            )
            p.add_argument(
                "--accel",
                dest="acceleration",
                type=float,
                default=20.0,
                metavar="RAD_S2",
                help="motor acceleration limit, rad/s^2 (default 20)",
            )
        if name == "follow":
            p.add_argument(
                "--source",
                default="-",
                help="JSON-lines targets: a file, '-' for stdin, or udp:PORT on localhost",
            )
        if name == "calibrate":
            p.add_argument("--out", default="calibration.json", help="calibration file to write")
            p.add_argument("--force", action="store_true", help="overwrite an existing --out")
        else:
            p.add_argument(
                "--calibration",
                metavar="FILE",
                required=needs_cal,
                help="calibration JSON from 'handarm bridge calibrate'",
            )
        p.set_defaults(func=func)

    p = bsub.add_parser(
        "scan",
        help="list the servos at every baud",
        description="List every servo that answers (ID, baud, model, firmware, duplicates).",
    )
    p.add_argument("--port", type=_port_name, required=True, help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=int, nargs="+", help="rates to try (default: all MX-64 rates)")
    p.add_argument("--ids", default="0-253", help="IDs to ping, N or N-M (default 0-253)")
    p.add_argument("--timeout", type=float, metavar="MS", help="status timeout, ms")
    p.set_defaults(func=cmd_scan)

    p = bsub.add_parser(
        "setup",
        help="give one connected servo a joint's ID and baud",
        description="Give the one servo on the bus the ID and baud of a joint (factory "
        "servos: ID 1 at 57600), with read-back. Connect one servo at a time.",
    )
    add_design_arg(p)
    p.add_argument("--joint", type=int, required=True, help="joint 1..6")
    p.add_argument("--port", type=_port_name, required=True, help="serial port, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=int, nargs="+", help="rates to search (default: all)")
    p.add_argument("--ids", default="0-253", help="IDs to search, N or N-M (default 0-253)")
    p.add_argument("--timeout", type=float, metavar="MS", help="status timeout, ms")
    p.set_defaults(func=cmd_setup)

    p = bsub.add_parser(
        "emulate",
        help="software MX-64T bus on a pseudo-terminal",
        description="Run a software bus of MX-64T servos on a pseudo-terminal until Ctrl-C.",
    )
    add_design_arg(p)
    p.set_defaults(func=cmd_emulate)
