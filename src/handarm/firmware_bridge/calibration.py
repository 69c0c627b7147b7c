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

from handarm._io import write_text_atomic
from handarm.design import ArmDesign

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
                f"the design has {design.servo_model}"
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
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise FileNotFoundError(f"calibration file not found: {path}") from None
        except json.JSONDecodeError as exc:
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
                str(data["design_name"]),
                str(data["servo_model"]),
                int(data["model_number"]),
                tuple(int(v) for v in data["servo_ids"]),
                tuple(int(v) for v in data["offsets"]),
                str(data["recorded_at"]),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: calibration field missing or malformed: {exc}") from None
        if len(cal.offsets) != 6 or len(cal.servo_ids) != 6:
            raise ValueError(f"{path}: calibration needs 6 servo_ids and 6 offsets")
        if design is not None:
            cal.check_matches(design)
        return cal
