"""The ``handarm`` command: argument parsing only; every action is a library call.

Exit statuses (one source: ``EXIT_CODES``, printed in the README's table):

==== ===================================================================
"""

from __future__ import annotations

import _thread
import argparse
import importlib
import os
import signal
import sys
import threading
from contextlib import contextmanager

from handarm import __version__
from handarm.cli import bridge, build, ik, optimize, report, workspace
from handarm.cli._common import Parser, UsageError, option_error

__all__ = ["main", "make_parser", "UsageError", "EXIT_CODES"]

_RUNTIME_OPTIONS = {"port": "--port", "baud": "--baud", "scheduler": "--scheduler"}

EXIT_OK, EXIT_NO_SOLUTION, EXIT_USAGE, EXIT_REFUSED, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
EXIT_ARM_STATE, EXIT_BUS = 4, 5  # the ``exit_status`` of the bridge's errors

#: Every exit status of the ``handarm`` command and what it means (the README's table).
EXIT_CODES = {
    EXIT_OK: "success",
    EXIT_NO_SOLUTION: "the command ran but found no answer (`ik` with no solution)",
    EXIT_USAGE: "a user mistake (file, value, option, a job over the resource limit); one line",
    EXIT_REFUSED: "refused by a solver or the motion planner, or out of memory; one line",
    EXIT_ARM_STATE: "arm state: unknown or invalid pose, servo settings differ, a servo fault",
    EXIT_BUS: "bus failure: port lost, servo silent, duplicate ID, a failed write",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C); one line",
}

#: Heavy modules each command needs, imported before the command runs; Ctrl-C meanwhile
#: ends the process at once (nothing is written yet), since some libraries' import guards
#: catch BaseException and would swallow a KeyboardInterrupt.
_PRELOAD = {
    "study": ("handarm.pipeline", "handarm.workspace.study_run", "dask.distributed"),
    "ik": ("handarm.ik",),
}
_PRELOAD_DEFAULT = ("handarm.pipeline",)


#: Seconds a KeyboardInterrupt may take to end the command before the process is ended
#: outright: some libraries (Dask's client among them) catch it and carry on.
_GRACE = 5.0


class _Interrupts:
    """SIGINT handler: raises KeyboardInterrupt, or while importing exits at once (130).

    After the first Ctrl-C a watchdog ends the process (status 130) if the command has not
    ended within ``_GRACE`` seconds. A hard exit leaves at most a hidden ``.tmp`` file (the
    next run removes it) and a build folder still marked incomplete: both true states.
    """

    def __init__(self) -> None:
        self.seen = False
        self.importing = False
        self.reported = False
        self.name = "handarm"
        self.previous_hook = sys.unraisablehook

    def __call__(self, signum, frame) -> None:
        if self.importing:
            self.exit_now()
        if not self.seen:
            self.seen = True
            watchdog = threading.Timer(_GRACE, self.exit_now)
            watchdog.daemon = True
            watchdog.start()
        raise KeyboardInterrupt

    def unraisable(self, info) -> None:
        """``sys.unraisablehook``: a Ctrl-C raised inside a callback Python ignores.

        A KeyboardInterrupt raised while a weakref callback or a finalizer runs cannot
        propagate: Python would print "Exception ignored in ..." with a traceback and go on.
        It is delivered again to the command instead, silently. Once a Ctrl-C has arrived,
        any other such report is about an object the interrupt cut short (a finalizer of a
        half-built object) and is dropped too.
        """
        if info.exc_type is not None and issubclass(info.exc_type, KeyboardInterrupt):
            again = threading.Timer(0.01, _thread.interrupt_main)
            again.daemon = True
            again.start()
            return
        if not self.seen:
            self.previous_hook(info)

    def exit_now(self) -> None:
        if not self.reported:
            os.write(2, f"{self.name}: interrupted\n".encode())
        os._exit(EXIT_INTERRUPTED)

    @contextmanager
    def imports(self):
        self.importing = True
        try:
            yield
        finally:
            self.importing = False

    def check(self) -> None:
        """Raise KeyboardInterrupt if one arrived (and was perhaps swallowed) since start."""
        if self.seen:
            raise KeyboardInterrupt


def make_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``handarm`` command."""
    parser = Parser(
        prog="handarm",
        description="Design, carve, solve and drive small coupled-tendon robot arms.",
        epilog="exit status: " + "; ".join(f"{code} {text}" for code, text in EXIT_CODES.items()),
    )
    parser.add_argument("--version", action="version", version=f"handarm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for module in (build, ik, bridge, workspace, optimize, report):
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    interrupts = _Interrupts()
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.SIG_IGN:  # an inherited ignore (nohup) is left alone
        signal.signal(signal.SIGINT, interrupts)
    interrupts.previous_hook, sys.unraisablehook = sys.unraisablehook, interrupts.unraisable
    name = "handarm"
    try:
        parser = make_parser()
        args = parser.parse_args(argv)
        name = interrupts.name = " ".join(
            filter(None, ("handarm", args.command, getattr(args, "bridge_command", None)))
        )
        with interrupts.imports():
            for module in _PRELOAD.get(args.command, _PRELOAD_DEFAULT):
                importlib.import_module(module)
        status = args.func(args)
        interrupts.check()  # a library that swallowed Ctrl-C does not make it a success
        return status
    except KeyboardInterrupt:
        return _interrupted(interrupts, name)
    except Exception as exc:
        if interrupts.seen:  # a library turned the Ctrl-C into an error of its own (numba
            return _interrupted(interrupts, name)  # cut mid-compile: "no compiled object")
        return _failure(name, exc)
    finally:
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = interrupts.previous_hook


def _interrupted(interrupts: _Interrupts, name: str) -> int:
    interrupts.reported = True
    print(f"{name}: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _failure(name: str, exc: Exception) -> int:
    """One line and the exit status for a refused command; anything else is a bug: raised."""
    if isinstance(exc, (UsageError, ValueError, OSError)):
        if name.startswith("handarm bridge") and not isinstance(exc, UsageError):
            exc = option_error(exc, bridge.OPTIONS)  # the library's names, as options
        print(f"{name}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    if isinstance(exc, MemoryError):
        print(f"{name}: error: out of memory; ask for a smaller job", file=sys.stderr)
        return EXIT_REFUSED
    if isinstance(exc, RuntimeError):  # a solver, the planner, the arm's state or the bus
        status = getattr(exc, "exit_status", EXIT_REFUSED)
        print(f"{name}: error: {_one_line(option_error(exc, _RUNTIME_OPTIONS))}", file=sys.stderr)
        return status
    raise exc


def _one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line (library messages sometimes span several)."""
    return " ".join(str(exc).split()) or type(exc).__name__
