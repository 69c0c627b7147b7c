"""ArmDesign: every parameter of a coupled-tendon arm, with the paper's defaults.

The design is a small frozen value. Everything is SI (metres, radians, kg/m^3).
``ArmDesign.replace(**changes)`` derives a new, validated design cheaply, which
is what trade studies do thousands of times.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from handarm._io import read_regular_bytes, write_text_atomic
from handarm._pulley import drum_hexagon_problem
from handarm.firmware_bridge.mx64 import BAUD_VALUES
from handarm.servo import SERVOS, ServoSpec

__all__ = ["ArmDesign", "PAPER_LIMITS_DEG", "FIELD_BOUNDS", "MIN_BORE_WALL", "NAME_PATTERN"]

#: Joint limits of the paper's arm (section II-A.2), degrees, symmetric.
PAPER_LIMITS_DEG = (135.0, 150.0, 135.0, 125.0, 150.0, 150.0)


#: Collision models ``is_valid`` and the IK know (see ``ArmDesign.collision_model``).
COLLISION_MODELS = ("printed", "paper")

_N_JOINTS = 6
_N_LINKS = 7

#: Physical bounds (inclusive, SI) of every numeric field, per element for the tuples. A
#: design inside them (and the relations of ``_check_relations``) can be carved, mapped,
#: exported and sized; outside them a design is refused at load with the field named.
FIELD_BOUNDS: dict[str, tuple[float, float]] = {
    "link_lengths": (0.005, 0.5),  # m: a desk-sized printed arm
    "beam_width": (0.002, 0.1),
    "beam_thickness": (0.002, 0.1),
    "hub_radius": (0.002, 0.1),
    "axle_diameter": (0.0005, 0.05),
    "cable_diameter": (0.0001, 0.005),
    "idler_width": (0.0005, 0.05),
    "cheek_thickness": (0.0008, 0.05),  # two print lines of a 0.4 mm nozzle
    "clearance": (0.00005, 0.001),
    "joint_pulley_radii": (0.001, 0.1),
    "motor_pulley_radius": (0.001, 0.1),
    "density": (100.0, 20000.0),  # kg/m^3: foams to tungsten-filled filament
    "min_wall": (0.0004, 0.005),  # m: one line of a 0.4 mm nozzle to a solid 5 mm
}

#: Smallest wall around an axle bore that carving keeps (m).
MIN_BORE_WALL = 0.001

#: What a design name may be: it becomes file names (``<name>.urdf``), so no separators,
#: no leading dot, at most 64 characters.
NAME_PATTERN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]{0,63}")


def _default_limits() -> tuple[tuple[float, float], ...]:
    return tuple((-math.radians(d), math.radians(d)) for d in PAPER_LIMITS_DEG)


def _default_routing() -> tuple[tuple[int, ...], ...]:
    # Cable k wraps the idlers of joints 1..k-1 the same way round as its own pulley.
    return tuple(tuple(1 if j <= k else 0 for j in range(_N_JOINTS)) for k in range(_N_JOINTS))


@dataclasses.dataclass(frozen=True)
class ArmDesign:
    """A coupled-tendon 6-DoF arm of the paper's family.

    Parameters
    ----------
    name : str
        A label used in file names and summaries.
    link_lengths : tuple of 7 float
        ``a0..a6`` in metres: the handle stub ``l0``, links ``l1..l5`` and the tool link ``l6``.
    joint_limits : tuple of 6 (lower, upper) pairs
        Joint limits in radians, each within [-pi, pi].
    beam_width, beam_thickness : float
        Cross-section of each link beam, in the joint plane and along the joint axis (m).
    hub_radius : float
        Outer radius of the hub around each joint axle (m).
    axle_diameter : float
        Diameter of the axle bore (m).
    cable_diameter : float
        Tendon diameter (m).
    idler_width : float
        Axial width of one idler pulley, including its flanges (m).
    cheek_thickness : float
        Thickness of each fork cheek (m).
    clearance : float
        Print clearance between parts that move against each other (m).
    joint_pulley_radii : tuple of 6 float
        Radius of the driving pulley (and idlers) at each joint (m).
    motor_pulley_radius : float
        Radius of the pulley on each motor horn (m).
    routing_signs : 6x6 int
        ``routing_signs[k][j]`` is the wrap sign of cable ``k`` on joint ``j``: +1 or -1 for
        ``j <= k`` and 0 above the diagonal (cable k never reaches joints beyond k).
    servo_ids : tuple of 6 int
        Dynamixel IDs of the motors driving joints 1..6.
    servo_model : str
        Servo model name, one of ``handarm.servo.SERVOS``.
    baud_rate : int
        Servo bus baud rate (bit/s).
    density : float
        Density of the printed link material (kg/m^3); ABS by default.
    min_wall : float
        Thinnest wall a printed part may have (m); 1.2 mm suits a 0.4 mm nozzle. Carving
        measures every part's thinnest wall against it (``links/*.json``).
    collision_model : str
        What ``is_valid`` and the IK call a collision: ``"printed"`` (default) checks the
        envelopes of the links the build prints, all 15 non-adjacent pairs, with the
        clearance; ``"paper"`` the paper's zero-thickness segments in their planes.
    """

    name: str = "paper_arm"
    link_lengths: tuple[float, ...] = (0.05,) * _N_LINKS
    joint_limits: tuple[tuple[float, float], ...] = dataclasses.field(
        default_factory=_default_limits
    )
    beam_width: float = 0.012
    beam_thickness: float = 0.010
    hub_radius: float = 0.009
    axle_diameter: float = 0.003
    cable_diameter: float = 0.0015
    idler_width: float = 0.003
    cheek_thickness: float = 0.0025
    clearance: float = 0.0004
    joint_pulley_radii: tuple[float, ...] = (0.008,) * _N_JOINTS
    motor_pulley_radius: float = 0.008
    routing_signs: tuple[tuple[int, ...], ...] = dataclasses.field(default_factory=_default_routing)
    servo_ids: tuple[int, ...] = (1, 2, 3, 4, 5, 6)
    servo_model: str = "MX-64T"
    baud_rate: int = 1_000_000
    density: float = 1040.0
    collision_model: str = "printed"
    min_wall: float = 0.0012

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = _normalise(f.name, getattr(self, f.name))
            object.__setattr__(self, f.name, value)
        _check_relations(self)

    # -- derived arrays (read-only, computed once per design) -------------------------------

    @cached_property
    def servo(self) -> ServoSpec:
        """The specification of the design's servo model."""
        return SERVOS[self.servo_model]

    @cached_property
    def lengths(self) -> np.ndarray:
        """Link lengths ``a0..a6``, shape (7,), metres."""
        return _frozen_array(self.link_lengths)

    @cached_property
    def lower(self) -> np.ndarray:
        """Lower joint limits, shape (6,), radians."""
        return _frozen_array([lo for lo, _ in self.joint_limits])

    @cached_property
    def upper(self) -> np.ndarray:
        """Upper joint limits, shape (6,), radians."""
        return _frozen_array([hi for _, hi in self.joint_limits])

    # -- derivation, dict and TOML --------------------------------------------------------

    def replace(self, **changes: Any) -> ArmDesign:
        """Return a validated copy with ``changes`` applied (unknown fields are errors)."""
        unknown = sorted(set(changes) - _FIELD_NAMES)
        if unknown:
            raise ValueError(f"unknown field {unknown[0]!r}; known fields: {sorted(_FIELD_NAMES)}")
        return dataclasses.replace(self, **changes)

    def with_limits_deg(self, limits_deg: Sequence[float]) -> ArmDesign:
        """Return a copy with symmetric limits ``±limits_deg[k]`` (degrees) on joint k+1."""
        if len(limits_deg) != _N_JOINTS:
            raise ValueError(f"limits_deg: expected 6 values, got {len(limits_deg)}")
        return self.replace(
            joint_limits=tuple((-math.radians(v), math.radians(v)) for v in limits_deg)
        )

    def limited_to(self, limits: Sequence[Sequence[float]]) -> ArmDesign:
        """Return a copy whose joint limits are the design's intersected with ``limits``.

        ``limits`` holds 6 (lower, upper) pairs in radians, e.g. what the carved links allow
        (``CarveResult.as_built``). Raises ValueError naming the joint when an
        intersection is empty.
        """
        pairs = [tuple(map(float, pair)) for pair in limits]
        if len(pairs) != _N_JOINTS or any(len(pair) != 2 for pair in pairs):
            raise ValueError(f"limits: expected 6 (lower, upper) pairs, got {limits!r}")
        joint_limits = []
        for k, ((lo, hi), (a, b)) in enumerate(zip(self.joint_limits, pairs, strict=True)):
            lo, hi = max(lo, a), min(hi, b)
            if lo > hi:
                raise ValueError(
                    f"joint_limits[{k}]: [{math.degrees(self.joint_limits[k][0]):g}, "
                    f"{math.degrees(self.joint_limits[k][1]):g}] deg and the allowed "
                    f"[{math.degrees(a):g}, {math.degrees(b):g}] deg do not overlap"
                )
            joint_limits.append((lo, hi))
        return self.replace(joint_limits=tuple(joint_limits))

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of every field (lists instead of tuples), as written to TOML."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            out[f.name] = _to_lists(value)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ArmDesign:
        """Build a design from a mapping; missing keys take the defaults, unknown keys fail."""
        if not isinstance(data, Mapping):
            raise ValueError(f"design: expected a table of fields, got {type(data).__name__}")
        unknown = sorted(set(data) - _FIELD_NAMES)
        if unknown:
            raise ValueError(
                f"unknown key {unknown[0]!r} in design; "
                f"known keys: {', '.join(sorted(_FIELD_NAMES))}"
            )
        return cls(**dict(data))

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> ArmDesign:
        """Load a design from a TOML file of the same fields as ``to_toml`` writes."""
        path = Path(path)
        try:
            data = tomllib.loads(read_regular_bytes(path).decode("utf-8"))
        except FileNotFoundError:
            raise FileNotFoundError(f"design file not found: {path}") from None
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc.reason}") from None
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from None
        except ValueError as exc:  # a FIFO, device or huge file
            raise ValueError(f"{path}: {exc}") from None
        try:
            return cls.from_dict(data)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None

    def to_toml_string(self) -> str:
        """The design as TOML text; floats are written exactly (shortest round-trip repr)."""
        lines = [
            "# handarm arm design. SI units: metres, radians, kg/m^3.",
            "# link_lengths = a0..a6; joint_limits = [lower, upper] per joint 1..6.",
        ]
        for key, value in self.to_dict().items():
            if key == "joint_limits":
                lines.append("joint_limits = [")
                for k, (lo, hi) in enumerate(value):
                    deg = f"{math.degrees(lo):g} .. {math.degrees(hi):g} deg"
                    lines.append(
                        f"    [{_toml_value(lo)}, {_toml_value(hi)}],  # joint {k + 1}: {deg}"
                    )
                lines.append("]")
            elif key == "routing_signs":
                lines.append("routing_signs = [")
                lines += [f"    {_toml_value(row)}," for row in value]
                lines.append("]")
            else:
                lines.append(f"{key} = {_toml_value(value)}")
        return "\n".join(lines) + "\n"

    def to_toml(self, path: str | os.PathLike[str]) -> Path:
        """Write the design to ``path`` atomically; returns the path."""
        path = Path(path)
        write_text_atomic(path, self.to_toml_string())
        return path


