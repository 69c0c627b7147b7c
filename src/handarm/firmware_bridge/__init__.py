"""Servo-controller export, calibration and the Dynamixel Protocol 1.0 bus for MX-64T servos.

Modules (loaded on first use): ``export`` (controller.json, arm_config.h),
``calibration``, ``bus`` (the live bus through dynamixel_sdk: checks, apply, goto, stop),
``motion`` (collision-free paths with OMPL, timing with ruckig), ``follow`` (the handheld
follow loop), ``emulator`` (a software bus on a pseudo-terminal), ``mx64`` (the control
table), ``sizing`` (payload and pulleys).
"""

from __future__ import annotations

from handarm._lazy import lazy_attributes

_MODULES = frozenset(
    {"bus", "calibration", "emulator", "export", "follow", "motion", "mx64", "sizing"}
)
_NAMES = {
    "Calibration": "calibration",
    "controller_config": "export",
    "ServoBus": "bus",
    "BusError": "bus",
    "ArmStateError": "bus",
    "PlanningError": "motion",
    "goto": "bus",
    "plan_move": "bus",
    "check_state": "bus",
    "follow": "follow",
    "EmulatedBus": "emulator",
    "max_payload": "sizing",
    "size_pulleys": "sizing",
}

__all__ = sorted(_NAMES)


__getattr__, __dir__ = lazy_attributes(__name__, _MODULES, _NAMES)
