"""Small input checks shared by the public functions; each names the offending argument."""

from __future__ import annotations

from typing import Any

import numpy as np

from handarm.design import ArmDesign


def check_design(design: Any, name: str = "design") -> ArmDesign:
    """Return ``design`` if it is an ArmDesign, else raise TypeError naming it."""
    if not isinstance(design, ArmDesign):
        raise TypeError(f"{name}: expected an ArmDesign, got {type(design).__name__}")
    return design


def check_array(value: Any, name: str, last: int, *, finite: bool = True) -> np.ndarray:
    """Float array of shape (..., last); raise ValueError naming ``name`` otherwise.

    Only real numbers: complex values (whose imaginary part a conversion drops with a
    warning), booleans, strings and other objects are refused, not converted.
    """
    arr = real_array(value)
    if arr is None:
        raise ValueError(f"{name}: expected real numbers, got {_kind(value)}")
    if arr.ndim == 0 or arr.shape[-1] != last:
        raise ValueError(f"{name}: expected shape (..., {last}), got {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr


def real_array(value: Any) -> np.ndarray | None:
    """``value`` as a float array if it holds only real numbers (ints, floats), else None."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):  # ragged
        return None
    if arr.dtype.kind not in "iuf" or _holds_bool(value):
        return None
    return arr.astype(float, copy=False)


def _holds_bool(value: Any) -> bool:
    """A boolean inside nested lists: numpy makes [True, 0.5] an array of numbers."""
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, (list, tuple)):
        for v in value:  # one loop per level: a list of 1e5 points costs ~10 ms
            t = type(v)
            if t is bool or t is np.bool_ or ((t is list or t is tuple) and _holds_bool(v)):
                return True
    return False


def _kind(value: Any) -> str:
    try:
        kind = np.asarray(value).dtype
    except (TypeError, ValueError):
        return f"{type(value).__name__} of uneven rows"
    names = {"c": "complex numbers", "b": "booleans", "U": "strings", "S": "bytes"}
    return names.get(kind.kind, type(value).__name__)


def check_joints(q: Any, name: str = "q") -> np.ndarray:
    """Joint angles, shape (..., 6), radians, finite."""
    return check_array(q, name, 6)


def check_number(value: Any, name: str, *, low: float | None = None, unit: str = "") -> float:
    """A finite real number (at least ``low`` if given) as a float; ValueError naming ``name``.

    ``unit`` is said in the message ("m", "rad"). Booleans, strings, None and arrays of more
    than one number are refused, not converted.
    """
    at_least = "" if low is None else f" >= {low:g}"
    unit = f" ({unit})" if unit else ""
    real = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not real and not (
        isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind in "iuf"
    ):
        raise ValueError(
            f"{name}: expected a finite number{at_least}{unit}, got {type(value).__name__}"
        )
    x = float(value)
    if not np.isfinite(x) or (low is not None and x < low):
        raise ValueError(f"{name}: expected a finite number{at_least}{unit}, got {value!r}")
    return x
