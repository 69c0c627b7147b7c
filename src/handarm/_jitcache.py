"""The compiled-code cache of handarm's numba kernels, stamped by the whole package.

numba keeps each ``cache=True`` kernel's machine code beside its source and reuses it while
*that file* is unchanged. A kernel compiled together with the kernels it calls from other
modules (``handarm.ik._solve`` calls ``handarm.ik._printed``, which calls
``handarm._collide``) then outlives a change to them: after editing ``_printed.py`` the
solver still ran the old certification, silently. Here every handarm kernel's cache entry is
stamped with a digest of all of the package's source files instead, so that any change to
handarm's code recompiles every kernel once. An installed release never changes, so nothing
is recompiled there; a working copy pays one compilation after each edit. A process whose
sources changed after it imported handarm (its modules load lazily, some before the edit
and some after) reuses and keeps nothing (``stamp_now``).

Importing this module puts the locators first in numba's list (``install``);
``handarm/__init__.py`` imports it before any kernel is defined (a kernel picks its locator
when it is decorated). Functions outside the package keep numba's own locators.
"""

from __future__ import annotations

import functools
import hashlib
import uuid
from pathlib import Path

from numba.core import caching

ROOT = Path(__file__).resolve().parent


def _sources(root: Path) -> list[Path]:
    """The package's source files: its regular ``.py`` files.

    Not an editor's hidden lock or backup files (Emacs keeps a dangling ``.#name.py`` link
    while a buffer is modified).
    """
    return sorted(p for p in root.rglob("*.py") if not p.name.startswith(".") and p.is_file())


def _stat_key(root: Path, paths=None) -> tuple:
    """(path, modification time, size) of every source file: what the digest is cached by.

    ``paths``: the files to look at (default: ``_sources(root)``).
    """
    key = []
    for path in _sources(root) if paths is None else paths:
        try:
            st = path.stat()
        except OSError:
            continue
        key.append((str(path), st.st_mtime_ns, st.st_size))
    return tuple(key)


def source_digest(root: Path) -> bytes:
    """SHA-256 of every source file under ``root``: their paths (relative) and contents.

    A file that cannot be read is left out (Python could not import it either).
    """
    return _digest(root, _stat_key(root))


@functools.lru_cache(maxsize=8)
def _digest(root: Path, key: tuple) -> bytes:
    h = hashlib.sha256()
    for name, _, _ in key:
        path = Path(name)
        try:
            data = path.read_bytes()
        except OSError:
            continue
        h.update(path.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(data)
        h.update(b"\0")
    return h.digest()


#: The sources when the package was imported (``handarm/__init__`` imports this module
#: first): what every module the process imports later is checked against.
_FILES = _sources(ROOT)
_AT_IMPORT = _digest(ROOT, _stat_key(ROOT, _FILES))


def stamp_now(root: Path, files: list[Path], at_import: bytes):
    """``at_import`` while the sources under ``root`` are as they were, else a new stamp.

    Modules load lazily, so a kernel may be defined after a source file was edited in a
    running process. That process then holds some modules as they were and some as they
    are, and no cache entry fits that mixture: the stamp is then new every time, so the
    process reuses no compiled code and what it stores is never reused.
    """
    if _digest(root, _stat_key(root, files)) == at_import:
        return at_import
    return ("sources edited while running", uuid.uuid4().hex)


def package_stamp():
    """The stamp of every handarm kernel: the digest of the sources at import (``stamp_now``)."""
    return stamp_now(ROOT, _FILES, _AT_IMPORT)


@functools.cache
def _module_stamp(py_file: str):
    """``package_stamp`` when the module in ``py_file`` defined its first kernel.

    A module is imported once per process and defines its kernels then, so the sources are
    looked at once per module (a look takes about a millisecond), not once per kernel.
    """
    return package_stamp()


def _inside(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(ROOT)
    except (OSError, ValueError):
        return False


class _PackageStamp:
    """Locator mixin: handarm's kernels are fresh while the whole package is unchanged."""

    def get_source_stamp(self):
        return _module_stamp(self._py_file)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _inside(py_file):
            return None
        return super().from_function(py_func, py_file)


class UserProvidedLocator(_PackageStamp, caching.UserProvidedCacheLocator):
    """numba's cache in ``NUMBA_CACHE_DIR`` when that is set, the package's stamp."""


class InTreeLocator(_PackageStamp, caching.InTreeCacheLocator):
    """numba's in-tree cache (``__pycache__`` beside the source), the package's stamp."""


class UserWideLocator(_PackageStamp, caching.UserWideCacheLocator):
    """numba's user-wide cache (a read-only install), the package's stamp."""


def install() -> None:
    """Put the package locators first in numba's list of cache locators (once).

    In numba's own order: ``NUMBA_CACHE_DIR`` if set, beside the source, user-wide.
    """
    classes = caching.CacheImpl._locator_classes
    if InTreeLocator not in classes:
        classes[:0] = [UserProvidedLocator, InTreeLocator, UserWideLocator]


install()
