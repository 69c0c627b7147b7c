"""Output folders a build can trust: checked before work, locked, marked, with a manifest.

A build folder holds ``handarm-build.json`` (the design and every file the build wrote).
While a build runs, the folder holds ``.handarm-incomplete`` and an exclusive lock on
``.handarm.lock``; a second build into the same folder is refused at once. Partial
``.*.tmp`` files a killed write left behind are removed at the next build, and files the
previous build wrote that the new one does not are removed when the new one finishes.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import stat
from collections.abc import Iterator
from pathlib import Path

from handarm._io import write_text_atomic

__all__ = ["MANIFEST", "INCOMPLETE", "LOCK", "check_out_dir", "check_layout", "build_folder"]

MANIFEST = "handarm-build.json"
INCOMPLETE = ".handarm-incomplete"
LOCK = ".handarm.lock"


def check_out_dir(out: str | os.PathLike[str], name: str = "out") -> Path:
    """``out`` as a Path if it is (or can become) a writable folder; ValueError otherwise.

    A symlink, FIFO, device or regular file at ``out`` is refused rather than replaced or
    written through; so is a folder the user cannot write into, one holding a symbolic link
    to a folder (its files would land wherever the link points), and an empty name (which
    would be the working folder). Nothing is created.
    """
    if isinstance(out, str) and not out.strip():
        raise ValueError(f"{name}: expected a folder name, got {out!r}")
    out = Path(out)
    try:
        st = out.lstat()
    except FileNotFoundError:
        parent = next((p for p in out.absolute().parents if p.exists()), Path("/"))
        if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
            raise ValueError(f"{name}: cannot create {out}: {parent} is not writable") from None
        return out
    if stat.S_ISLNK(st.st_mode):
        raise ValueError(f"{name}: {out} is a symbolic link; give a real folder")
    if not stat.S_ISDIR(st.st_mode):
        raise ValueError(f"{name}: {out} exists and is not a folder")
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"{name}: {out} is not writable")
    for root, dirs, files in os.walk(out):  # links are listed, not followed
        for d in dirs:
            if os.path.islink(os.path.join(root, d)):
                raise ValueError(
                    f"{name}: {Path(root, d)} is a symbolic link; the outputs would be "
                    "written through it, outside the folder"
                )
        for f in files:  # a FIFO or device was found only when its name came to be written
            mode = os.lstat(os.path.join(root, f)).st_mode
            if (
                stat.S_ISFIFO(mode)
                or stat.S_ISCHR(mode)
                or stat.S_ISBLK(mode)
                or stat.S_ISSOCK(mode)
            ):
                raise ValueError(f"{name}: {Path(root, f)} is not a regular file; remove it first")
    return out


def check_layout(
    out: Path, folders: tuple[str, ...], files: tuple[str, ...], name: str = "out"
) -> None:
    """Refuse, before any work, what is in the way of the outputs at the top of ``out``.

    ``folders`` and ``files``: the names the job writes there. A file (or link) named like
    one of its folders, a folder it cannot write into, or a folder named like one of its
    files was found only when the outputs came to be written, after minutes of carving.
    """
    for f in folders:
        p = out / f
        if p.is_symlink() or (p.exists() and not p.is_dir()):
            raise ValueError(f"{name}: {p} is in the way of the folder of that name; remove it")
        if p.is_dir() and not os.access(p, os.W_OK | os.X_OK):
            raise ValueError(f"{name}: {p} is not writable")
    for f in files:
        p = out / f
        if p.is_dir() and not p.is_symlink():
            raise ValueError(f"{name}: {p} is a folder where a file of that name is written")


def _remove_stale_tmp(out: Path) -> None:
    for path in out.rglob(".*.tmp"):
        if path.is_file() and not path.is_symlink():
            path.unlink(missing_ok=True)


def _previous_files(out: Path) -> list[Path]:
    try:
        data = json.loads((out / MANIFEST).read_text())
        return [out / f for f in data["files"] if isinstance(f, str)]
    except (OSError, ValueError, KeyError, TypeError):
        return []


@contextlib.contextmanager
def build_folder(out: str | os.PathLike[str], design_dict: dict) -> Iterator[list[Path]]:
    """Lock and mark ``out`` for a build; yields the list the build appends its files to.

    On success the manifest is written, files of the previous build that were not written
    again are removed and the incomplete marker goes; on failure or interruption the
    marker stays.

    Raises
    ------
    ValueError
        If ``out`` is not a usable folder or another build holds its lock.
    """
    out = check_out_dir(out)
    out.mkdir(parents=True, exist_ok=True)
    fd = os.open(out / LOCK, os.O_CREAT | os.O_RDWR | os.O_NOFOLLOW, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ValueError(f"out: another build is writing into {out}") from None
        _remove_stale_tmp(out)
        previous = _previous_files(out)
        (out / INCOMPLETE).write_text("a build into this folder did not finish\n")
        files: list[Path] = []
        yield files
        root = out.resolve()
        kept = {p.resolve() for p in files}
        for path in previous:
            real = path.resolve()
            if real not in kept and real.is_relative_to(root) and path.is_file():
                path.unlink()
        rel = [str(p.relative_to(out)) for p in files if p.is_relative_to(out)]
        write_text_atomic(
            out / MANIFEST, json.dumps({"design": design_dict, "files": rel}, indent=2) + "\n"
        )
        (out / INCOMPLETE).unlink(missing_ok=True)
    finally:
        os.close(fd)
