"""Lazy attributes of a package (PEP 562): submodules and names load on first use."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from typing import Any


def lazy_attributes(
    package: str, modules: Iterable[str], names: Mapping[str, str] | None = None
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    modules : iterable of str
        Submodules reachable as attributes (``handarm.ik`` as ``handarm.ik``).
    names : mapping of str to str, optional
        Attribute name -> the module (relative to ``package``, or absolute when it contains
        a dot) that defines it.
    """
    modules = frozenset(modules)
    names = dict(names or {})

    def __getattr__(name: str) -> Any:
        if name in modules:
            return importlib.import_module(f"{package}.{name}")
        if name in names:
            where = names[name]
            module = where if "." in where else f"{package}.{where}"
            return getattr(importlib.import_module(module), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        import sys

        return sorted(set(vars(sys.modules[package])) | modules | set(names))

    return __getattr__, __dir__
