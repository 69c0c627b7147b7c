"""The compiled kernels' cache is stamped by the whole package (``handarm._jitcache``)."""

from __future__ import annotations

import importlib.util
import shutil
import sys

from numba.core import caching

import handarm
from handarm import _jitcache


def test_every_kernel_is_cached_under_the_package_stamp():
    """A kernel that calls into other modules is stale when any of them changes: each of
    handarm's cached kernels carries the digest of the whole package, whichever file it is
    in."""
    from handarm import _collide
    from handarm.ik import _printed, _solve

    kernels = [_solve.count_many, _solve.solve_many, _printed.printed_ranges, _collide.free_many]
    for k in kernels:
        locator = k._cache._impl._locator
        assert isinstance(locator, _jitcache._PackageStamp), (k, type(locator))
        assert locator.get_source_stamp() == _jitcache.source_digest(_jitcache.ROOT)
    assert handarm.ik.solve(handarm.ArmDesign(), [0.2, 0.05, 0.03], [1.0, 0.0, 0.0]).count >= 0


def test_the_stamp_changes_with_any_source_file_and_only_with_its_content(tmp_path):
    root = tmp_path / "pkg"
    shutil.copytree(_jitcache.ROOT, root, ignore=shutil.ignore_patterns("__pycache__"))
    before = _jitcache.source_digest(root)
    deep = root / "ik" / "_printed.py"
    deep.touch()  # a new time, the same bytes
    assert _jitcache.source_digest(root) == before
    deep.write_text(deep.read_text() + "\n# changed\n")
    assert _jitcache.source_digest(root) != before
    deep.write_text(deep.read_text().removesuffix("\n# changed\n"))
    assert _jitcache.source_digest(root) == before
    (root / "new_module.py").write_text("X = 1\n")
    assert _jitcache.source_digest(root) != before


def test_sources_edited_after_import_give_a_stamp_nothing_shares(tmp_path):
    """A process that imported handarm before an edit holds a mixture of old and new
    modules: no cached code fits it, so its stamp matches nothing, not even itself."""
    root = tmp_path / "pkg"
    shutil.copytree(_jitcache.ROOT, root, ignore=shutil.ignore_patterns("__pycache__"))
    files = _jitcache._sources(root)
    at_import = _jitcache.source_digest(root)
    assert _jitcache.stamp_now(root, files, at_import) == at_import
    (root / "collision.py").touch()
    assert _jitcache.stamp_now(root, files, at_import) == at_import
    (root / "collision.py").write_text((root / "collision.py").read_text() + "\n# edit\n")
    first, second = (_jitcache.stamp_now(root, files, at_import) for _ in range(2))
    assert first != at_import and second != at_import and first != second


def test_editor_lock_files_and_unreadable_entries_are_not_sources(tmp_path):
    """Emacs keeps a dangling ``.#name.py`` link beside a modified buffer: the digest, and
    so every kernel's import, must not trip over it."""
    root = tmp_path / "pkg"
    shutil.copytree(_jitcache.ROOT, root, ignore=shutil.ignore_patterns("__pycache__"))
    before = _jitcache.source_digest(root)
    (root / "ik" / ".#_solve.py").symlink_to("user@host.1234:1700000000")
    (root / "dangling.py").symlink_to(tmp_path / "nowhere.py")
    assert _jitcache.source_digest(root) == before


def test_kernels_outside_the_package_keep_numbas_locators(tmp_path):
    src = tmp_path / "outside_kernel.py"
    src.write_text("import numba\n\n@numba.njit(cache=True)\ndef plus_one(x):\n    return x + 1\n")
    spec = importlib.util.spec_from_file_location("outside_kernel", src)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["outside_kernel"] = mod
    try:
        spec.loader.exec_module(mod)
        locator = mod.plus_one._cache._impl._locator
        assert not isinstance(locator, _jitcache._PackageStamp)
        assert isinstance(locator, caching._CacheLocator)
        assert mod.plus_one(1) == 2
    finally:
        sys.modules.pop("outside_kernel", None)
