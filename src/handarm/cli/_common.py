"""What every subcommand shares: design loading, one-line errors, option names."""

from __future__ import annotations

import argparse
from collections.abc import Mapping

from handarm.design import ArmDesign


class UsageError(Exception):
    """A mistake in what the user asked for; reported as one line, exit status 2."""


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
