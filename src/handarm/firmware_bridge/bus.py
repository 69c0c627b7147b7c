"""The live servo bus through dynamixel_sdk, Protocol 1.0: apply, read, goto, calibrate.

Every operation first pings all six IDs and checks their model numbers; a missing servo, a
wrong model (311 is the MX(2.0) firmware) or a timeout aborts before anything is written.
Reads go servo by servo (the SDK's GroupBulkRead is broken under Protocol 1.0, see
the DynamixelSDK's Protocol 1.0 packet handler); goal positions go in one SYNC_WRITE.
"""

from __future__ import annotations

import numpy as np

from handarm.design import ArmDesign
from handarm.firmware_bridge.calibration import Calibration
from handarm.firmware_bridge.export import angle_limit_registers
from handarm.firmware_bridge.mx64 import (
    ADDR,
    MODEL_NUMBER_MX2,
    baud_register,
    from_unsigned16,
    to_unsigned16,
)
from handarm.kinematics import COLLISION_PAIRS, is_valid, link_crossings
from handarm.transmission import (
    joint_from_motor,
    motor_from_joint,
    motor_from_ticks,
    motor_ranges,
    ticks_from_motor,
)

__all__ = [
    "BusError",
    "ServoBus",
    "check_servos",
    "apply_settings",
    "read_joint_angles",
    "goto",
    "record_calibration",
    "goal_ticks",
]


class BusError(RuntimeError):
    """The bus or a servo did not do what was asked (message says which servo and why)."""


class ServoBus:
    """An open serial port with a Protocol 1.0 packet handler."""

    def __init__(self, port: str, baud: int):
        from dynamixel_sdk import PacketHandler, PortHandler

        self.port_name = port
        self.port = PortHandler(port)
        self.packet = PacketHandler(1.0)
        try:
            opened = self.port.openPort()
        except Exception as exc:  # pyserial raises SerialException or OSError
            raise BusError(f"port: cannot open {port}: {exc}") from None
        if not opened:
            raise BusError(f"port: cannot open {port}")
        if not self.port.setBaudRate(baud):
            self.port.closePort()
            raise BusError(f"baud: the SDK cannot set {baud} bit/s on {port}")

    def close(self) -> None:
        """Close the port."""
        self.port.closePort()

    def __enter__(self) -> ServoBus:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _check(self, sid: int, what: str, comm: int, error: int) -> None:
        from dynamixel_sdk import COMM_SUCCESS

        if comm != COMM_SUCCESS:
            raise BusError(f"servo {sid}: {what}: {self.packet.getTxRxResult(comm).strip()}")
        if error:
            raise BusError(f"servo {sid}: {what}: {self.packet.getRxPacketError(error).strip()}")

    def ping(self, sid: int) -> int:
        """Model number of servo ``sid``; BusError if it does not answer."""
        model, comm, error = self.packet.ping(self.port, sid)
        self._check(sid, "ping", comm, error)
        return int(model)

    def read(self, sid: int, name: str) -> int:
        """Unsigned value of a named register."""
        addr, size = ADDR[name]
        if size == 1:
            value, comm, error = self.packet.read1ByteTxRx(self.port, sid, addr)
        else:
            value, comm, error = self.packet.read2ByteTxRx(self.port, sid, addr)
        self._check(sid, f"read {name}", comm, error)
        return int(value)

    def write(self, sid: int, name: str, value: int) -> None:
        """Write a named register and check the status packet."""
        addr, size = ADDR[name]
        if size == 1:
            comm, error = self.packet.write1ByteTxRx(self.port, sid, addr, int(value))
        else:
            comm, error = self.packet.write2ByteTxRx(self.port, sid, addr, int(value))
        self._check(sid, f"write {name}={value}", comm, error)

    def sync_write_goals(self, ids, ticks) -> None:
        """One SYNC_WRITE of Goal Position (two's complement for multi-turn)."""
        from dynamixel_sdk import COMM_SUCCESS, GroupSyncWrite

        addr, size = ADDR["goal_position"]
        group = GroupSyncWrite(self.port, self.packet, addr, size)
        for sid, t in zip(ids, ticks, strict=True):
            raw = to_unsigned16(int(t))
            group.addParam(int(sid), [raw & 0xFF, raw >> 8])
        comm = group.txPacket()
        if comm != COMM_SUCCESS:
            raise BusError(f"sync write: {self.packet.getTxRxResult(comm).strip()}")


def check_servos(bus: ServoBus, design: ArmDesign) -> list[int]:
    """Ping every servo of the design and check its model; BusError listing every problem."""
    expected = design.servo.model_number
    problems, models = [], []
    for joint, sid in enumerate(design.servo_ids, start=1):
        try:
            model = bus.ping(sid)
        except BusError as exc:
            problems.append(f"joint {joint}: {exc}")
            continue
        models.append(model)
        if model == MODEL_NUMBER_MX2:
            problems.append(
                f"joint {joint}: servo {sid} reports model {model}, the MX(2.0) "
                f"firmware; handarm needs the Protocol 1.0 firmware ({expected})"
            )
        elif model != expected:
            problems.append(
                f"joint {joint}: servo {sid} reports model {model}, "
                f"expected {expected} ({design.servo_model})"
            )
    if problems:
        raise BusError("nothing was written: " + "; ".join(problems))
    return models


