"""Study files: a named list of designs and the map settings they share.

A study file (TOML)::

    name = "joints-2-and-5"
    design = "arm.toml"          # optional, relative to the study file; default: the paper's arm
    voxel = 0.02                 # map settings for every design (m, count, index threshold)
    directions = 56
    threshold = 0.5

    [grid]                       # every combination of these
    limit_deg_2 = [120, 135, 150]   # symmetric limit of joint 2, degrees
    limit_deg_5 = [120, 135, 150]
    clearance = [0.0003, 0.0004]    # any numeric ArmDesign field

    [weights]                    # handarm.workspace.scores.DEFAULT_WEIGHTS by name
    mass = 0.5

    [[designs]]                  # and/or explicit designs: a name and field overrides
    name = "wide-5"
    limit_deg_5 = 160

Every design is carved (mass, minimum cross-section, achieved limits) and mapped with the
achieved limits (the limits the printed links really allow, within the requested ones).
Results go to ``OUT/designs/<key>.json`` as each design finishes (atomically), so an
interrupted run loses nothing and a re-run only computes what is missing. The table, the
Pareto front and the pictures are made from those files; the per-joint sensitivity of the
base design goes to ``OUT/sensitivity.json``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
import tomllib
from pathlib import Path

from handarm._io import read_regular_bytes
from handarm._resources import check_voxel
from handarm.design import ArmDesign
from handarm.workspace.maps import MIN_WIDTH, direction_set
from handarm.workspace.scores import DEFAULT_WEIGHTS

__all__ = ["Study", "apply_params", "load_study", "design_key", "study_settings"]

_SETTINGS = ("voxel", "directions", "threshold")
_STUDY_KEYS = {"name", "design", "grid", "designs", "weights", *_SETTINGS}


@dataclasses.dataclass(frozen=True, eq=False)  # holds dicts: identity equality
class Study:
    """A named list of designs with the map settings and score weights they share."""

    name: str
    base: ArmDesign
    designs: tuple[tuple[str, dict, ArmDesign], ...]  # (name, parameters, design)
    voxel: float = 0.02
    directions: int = 56
    threshold: float = 0.5
    weights: dict = dataclasses.field(default_factory=dict)


def apply_params(base: ArmDesign, params: dict, where: str) -> ArmDesign:
    """The base design with named parameters applied.

    ``limit_deg_K`` sets a symmetric limit of joint K (degrees), ``link_length_K`` sets a_K
    (m, K = 0..6), ``pulley_radius_K`` the joint pulley K (m); any other name is an
    ``ArmDesign`` field.

    Raises
    ------
    ValueError
        If a name or value is wrong or the design is invalid; the message starts with
        ``where``.
    """
    limits = list(base.joint_limits)
    lengths = list(base.link_lengths)
    radii = list(base.joint_pulley_radii)
    fields = {}
    indexed = {"limit_deg_": (1, 6), "link_length_": (0, 6), "pulley_radius_": (1, 6)}
    for key, value in params.items():
        prefix = next((p for p in indexed if key.startswith(p)), None)
        if prefix is None:
            fields[key] = value
            continue
        lo, hi = indexed[prefix]
        try:
            k = int(key.removeprefix(prefix))
        except ValueError:
            k = -1
        if not lo <= k <= hi:
            what = "joint number" if prefix != "link_length_" else "link number"
            raise ValueError(f"{where}: {key!r}: {what} must be {lo}..{hi}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise ValueError(f"{where}: {key}: expected a positive number, got {value!r}")
        if prefix == "limit_deg_":
            limits[k - 1] = (-math.radians(value), math.radians(value))
        elif prefix == "link_length_":
            lengths[k] = float(value)
        else:
            radii[k - 1] = float(value)
    try:
        return base.replace(
            joint_limits=tuple(limits),
            link_lengths=tuple(lengths),
            joint_pulley_radii=tuple(radii),
            **fields,
        )
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def load_study(path: str | os.PathLike[str]) -> Study:
    """Read and validate a study file (see the module doc).

    Every value is checked here, before any work starts, and a bad one is refused with its
    field named: map settings (``voxel`` a positive number of metres, ``directions`` an
    integer >= 4, ``threshold`` in (0, 1]), score weights (numbers), grid entries (non-empty
    lists; an empty ``[grid]`` is an error, not a silent single design) and every design's
    fields.

    Raises
    ------
    FileNotFoundError
        If the file (or the base design it names) does not exist.
    ValueError
        If a value is wrong; the message names the file and the field.
    """
    path = Path(path)
    try:
        data = tomllib.loads(read_regular_bytes(path).decode("utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"study file not found: {path}") from None
    except ValueError as exc:  # TOML syntax, encoding, a FIFO or device
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    unknown = sorted(set(data) - _STUDY_KEYS)
    if unknown:
        raise ValueError(f"{path}: unknown key {unknown[0]!r}; known: {sorted(_STUDY_KEYS)}")
    settings = _settings(path, data)
    weights = _weights(path, data.get("weights", {}))
    base = ArmDesign()
    if "design" in data:
        if not isinstance(data["design"], str):
            raise ValueError(f"{path}: design: expected a file name, got {data['design']!r}")
        base = ArmDesign.from_toml((path.parent / data["design"]).resolve())
    if "voxel" in settings:  # the base design's reach: millimetres show at once
        check_voxel(base, settings["voxel"], f"{path}: voxel")
    designs = []
    if "grid" in data:
        grid = data["grid"]
        if not isinstance(grid, dict):
            raise ValueError(f"{path}: grid: expected a table of lists")
        if not grid:
            raise ValueError(f"{path}: grid: empty; give at least one field and its values")
        for key, values in grid.items():
            if key == "name":  # each row's name is made from its values
                raise ValueError(
                    f"{path}: grid.name: a design's name is not a variable (each grid row is "
                    "named after its values); list named designs under [[designs]] instead"
                )
            if not isinstance(values, list) or not values:
                raise ValueError(f"{path}: grid.{key}: expected a non-empty list")
        keys = list(grid)
        for combo in itertools.product(*(grid[k] for k in keys)):
            params = dict(zip(keys, combo, strict=True))
            name = ",".join(f"{k}={v}" for k, v in params.items())
            designs.append((name, params, apply_params(base, params, f"{path}: grid {name}")))
    entries = data.get("designs", [])
    if not isinstance(entries, list):
        raise ValueError(f"{path}: designs: expected an array of tables ([[designs]])")
    for n, entry in enumerate(entries):
        if not isinstance(entry, dict):
            raise ValueError(f"{path}: designs[{n}]: expected a table")
        params = {k: v for k, v in entry.items() if k != "name"}
        name = entry.get("name", f"design{n}")
        if not isinstance(name, str) or not name:
            raise ValueError(f"{path}: designs[{n}].name: expected a non-empty string")
        designs.append((name, params, apply_params(base, params, f"{path}: designs[{n}] ({name})")))
    if not designs:
        designs.append(("base", {}, base))
    names = [d[0] for d in designs]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise ValueError(f"{path}: design names must be distinct; {dup!r} appears twice")
    return Study(
        str(data.get("name", path.stem)), base, tuple(designs), **settings, weights=weights
    )


def _settings(path: Path, data: dict) -> dict:
    out = {}
    if "voxel" in data:
        v = data["voxel"]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{path}: voxel: expected a number of metres, got {v!r}")
        if not v > 0:
            raise ValueError(f"{path}: voxel: must be > 0, got {v}")
        out["voxel"] = float(v)
    if "directions" in data:
        v = data["directions"]
        if isinstance(v, bool) or not isinstance(v, int) or v < 4:
            raise ValueError(f"{path}: directions: expected an integer >= 4, got {v!r}")
        try:
            direction_set(v)  # honoured exactly or refused with the nearest valid counts
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
        out["directions"] = v
    if "threshold" in data:
        v = data["threshold"]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v <= 1.0:
            raise ValueError(f"{path}: threshold: expected a number in (0, 1], got {v!r}")
        out["threshold"] = float(v)
    return out


def _weights(path: Path, weights) -> dict:
    if not isinstance(weights, dict):
        raise ValueError(f"{path}: weights: expected a table of numbers")
    out = {}
    for key, value in weights.items():
        if key not in DEFAULT_WEIGHTS:
            raise ValueError(
                f"{path}: weights.{key}: unknown weight; known: {sorted(DEFAULT_WEIGHTS)}"
            )
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{path}: weights.{key}: expected a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{path}: weights.{key}: must be finite, got {value}")
        out[key] = float(value)
    return out


def design_key(design: ArmDesign, settings: dict) -> str:
    """A short hash of a design and the map settings: the name of its result files."""
    blob = json.dumps({"design": design.to_dict(), "settings": settings}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def study_settings(study: Study) -> dict:
    """The map settings a study's results are computed with and keyed by."""
    return {
        "voxel": study.voxel,
        "directions": study.directions,
        "threshold": study.threshold,
        "min_width": MIN_WIDTH,
    }
