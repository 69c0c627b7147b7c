"""The ``handarm`` command: argument parsing only; every action is a library call.

A user mistake (missing file, bad TOML, bad value) prints one line and exits with status 2;
a refusal by a solver or the motion planner exits with 3; an arm or servo state the bridge
will not move from (unknown pose, servo settings that differ, a servo fault) with 4; a bus
failure (port lost, servo silent, duplicate ID) with 5; Ctrl-C exits with 130 (a moving
arm is stopped holding its pose first).
"""

from __future__ import annotations

import argparse
import sys

from handarm import __version__
from handarm.cli import bridge, build, ik, workspace
from handarm.cli._common import UsageError, option_error

__all__ = ["main", "make_parser", "UsageError"]

_RUNTIME_OPTIONS = {"port": "--port", "baud": "--baud", "scheduler": "--scheduler"}

EXIT_OK, EXIT_NO_SOLUTION, EXIT_USAGE, EXIT_REFUSED, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
EXIT_ARM_STATE, EXIT_BUS = 4, 5  # the ``exit_status`` of the bridge's errors


def make_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``handarm`` command."""
    parser = argparse.ArgumentParser(
        prog="handarm",
        description="Design, carve, solve and drive small coupled-tendon robot arms.",
    )
    parser.add_argument("--version", action="version", version=f"handarm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for module in (build, ik, bridge, workspace):
        module.register(sub)
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
        return EXIT_USAGE
    except RuntimeError as exc:  # a solver, the planner, the arm's state or the bus said no
        status = getattr(exc, "exit_status", EXIT_REFUSED)
        exc = option_error(exc, _RUNTIME_OPTIONS)
        print(f"handarm {name}: error: {exc}", file=sys.stderr)
        return status
    except KeyboardInterrupt:
        print(f"handarm {name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
