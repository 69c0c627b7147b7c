"""Optimization files: variables, objectives in physical units, constraints, map settings.

An optimization file (TOML)::

    name = "neighbourhood"
    design = "arm.toml"            # optional, relative to this file; default: the paper's arm
    sampler = "tpe"                # tpe | nsga2 | gp | grid (the --sampler option overrides)
    population = 20                # NSGA-II's generation size (keep it across resumed runs)
    trials = 40                    # total finished trials wanted (--trials overrides)
    seed = 0

    [map]                          # screening maps (every trial)
    voxel = 0.05                   # m
    directions = 16                # a valid count of handarm.workspace.maps.direction_set
    threshold = 0.5                # reachability index counted as dexterous
    min_width = 1e-6               # narrowest counted IK solution range (m of u)
    full_voxel = 0.03              # optional: the front re-evaluated at this resolution ...
    full_directions = 36
    repeats = 2                    # ... with this many jittered grids / rotated direction sets

    [variables]                    # name = {low, high[, step][, type = "int"]} or {choices}
    limit_deg_2 = {low = 90, high = 170}       # symmetric limit of joint 2 (degrees)
    link_length_3 = {low = 0.04, high = 0.06}  # a_3 (m); link_length_0..6
    pulley_radius_2 = {low = 0.006, high = 0.012}  # joint pulley 2 (m); 1..6
    beam_width = {low = 0.010, high = 0.014}   # any numeric design field
    servo_model = {choices = ["MX-64T", "MX-106T"]}

    [objectives]                   # name = "maximize" | "minimize" | {direction, reference}
    dexterous_volume = "maximize"  # L
    mass = "minimize"              # g

    [constraints]                  # all optional
    max_mass_g = 200
    min_cross_section_mm2 = 40
    min_payload_kg = 0.2
    task_poses = "poses.csv"       # x, y, z, ex, ey, ez per row (m, relative to the handle)

Objectives are measurements in physical units (``OBJECTIVES``): no objective is divided by
the design's own size. Printability (carving succeeds, every link one watertight body) and
motor travel (within the servo's multi-turn range) are always required.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
import math
import os
import tomllib
from pathlib import Path

import numpy as np

from handarm._resources import check_voxel
from handarm.design import ArmDesign
from handarm.workspace.maps import MIN_WIDTH, direction_set
from handarm.workspace.study_file import apply_params

__all__ = ["OBJECTIVES", "CONSTRAINTS", "Objective", "Variable", "OptFile", "load_opt"]

#: objective name -> (measurement key, unit, default hypervolume reference)
OBJECTIVES = {
    "dexterous_volume": ("dexterous_volume_L", "L", 0.0),
    "reachable_volume": ("reachable_volume_L", "L", 0.0),
    "mean_index": ("mean_index", "", 0.0),
    "mass": ("mass_g", "g", 500.0),
    "min_cross_section": ("min_cross_section_mm2", "mm^2", 0.0),
    "payload": ("payload_kg", "kg", 0.0),
}
#: constraint name -> (measurement key, sense): "max" means measurement <= bound
CONSTRAINTS = {
    "max_mass_g": ("mass_g", "max"),
    "min_cross_section_mm2": ("min_cross_section_mm2", "min"),
    "min_payload_kg": ("payload_kg", "min"),
    "min_dexterous_volume_L": ("dexterous_volume_L", "min"),
}
_SAMPLERS = ("nsga2", "tpe", "gp", "grid")
_KEYS = {"name", "design", "sampler", "trials", "seed", "map", "variables", "objectives"}
_KEYS |= {"constraints", "grid_points", "population"}
_MAP_KEYS = {"voxel", "directions", "threshold", "min_width", "full_voxel", "full_directions"}
_MAP_KEYS |= {"repeats"}


@dataclasses.dataclass(frozen=True)
class Variable:
    """One design variable: a float or int range (optionally stepped), or a list of choices."""

    name: str
    low: float | None = None
    high: float | None = None
    step: float | None = None
    integer: bool = False
    choices: tuple | None = None


@dataclasses.dataclass(frozen=True)
class Objective:
    """One objective: its name, measurement key, unit, direction and hypervolume reference."""

    name: str
    key: str
    unit: str
    direction: str
    reference: float


@dataclasses.dataclass(frozen=True, eq=False)  # holds dicts: identity equality
class OptFile:
    """A validated optimization file (see the module doc)."""

    path: Path
    name: str
    base: ArmDesign
    sampler: str
    trials: int
    seed: int
    map: dict
    variables: tuple[Variable, ...]
    objectives: tuple[Objective, ...]
    constraints: dict
    task_poses: np.ndarray | None
    grid_points: int
    population: int = 20

    def design(self, params: dict) -> ArmDesign:
        """The base design with a trial's variable values applied."""
        return apply_params(self.base, params, "parameters")

    def fingerprint(self) -> str:
        """A hash of everything that decides a trial's result (a stored run must match it)."""
        blob = {
            "base": self.base.to_dict(),
            "map": self.map,
            "variables": [dataclasses.asdict(v) for v in self.variables],
            "objectives": [dataclasses.asdict(o) for o in self.objectives],
            "constraints": self.constraints,
            "task_poses": None if self.task_poses is None else self.task_poses.tolist(),
            "grid_points": self.grid_points,
        }
        return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()[:16]


