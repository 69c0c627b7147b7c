"""The ``handarm`` console script: Ctrl-C handled from the first instant.

Importing the ``handarm`` package (numpy, numba) takes a second or more, and a SIGINT
during an import must not print a traceback or be swallowed by a library's import guard.
This module lives outside the package so that it can take over SIGINT before anything
heavy is imported; ``handarm.cli.main`` then installs its own handler.
"""

from __future__ import annotations

import _signal  # built in: no file to import before the handler is in place
import os
import sys


def _abort(signum, frame) -> None:  # nothing has been written yet: leave at once
    os.write(2, b"handarm: interrupted\n")
    os._exit(130)


def _take_sigint() -> None:
    """Handle SIGINT from now on, unless it was ignored when the process started.

    ``nohup`` and a shell's background jobs start commands with SIGINT ignored; Python
    leaves an inherited ignore alone, and so does handarm.
    """
    if _signal.getsignal(_signal.SIGINT) is not _signal.SIG_IGN:
        _signal.signal(_signal.SIGINT, _abort)


_take_sigint()  # at import: the console script imports, then calls


def main() -> int:
    """Run ``handarm.cli.main`` with Ctrl-C ending the process cleanly during imports."""
    _take_sigint()
    from handarm.cli import EXIT_INTERRUPTED
    from handarm.cli import main as run

    status = run()
    if status == EXIT_INTERRUPTED:
        _end_interrupted(status)
    return status


def _end_interrupted(status: int) -> None:
    """After "interrupted" is reported, end the process without the interpreter's teardown.

    A Ctrl-C can land inside a library's constructor (seen in CI: llvmlite's ``ObjectRef``);
    the half-built object's finalizer then fails while Python exits and prints "Exception
    ignored in ..." with a traceback. Worse, tearing down native libraries an interrupt cut
    short can crash: CI once saw ``handarm build`` report "interrupted" and then die of
    SIGSEGV (status -11) instead of exiting 130. The command has already cleaned up and
    reported, so the exit handlers libraries registered (``atexit``: closing Dask clients,
    stopping tqdm's monitor) run, silently, and the process then ends at once with
    ``status``, skipping module teardown and native destructors.
    """
    import atexit

    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said
            pass
    sys.unraisablehook = lambda info: None
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    os.close(devnull)
    try:
        atexit._run_exitfuncs()
    finally:
        os._exit(status)


if __name__ == "__main__":
    sys.exit(main())
