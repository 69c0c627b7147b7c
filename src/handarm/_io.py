"""Atomic file writing: a reader never sees a half-written output file."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    path = Path(path)
    if path.is_symlink() or (path.exists() and not path.is_file()):
        # a rename would replace a link, FIFO or device node with a regular file
        raise ValueError(f"{path}: exists and is not a regular file; not replacing it")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)  # mkstemp makes files private; outputs are ordinary files
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def read_regular_bytes(path: Path, limit: int = 1 << 24) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes.

    A FIFO or device node would block or never end, so anything but a regular file is
    refused before it is opened (ValueError); so is a file over ``limit`` bytes (16 MiB).
    FileNotFoundError passes through.
    """
    path = Path(path)
    st = path.stat()
    if stat.S_ISDIR(st.st_mode):
        raise ValueError("is a folder, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise ValueError("not a regular file")
    if st.st_size > limit:
        raise ValueError(f"{st.st_size} bytes is too large (limit {limit})")
    try:
        with path.open("rb") as fh:
            return fh.read(limit + 1)
    except PermissionError:
        raise ValueError("cannot be read (permission denied)") from None


def not_a_file(path: Path) -> str:
    """Why ``path`` is no file to read: "no such file 'x'", "'x' is a folder, not a file"."""
    name = repr(str(path))
    if not path.exists():
        return f"no such file {name}"
    return f"{name} is a folder, not a file" if path.is_dir() else f"{name} is not a regular file"