def _number(where: str, value, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{where}: expected a number, got {value!r}")
    if positive and not value > 0:
        raise ValueError(f"{where}: must be > 0, got {value}")
    return float(value)


def _int(where: str, value, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{where}: expected an integer >= {low}, got {value!r}")
    return value


def _map(path: Path, data) -> dict:
    if not isinstance(data, dict):
        raise ValueError(f"{path}: map: expected a table")
    unknown = sorted(set(data) - _MAP_KEYS)
    if unknown:
        raise ValueError(f"{path}: map.{unknown[0]}: unknown key; known: {sorted(_MAP_KEYS)}")
    out = {"voxel": 0.05, "directions": 16, "threshold": 0.5, "min_width": MIN_WIDTH}
    out |= {"full_voxel": None, "full_directions": None, "repeats": 0}
    for key in ("voxel", "full_voxel"):
        if key in data:
            out[key] = _number(f"{path}: map.{key}", data[key], positive=True)
    for key in ("directions", "full_directions"):
        if key in data:
            n = _int(f"{path}: map.{key}", data[key], 4)
            try:
                direction_set(n)
            except ValueError as exc:
                raise ValueError(
                    f"{path}: map.{key}{str(exc).removeprefix('directions')}"
                ) from None
            out[key] = n
    if "threshold" in data:
        t = _number(f"{path}: map.threshold", data["threshold"])
        if not 0.0 < t <= 1.0:
            raise ValueError(f"{path}: map.threshold: expected a number in (0, 1], got {t}")
        out["threshold"] = t
    if "min_width" in data:
        w = _number(f"{path}: map.min_width", data["min_width"])
        if w < 0:
            raise ValueError(f"{path}: map.min_width: must be >= 0, got {w}")
        out["min_width"] = w
    if "repeats" in data:
        out["repeats"] = _int(f"{path}: map.repeats", data["repeats"], 0)
    return out


def _variables(path: Path, base: ArmDesign, data) -> tuple[Variable, ...]:
    if not isinstance(data, dict) or not data:
        raise ValueError(f"{path}: variables: expected a non-empty table of variables")
    out = []
    for name, spec in data.items():
        where = f"{path}: variables.{name}"
        if not isinstance(spec, dict):
            raise ValueError(f"{where}: expected {{low, high}} or {{choices}}")
        unknown = sorted(set(spec) - {"low", "high", "step", "type", "choices"})
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key")
        if "choices" in spec:
            choices = spec["choices"]
            if not isinstance(choices, list) or not choices:
                raise ValueError(f"{where}.choices: expected a non-empty list")
            var = Variable(name, choices=tuple(choices))
            samples = list(choices)
        else:
            if "low" not in spec or "high" not in spec:
                raise ValueError(f"{where}: expected low and high (or choices)")
            integer = spec.get("type", "float") == "int"
            if spec.get("type", "float") not in ("float", "int"):
                raise ValueError(f'{where}.type: expected "float" or "int"')
            low = _number(f"{where}.low", spec["low"])
            high = _number(f"{where}.high", spec["high"])
            if not low < high:
                raise ValueError(f"{where}: expected low < high, got {low} and {high}")
            step = _number(f"{where}.step", spec["step"], True) if "step" in spec else None
            var = Variable(name, low, high, step, integer)
            samples = [int(low) if integer else low, int(high) if integer else high]
        for value in samples:  # every bound and choice must make a design: refuse before work
            apply_params(base, {name: value}, where)
        out.append(var)
    return tuple(out)


def _objectives(path: Path, data) -> tuple[Objective, ...]:
    if not isinstance(data, dict) or not data:
        raise ValueError(f'{path}: objectives: expected a non-empty table, e.g. mass = "minimize"')
    out = []
    for name, spec in data.items():
        where = f"{path}: objectives.{name}"
        if name not in OBJECTIVES:
            raise ValueError(f"{where}: unknown objective; known: {sorted(OBJECTIVES)}")
        key, unit, reference = OBJECTIVES[name]
        if isinstance(spec, str):
            spec = {"direction": spec}
        if not isinstance(spec, dict) or spec.get("direction") not in ("maximize", "minimize"):
            raise ValueError(f'{where}: expected "maximize" or "minimize"')
        if "reference" in spec:
            reference = _number(f"{where}.reference", spec["reference"])
        out.append(Objective(name, key, unit, spec["direction"], reference))
    return tuple(out)


def _constraints(path: Path, data) -> tuple[dict, np.ndarray | None]:
    if not isinstance(data, dict):
        raise ValueError(f"{path}: constraints: expected a table")
    out, poses = {}, None
    for name, value in data.items():
        where = f"{path}: constraints.{name}"
        if name == "task_poses":
            if not isinstance(value, str):
                raise ValueError(f"{where}: expected a CSV file name")
            poses = load_task_poses(path.parent / value, where)
        elif name in CONSTRAINTS:
            out[name] = _number(where, value)
        else:
            known = sorted([*CONSTRAINTS, "task_poses"])
            raise ValueError(f"{where}: unknown constraint; known: {known}")
    return out, poses


def load_task_poses(path: Path, where: str) -> np.ndarray:
    """Task poses from a CSV of x, y, z, ex, ey, ez (m, relative to the handle), shape (n, 6).

    A first row that is not numbers is taken as a header.
    """
    try:
        rows = list(csv.reader(Path(path).read_text().splitlines()))
    except FileNotFoundError:
        raise FileNotFoundError(f"{where}: file not found: {path}") from None
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    out = []
    for n, row in enumerate(rows):
        try:
            values = [float(c) for c in row]
        except ValueError:
            if n == 0:
                continue  # header
            raise ValueError(f"{where}: {path} row {n + 1}: expected 6 numbers") from None
        if len(values) != 6 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"{where}: {path} row {n + 1}: expected 6 finite numbers")
        if np.linalg.norm(values[3:]) < 1e-9:
            raise ValueError(f"{where}: {path} row {n + 1}: the direction is zero")
        out.append(values)
    if not out:
        raise ValueError(f"{where}: {path} holds no poses")
    return np.array(out)


def load_opt(path: str | os.PathLike[str]) -> OptFile:
    """Read and validate an optimization file; every value is checked before any work.

    Raises
    ------
    FileNotFoundError
        If the file, its base design or its task-pose CSV does not exist.
    ValueError
        If a value is wrong; the message names the file and the field.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"optimization file not found: {path}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        raise ValueError(f"{path}: unknown key {unknown[0]!r}; known: {sorted(_KEYS)}")
    base = ArmDesign()
    if "design" in data:
        if not isinstance(data["design"], str):
            raise ValueError(f"{path}: design: expected a file name, got {data['design']!r}")
        base = ArmDesign.from_toml((path.parent / data["design"]).resolve())
    sampler = data.get("sampler", "tpe")
    if sampler not in _SAMPLERS:
        raise ValueError(f"{path}: sampler: expected one of {list(_SAMPLERS)}, got {sampler!r}")
    constraints, poses = _constraints(path, data.get("constraints", {}))
    settings = _map(path, data.get("map", {}))
    for key in ("voxel", "full_voxel"):
        if settings[key] is not None:  # the base design's reach: millimetres show at once
            check_voxel(base, settings[key], f"{path}: map.{key}")
    return OptFile(
        path=path,
        name=str(data.get("name", path.stem)),
        base=base,
        sampler=sampler,
        trials=_int(f"{path}: trials", data.get("trials", 20), 1),
        seed=_int(f"{path}: seed", data.get("seed", 0), 0),
        map=settings,
        variables=_variables(path, base, data.get("variables")),
        objectives=_objectives(path, data.get("objectives")),
        constraints=constraints,
        task_poses=poses,
        grid_points=_int(f"{path}: grid_points", data.get("grid_points", 5), 2),
        population=_int(f"{path}: population", data.get("population", 20), 2),
    )
