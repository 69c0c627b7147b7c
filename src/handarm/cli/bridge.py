"""``handarm bridge ...``: the servo controller (export, sizing, the live bus, an emulator)."""

from __future__ import annotations

import argparse
import json
import math
import os

import numpy as np

from handarm.cli._common import UsageError, add_design_arg, load_design, number, option_error

_BUS_OPTIONS = {"port": "--port", "baud": "--baud", "calibration": "--calibration"}


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


def cmd_export(args: argparse.Namespace) -> int:
    """Write controller.json, arm_config.h and a ros2_control fragment."""
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
        raise option_error(exc, {"max_torque_fraction": "--max-torque"}) from None
    for path in paths:
        print(path)
    return 0


def cmd_size(args: argparse.Namespace) -> int:
    """Largest payload of the design, and joint pulley radii that maximise it (cvxpy)."""
    from handarm.firmware_bridge import sizing

    design = load_design(args.design)
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

    return ServoBus(args.port, args.baud or design.baud_rate)


def cmd_apply(args: argparse.Namespace) -> int:
    """Check all six servos, write their EEPROM settings and verify them."""
    from handarm.firmware_bridge.bus import apply_settings

    design = load_design(args.design)
    calibration = _calibration(args, design, required=False)
    with _bus(args, design) as bus:
        settings = apply_settings(bus, design, calibration)
    for sid, regs in settings.items():
        print(f"servo {sid}: " + ", ".join(f"{k}={v}" for k, v in regs.items()) + " (verified)")
    return 0


def cmd_calibrate(args: argparse.Namespace) -> int:
    """Record each motor's reading with the arm held at its zero pose (straight)."""
    from handarm.firmware_bridge.bus import record_calibration

    design = load_design(args.design)
    if os.path.lexists(args.out) and not args.force:
        raise UsageError(f"--out: {args.out} exists; add --force to overwrite it")
    with _bus(args, design) as bus:
        calibration = record_calibration(bus, design)
    print(calibration.save(args.out))
    return 0


def cmd_read(args: argparse.Namespace) -> int:
    """Print the joint angles (degrees) from the motor encoders."""
    from handarm.firmware_bridge.bus import read_joint_angles

    design = load_design(args.design)
    calibration = _calibration(args, design)
    with _bus(args, design) as bus:
        q = read_joint_angles(bus, design, calibration)
    print(" ".join(f"{v:.2f}" for v in np.degrees(q)))
    return 0


def cmd_goto(args: argparse.Namespace) -> int:
    """Send joint targets (degrees, as 'handarm ik' prints them)."""
    from handarm.firmware_bridge.bus import goal_ticks, goto

    design = load_design(args.design)
    calibration = _calibration(args, design)
    q = np.radians(args.q)
    goal_ticks(design, calibration, q)  # refuse before opening the port
    with _bus(args, design) as bus:
        ticks = goto(bus, design, calibration, q)
    print("sent ticks: " + " ".join(str(int(t)) for t in ticks))
    return 0


def cmd_emulate(args: argparse.Namespace) -> int:
    """Run a software bus of MX-64T servos on a pseudo-terminal until Ctrl-C."""
    import time

    from handarm.firmware_bridge.emulator import EmulatedBus

    design = load_design(args.design)
    with EmulatedBus(design.servo_ids) as bus:
        print(f"emulated MX-64T bus (IDs {list(design.servo_ids)}) on {bus.port}", flush=True)
        while True:
            time.sleep(1.0)


_LIVE = (
    ("apply", cmd_apply, "write and verify the servos' EEPROM settings", False),
    ("calibrate", cmd_calibrate, "record the encoder offsets at the zero pose", False),
    ("read", cmd_read, "print the joint angles from the encoders", True),
    ("goto", cmd_goto, "move to joint targets (degrees)", True),
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
        help="controller.json, arm_config.h, ros2_control.xml",
        description="Write controller.json, arm_config.h and a ros2_control fragment.",
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
        else:
            add_design_arg(p)
        p.add_argument("--port", required=True, help="serial port, e.g. /dev/ttyUSB0")
        p.add_argument("--baud", type=number(int, low=1), help="bit rate (default: the design's)")
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
        "emulate",
        help="software MX-64T bus on a pseudo-terminal",
        description="Run a software bus of MX-64T servos on a pseudo-terminal until Ctrl-C.",
    )
    add_design_arg(p)
    p.set_defaults(func=cmd_emulate)