def _settings(design: ArmDesign, calibration: Calibration | None) -> dict[int, dict[str, int]]:
    offsets = None if calibration is None else calibration.offsets
    registers = angle_limit_registers(design, offsets)
    out = {}
    for m, sid in enumerate(design.servo_ids):
        _, cw, ccw = registers[m]
        out[sid] = {
            "torque_enable": 0,  # EEPROM writes need the torque off
            "return_delay_time": 0,
            "cw_angle_limit": cw,
            "ccw_angle_limit": ccw,
            "max_torque": design.servo.max_torque_register,
            "status_return_level": 2,
        }
    return out


def apply_settings(bus: ServoBus, design: ArmDesign, calibration=None) -> dict[int, dict]:
    """Check every servo, write the EEPROM settings, read them back; returns what was set."""
    if calibration is not None:
        calibration.check_matches(design)
    baud_register(design.baud_rate)
    check_servos(bus, design)
    settings = _settings(design, calibration)
    for sid, regs in settings.items():
        for name, value in regs.items():
            bus.write(sid, name, value)
    mismatches = []
    for sid, regs in settings.items():
        for name, value in regs.items():
            got = bus.read(sid, name)
            if got != value:
                mismatches.append(f"servo {sid} {name}: wrote {value}, reads {got}")
    if mismatches:
        raise BusError("verification failed: " + "; ".join(mismatches))
    return settings


def _present_ticks(bus: ServoBus, design: ArmDesign) -> np.ndarray:
    ranges = motor_ranges(design)
    ticks = []
    for m, sid in enumerate(design.servo_ids):
        raw = bus.read(sid, "present_position")
        ticks.append(from_unsigned16(raw) if ranges[m].mode == "multi-turn" else raw)
    return np.array(ticks, dtype=float)


def record_calibration(bus: ServoBus, design: ArmDesign) -> Calibration:
    """Read every motor at the zero pose (the arm held straight) into a Calibration."""
    check_servos(bus, design)
    return Calibration.record(design, _present_ticks(bus, design))


def read_joint_angles(bus: ServoBus, design: ArmDesign, calibration: Calibration) -> np.ndarray:
    """Joint angles (rad) from the present positions through K^-1 and the calibration."""
    calibration.check_matches(design)
    check_servos(bus, design)
    phi = motor_from_ticks(design, _present_ticks(bus, design), calibration.offsets)
    return joint_from_motor(design, phi)


def goal_ticks(design: ArmDesign, calibration: Calibration, q) -> np.ndarray:
    """Motor Goal Position ticks for joint angles q (rad); ValueError naming the problem.

    Refuses targets outside the joint limits, failing ``is_valid``, or outside what each
    servo's mode can reach.
    """
    q = np.asarray(q, dtype=float)
    if q.shape != (6,) or not np.all(np.isfinite(q)):
        raise ValueError(f"q: expected 6 finite joint angles, got {q!r}")
    for k in range(6):
        lo, hi = design.joint_limits[k]
        if not lo <= q[k] <= hi:
            raise ValueError(
                f"q{k + 1}: {np.degrees(q[k]):.2f} deg is outside joint {k + 1}'s limits "
                f"[{np.degrees(lo):.2f}, {np.degrees(hi):.2f}] deg; nothing was sent"
            )
    if not is_valid(design, q):
        pairs = [
            f"{a}-{b}"
            for (a, b), c in zip(COLLISION_PAIRS, link_crossings(design, q), strict=True)
            if c
        ]
        raise ValueError(f"q: links would cross ({', '.join(pairs)}); nothing was sent")
    ticks = ticks_from_motor(design, motor_from_joint(design, q), calibration.offsets)
    registers = angle_limit_registers(design, calibration.offsets)
    for m, (mode, cw, ccw) in enumerate(registers):
        limit = design.servo.multi_turn_limit
        lo, hi = (-limit, limit) if mode == "multi-turn" else (cw, ccw)
        if not lo <= ticks[m] <= hi:
            raise ValueError(
                f"q: motor {m + 1} would need {ticks[m]} ticks, outside its "
                f"{mode} range {lo}..{hi}; nothing was sent"
            )
    return ticks


def goto(bus: ServoBus, design: ArmDesign, calibration: Calibration, q) -> np.ndarray:
    """Send joint targets q (rad) in one SYNC_WRITE; returns the ticks sent."""
    calibration.check_matches(design)
    ticks = goal_ticks(design, calibration, q)  # refuses before touching the bus
    check_servos(bus, design)
    bus.sync_write_goals(design.servo_ids, ticks)
    return ticks