_FIELD_NAMES = frozenset(f.name for f in dataclasses.fields(ArmDesign))


# -- validation ------------------------------------------------------------------------------


def _frozen_array(values: Any) -> np.ndarray:
    arr = np.array(values, dtype=float)
    arr.flags.writeable = False
    return arr


def _toml_value(value: Any) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, str):
        return tomli_w.dumps({"v": value})[4:].strip()
    return repr(value)


def _to_lists(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_to_lists(v) for v in value]
    return value


def _number(field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{field}: expected a number, got {type(value).__name__} {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{field}: must be finite, got {x}")
    return x


def _integer(field: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{field}: expected an integer, got {type(value).__name__} {value!r}")
    return int(value)


def _positive(field: str, value: Any) -> float:
    x = _number(field, value)
    if x <= 0.0:
        raise ValueError(f"{field}: must be > 0, got {x}")
    return x


def _bounded(name: str, field: str, value: Any) -> float:
    """A positive number within ``FIELD_BOUNDS[name]``; ``field`` names it in errors."""
    x = _positive(field, value)
    lo, hi = FIELD_BOUNDS[name]
    if not lo <= x <= hi:
        raise ValueError(f"{field}: {x:g} is outside the physical range {lo:g} .. {hi:g}")
    return x


def _sequence(field: str, value: Any, n: int) -> Sequence[Any]:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{field}: expected a list of {n} values, got {type(value).__name__}")
    if len(value) != n:
        raise ValueError(f"{field}: expected {n} values, got {len(value)}")
    return value


def _normalise(name: str, value: Any) -> Any:
    """Check one field on its own and return it in canonical (hashable) form."""
    if name == "collision_model":
        if value not in COLLISION_MODELS:
            raise ValueError(
                f"collision_model: expected one of {list(COLLISION_MODELS)}, got {value!r}"
            )
        return value
    if name in ("name", "servo_model"):
        if not isinstance(value, str) or not value:
            raise ValueError(f"{name}: expected a non-empty string, got {value!r}")
        if name == "servo_model" and value not in SERVOS:
            raise ValueError(f"servo_model: unknown model {value!r}; known: {sorted(SERVOS)}")
        if name == "name" and not NAME_PATTERN.fullmatch(value):
            raise ValueError(
                f"name: {value[:80]!r} is not a file-name-safe label (letters, digits, "
                "'_', '.', '+', '-'; not starting with '.'; at most 64 characters)"
            )
        return value
    if name in ("link_lengths", "joint_pulley_radii"):
        seq = _sequence(name, value, _N_LINKS if name == "link_lengths" else _N_JOINTS)
        return tuple(_bounded(name, f"{name}[{k}]", v) for k, v in enumerate(seq))
    if name == "joint_limits":
        return _limits(value)
    if name == "routing_signs":
        return _routing(value)
    if name == "servo_ids":
        seq = _sequence(name, value, _N_JOINTS)
        ids = tuple(_integer(f"{name}[{k}]", v) for k, v in enumerate(seq))
        for k, i in enumerate(ids):
            if not 0 <= i <= 252:
                raise ValueError(f"servo_ids[{k}]: Dynamixel IDs are 0..252, got {i}")
        if len(set(ids)) != len(ids):
            raise ValueError(f"servo_ids: IDs must be distinct, got {list(ids)}")
        return ids
    if name == "baud_rate":
        baud = _integer(name, value)
        if baud not in BAUD_VALUES:
            raise ValueError(
                f"baud_rate: {baud} is not a rate the servo and the Dynamixel SDK share; "
                f"choose one of {sorted(BAUD_VALUES)}"
            )
        return baud
    return _bounded(name, name, value)


def _limits(value: Any) -> tuple[tuple[float, float], ...]:
    seq = _sequence("joint_limits", value, _N_JOINTS)
    out = []
    for k, pair in enumerate(seq):
        pair = _sequence(f"joint_limits[{k}]", pair, 2)
        lo = _number(f"joint_limits[{k}][0]", pair[0])
        hi = _number(f"joint_limits[{k}][1]", pair[1])
        if lo > hi:
            raise ValueError(f"joint_limits[{k}]: lower {lo:g} exceeds upper {hi:g}")
        for side, x in (("lower", lo), ("upper", hi)):
            if abs(x) > math.pi:
                raise ValueError(
                    f"joint_limits[{k}]: {side} {x:g} rad ({math.degrees(x):g} deg) "
                    "is beyond +-180 degrees"
                )
        out.append((lo, hi))
    return tuple(out)


def _routing(value: Any) -> tuple[tuple[int, ...], ...]:
    rows = _sequence("routing_signs", value, _N_JOINTS)
    out = []
    for k, row in enumerate(rows):
        row = _sequence(f"routing_signs[{k}]", row, _N_JOINTS)
        signs = tuple(_integer(f"routing_signs[{k}][{j}]", s) for j, s in enumerate(row))
        for j, s in enumerate(signs):
            if j <= k and s not in (-1, 1):
                raise ValueError(
                    f"routing_signs[{k}][{j}]: cable {k + 1} wraps joint {j + 1}, "
                    f"so the sign must be +1 or -1, got {s}"
                )
            if j > k and s != 0:
                raise ValueError(
                    f"routing_signs[{k}][{j}]: cable {k + 1} does not reach joint "
                    f"{j + 1}, so the sign must be 0, got {s}"
                )
        out.append(signs)
    return tuple(out)


def _check_relations(d: ArmDesign) -> None:
    """Checks between fields (each field is already valid on its own)."""
    bore = d.axle_diameter / 2.0 + d.clearance
    if bore + MIN_BORE_WALL > d.hub_radius:
        raise ValueError(
            f"hub_radius: {d.hub_radius:g} m leaves no wall around the axle bore "
            f"(axle_diameter/2 + clearance = {bore:g} m; the wall must be at least "
            f"{MIN_BORE_WALL:g} m)"
        )
    if d.cable_diameter >= d.idler_width:
        raise ValueError(
            f"idler_width: {d.idler_width:g} m must exceed cable_diameter {d.cable_diameter:g} m"
        )
    if 2.0 * d.clearance > d.cheek_thickness:
        raise ValueError(
            f"clearance: {d.clearance:g} m is more than half the cheek_thickness "
            f"{d.cheek_thickness:g} m"
        )
    for k, r in enumerate(d.joint_pulley_radii):
        if r <= d.cable_diameter:
            raise ValueError(
                f"joint_pulley_radii[{k}]: {r:g} m must exceed cable_diameter "
                f"{d.cable_diameter:g} m"
            )
    if d.motor_pulley_radius <= d.cable_diameter:
        raise ValueError(
            f"motor_pulley_radius: {d.motor_pulley_radius:g} m must exceed cable_diameter "
            f"{d.cable_diameter:g} m"
        )
    problem = drum_hexagon_problem(d)  # the handle's motor pulley: refused here, not after carving
    if problem is not None:
        raise ValueError(problem)
    for k, a in enumerate(d.link_lengths):
        if 2 * d.hub_radius >= a:
            raise ValueError(
                f"hub_radius: {d.hub_radius * 1e3:g} mm hubs do not fit on link l{k} "
                f"({a * 1e3:g} mm long); hub_radius must be below half of every link length"
            )
    if d.beam_width / 2 > d.hub_radius:
        raise ValueError(
            f"beam_width: {d.beam_width * 1e3:g} mm is wider than the hubs "
            f"({2 * d.hub_radius * 1e3:g} mm)"
        )
