"""What every subcommand shares: design loading, one-line errors, option names."""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Mapping
from pathlib import Path

from handarm._resources import DEFAULT_MAX_MEMORY, DEFAULT_MAX_SECONDS
from handarm.design import ArmDesign


class UsageError(Exception):
    """A mistake in what the user asked for; reported as one line, exit status 2."""


def out_file(value: str, option: str, suffix: str | None = None) -> Path:
    """The output file an option names, checked before any work.

    A file name (with ``suffix`` if given) in an existing, writable folder, and nothing but
    a regular file there already: a symbolic link, even to a file, is refused rather than
    written through.
    """
    path = Path(value)
    if not value or path.name in ("", ".", ".."):
        raise UsageError(f"{option}: expected a file name, got {value!r}")
    if suffix is not None and path.suffix.lower() != suffix:
        raise UsageError(f"{option}: expected a {suffix} file name, got {value!r}")
    if not path.parent.is_dir():
        raise UsageError(f"{option}: no such folder: {str(path.parent)!r}")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise UsageError(f"{option}: folder {str(path.parent)!r} is not writable")
    if path.is_symlink():
        raise UsageError(f"{option}: {value!r} is a symbolic link; give a file name")
    if path.exists() and not path.is_file():
        raise UsageError(f"{option}: {value!r} exists and is not a regular file")
    return path


def load_design(path: str | None) -> ArmDesign:
    """The design in ``path``, or the paper's arm when no file is given."""
    return ArmDesign() if path is None else ArmDesign.from_toml(path)


def add_design_arg(p: argparse.ArgumentParser) -> None:
    """The optional positional DESIGN.toml argument."""
    p.add_argument(
        "design", nargs="?", metavar="DESIGN.toml", help="arm design (default: the paper's arm)"
    )


def add_quiet(p: argparse.ArgumentParser) -> None:
    """The --quiet option (no progress bars)."""
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def option_error(exc: Exception, options: Mapping[str, str]) -> UsageError:
    """A library error that names an argument, reworded with the option the user typed.

    ``options`` maps library argument names to CLI options, e.g. ``{"p": "--pos"}``: the
    message ``p: must be finite`` becomes ``--pos: must be finite``.
    """
    msg = str(exc)
    for name, option in options.items():
        if msg.startswith(f"{name}:") or msg.startswith(f"{name}["):
            msg = option + msg[len(name) :]
            break
    return UsageError(msg)


def number(kind: type = float, *, low: float | None = None, high: float | None = None):
    """An argparse ``type``: a finite ``kind`` within [low, high], else a one-line error."""

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {kind.__name__}, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
        if (low is not None and value < low) or (high is not None and value > high):
            lo = "-inf" if low is None else f"{low:g}"
            hi = "inf" if high is None else f"{high:g}"
            span = f"{lo} .. {hi}"
            raise argparse.ArgumentTypeError(f"must be within {span}, got {text!r}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


def add_limits(p: argparse.ArgumentParser) -> None:
    """--max-memory and --max-minutes: the limits a job's estimate is held against."""
    p.add_argument(
        "--max-memory",
        type=number(low=0.001),
        default=DEFAULT_MAX_MEMORY / 2**30,
        metavar="GIB",
        help="refuse a job estimated to need more memory (default %(default)g GiB)",
    )
    p.add_argument(
        "--max-minutes",
        type=number(low=0.001),
        default=DEFAULT_MAX_SECONDS / 60,
        metavar="MIN",
        help="refuse a job estimated to take longer (default %(default)g min)",
    )


#: The map options' library argument names and the CLI options that set them.
MAP_OPTIONS = {"voxel": "--voxel", "directions": "--directions", "out": "--out"}


def add_map_options(p: argparse.ArgumentParser) -> None:
    """--voxel and --directions: the workspace map's resolution (build and workspace)."""
    p.add_argument(
        "--voxel",
        type=number(low=1e-4),
        default=0.01,
        metavar="M",
        help="workspace map voxel edge, m (default 0.01; 0.03 for a quick look)",
    )
    p.add_argument(
        "--directions",
        type=number(int, low=4),
        default=100,
        help="workspace map approach directions (default 100; 36 for a quick look)",
    )


def add_scene_options(p: argparse.ArgumentParser) -> None:
    """--scene and --clearance: obstacles the printed links keep clear of (ik, workspace)."""
    p.add_argument(
        "--scene", metavar="SCENE.toml", help="obstacles (handle frame) the links keep clear of"
    )
    p.add_argument(
        "--clearance", type=float, metavar="MM", help="distance kept from the obstacles, mm"
    )


def load_scene(args: argparse.Namespace):
    """(Scene or None, clearance in m) from --scene and --clearance, checked before any work."""
    if args.scene is None:
        if args.clearance is not None:
            raise UsageError("--clearance: only with --scene")
        return None, 0.0
    from handarm.scene import Scene

    try:
        scene = Scene.from_toml(args.scene)
    except ValueError as exc:
        raise UsageError(f"--scene: {str(exc).removeprefix('scene: ')}") from None
    if scene.frame != "handle":
        raise UsageError(
            f"--scene: {args.scene}: frame {scene.frame!r}; the command line takes scenes in "
            "the handle frame (use Scene.in_handle_frame from Python)"
        )
    if args.clearance is None:
        return scene, 0.0
    if not 0.0 <= args.clearance <= 1000.0:
        raise UsageError(f"--clearance: expected 0 to 1000 mm, got {args.clearance:g}")
    return scene, args.clearance * 1e-3


def limits(args: argparse.Namespace) -> dict:
    """The library's ``max_memory`` / ``max_seconds`` arguments from the options."""
    return {"max_memory": args.max_memory * 2**30, "max_seconds": args.max_minutes * 60}


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage dump), exit status 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")
