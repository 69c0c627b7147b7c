"""The compiled-code cache of handarm's numba kernels, stamped by the whole package.

numba keeps each ``cache=True`` kernel's machine code beside its source and reuses it while
*that file* is unchanged. A kernel compiled together with the kernels it calls from other
modules (``handarm.ik._solve`` calls ``handarm.ik._printed``, which calls
``handarm._collide``) then outlives a change to them: after editing ``_printed.py`` the
solver still ran the old certification, silently. Here every handarm kernel's cache entry is
stamped with a digest of all of the package's source files instead, so that any change to
handarm's code recompiles every kernel once. An installed release never changes, so nothing
is recompiled there; a working copy pays one compilation after each edit.

Importing this module puts the locators first in numba's list (``install``);
``handarm/__init__.py`` imports it before any kernel is defined (a kernel picks its locator
when it is decorated). Functions outside the package keep numba's own locators.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from numba.core import caching

ROOT = Path(__file__).resolve().parent


def source_digest(root: Path) -> bytes:
    """SHA-256 of every ``.py`` file under ``root``: their paths (relative) and contents."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.digest()


@functools.cache
def package_stamp() -> bytes:
    """The digest of handarm's sources as this process imported them (read once).

    A source file edited while the process runs is not imported again, so its kernels keep
    the code that was read: the stamp of the process start is the right one.
    """
    return source_digest(ROOT)


def _inside(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(ROOT)
    except (OSError, ValueError):
        return False


class _PackageStamp:
    """Locator mixin: handarm's kernels are fresh while the whole package is unchanged."""

    def get_source_stamp(self):
        return package_stamp()

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
