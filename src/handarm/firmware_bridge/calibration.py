"""Calibration: each motor's encoder reading at the arm's known zero pose.

The coupling K is fixed, so joint angles follow from motor encoders and one offset per
motor (paper II-B). The offsets are recorded at power-on with the arm held straight, and
again after the cables are re-tensioned.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import os
from pathlib import Path

from handarm._io import read_regular_bytes, write_text_atomic
from handarm.design import ArmDesign
from handarm.firmware_bridge.mx64 import MULTI_TURN_LIMIT

__all__ = ["Calibration", "SCHEMA"]

SCHEMA = "handarm.calibration/1"


@dataclasses.dataclass(frozen=True)
class Calibration:
    """Zero-pose encoder readings (ticks) of the six motors of one arm."""

    design_name: str
    servo_model: str
    model_number: int
    servo_ids: tuple[int, ...]
    offsets: tuple[int, ...]
    recorded_at: str

    @classmethod
    def record(cls, design: ArmDesign, readings) -> Calibration:
        """A calibration from the six Present Position readings taken at the zero pose."""
        for i, r in enumerate(readings):
            if isinstance(r, bool) or int(r) != r:
                raise ValueError(f"readings[{i}]: expected an integer tick count, got {r!r}")
        readings = tuple(int(r) for r in readings)
        if len(readings) != 6:
            raise ValueError(f"readings: expected 6 values, got {len(readings)}")
        now = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
        return cls(
            design.name,
            design.servo_model,
            design.servo.model_number,
            design.servo_ids,
            readings,
            now,
        )

    def check_matches(self, design: ArmDesign) -> None:
        """Refuse a calibration made for other servos than the design's."""
        if tuple(self.servo_ids) != tuple(design.servo_ids):
            raise ValueError(
                f"calibration: servo_ids {list(self.servo_ids)} do not match the design's "
                f"{list(design.servo_ids)}"
            )
        if self.servo_model != design.servo_model or self.model_number != design.servo.model_number:
            raise ValueError(
                f"calibration: recorded for {self.servo_model} (model {self.model_number}), "
                f"the design has {design.servo_model} (model {design.servo.model_number})"
            )

    def to_dict(self) -> dict:
        """JSON-ready dict with the schema tag."""
        d = dataclasses.asdict(self)
        d["servo_ids"], d["offsets"] = list(self.servo_ids), list(self.offsets)
        return {"schema": SCHEMA, **d}

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the calibration atomically (temporary file, then rename)."""
        path = Path(path)
        write_text_atomic(path, json.dumps(self.to_dict(), indent=2) + "\n")
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str], design: ArmDesign | None = None) -> Calibration:
        """Read a calibration file; with ``design``, refuse one that does not match it."""
        path = Path(path)
        try:
            data = json.loads(read_regular_bytes(path), parse_constant=_no_constant)
        except FileNotFoundError:
            raise FileNotFoundError(f"calibration: no such file: {path}") from None
        except ValueError as exc:  # JSON syntax, encoding, NaN/Infinity, special file
            raise ValueError(f"{path}: not valid JSON: {exc}") from None
        if not isinstance(data, dict) or data.get("schema") != SCHEMA:
            raise ValueError(f"{path}: not a handarm calibration (schema {SCHEMA!r} expected)")
        for field in ("offsets", "servo_ids"):
            for i, v in enumerate(data.get(field) or []):
                if isinstance(v, bool) or not isinstance(v, int):
                    raise ValueError(
                        f"{path}: {field}[{i}]: expected an integer (encoder ticks are whole "
                        f"numbers), got {v!r}"
                    )
        try:
            cal = cls(
                _strict(data, "design_name", str),
                _strict(data, "servo_model", str),
                _strict(data, "model_number", int),
                _ints(data, "servo_ids", 0, 252),
                _ints(data, "offsets", -MULTI_TURN_LIMIT, MULTI_TURN_LIMIT),
                _strict(data, "recorded_at", str),
            )
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
        if design is not None:
            cal.check_matches(design)
        return cal


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number a calibration can hold")


def _strict(data: dict, key: str, kind: type):
    """``data[key]`` if it is exactly of ``kind`` (no bool for int, no coercion)."""
    if key not in data:
        raise ValueError(f"{key}: missing")
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, kind):
        raise ValueError(f"{key}: expected {kind.__name__}, got {type(value).__name__} {value!r}")
    return value


def _ints(data: dict, key: str, lo: int, hi: int) -> tuple[int, ...]:
    """Six integers within [lo, hi] (JSON numbers like 1.9, true or "1" are refused)."""
    values = _strict(data, key, list)
    if len(values) != 6:
        raise ValueError(f"{key}: expected 6 values, got {len(values)}")
    out = []
    for k, v in enumerate(values):
        v = _strict({f"{key}[{k}]": v}, f"{key}[{k}]", int)
        if not lo <= v <= hi:
            raise ValueError(f"{key}[{k}]: {v} is outside {lo}..{hi}")
        out.append(v)
    if key == "servo_ids" and len(set(out)) != 6:
        raise ValueError(f"servo_ids: IDs must be distinct, got {out}")
    return tuple(out)
