"""A software bus of MX-64T servos (Protocol 1.0 firmware) on a pseudo-terminal.

dynamixel_sdk opens the pty's path exactly as it would open /dev/ttyUSB0, so the bridge is
tested (and can be tried without hardware: ``handarm bridge emulate``) through the real SDK.
Each servo keeps a stateful control table; instruction packets are parsed with their
checksums; status packets carry error bits. Goal Position moves a servo at once.

Faults, for tests: a silent servo (no reply), a servo whose replies have a bad checksum, a
servo that reports another model number (311 is the MX(2.0) firmware), a late reply, two
servos answering to one ID, a servo that overheats or overloads after some goals, a power
cycle (``power_cycle``: RAM back to its defaults, multi-turn position back within one turn).
Each servo answers only at its own Baud Rate (the host's rate is read from the pty).
"""

from __future__ import annotations

import os
import select
import termios
import threading
import tty
from collections.abc import Iterable, Mapping

from handarm.firmware_bridge.mx64 import (
    ADDR,
    EEPROM_END,
    MODEL_NUMBER,
    MULTI_TURN_LIMIT,
    SERVO_BAUD_REGISTER,
    TICKS_PER_REV,
    from_unsigned16,
)
from handarm.servo import SERVOS

__all__ = ["EmulatedServo", "EmulatedBus"]

PING, READ, WRITE, REG_WRITE, ACTION, RESET, SYNC_WRITE, BULK_READ = (
    0x01,
    0x02,
    0x03,
    0x04,
    0x05,
    0x06,
    0x83,
    0x92,
)
BROADCAST = 0xFE
ERR_ANGLE, ERR_RANGE, ERR_CHECKSUM, ERR_INSTRUCTION = 0x02, 0x08, 0x10, 0x40
ERR_OVERHEAT, ERR_OVERLOAD = 0x04, 0x20
_SPEC = SERVOS["MX-64T"]  # factory defaults come from the one servo specification
# a servo may hold any rate of its table (set by another tool), the host only opens shared ones
_REGISTER_BAUD = {v: k for k, v in SERVO_BAUD_REGISTER.items()}
_TERMIOS_BAUD = {
    getattr(termios, f"B{b}"): b for b in SERVO_BAUD_REGISTER if hasattr(termios, f"B{b}")
}
_TABLE_SIZE = 74
_READ_ONLY = set(range(0, 3)) | set(range(36, 47)) | {50, 51}


def _checksum(body: Iterable[int]) -> int:
    return (~sum(body)) & 0xFF


class EmulatedServo:
    """One MX-64T: a control table with the Protocol 1.0 firmware's defaults."""

    def __init__(
        self, servo_id: int, model: int = MODEL_NUMBER, position: int = 2048, baud_register=1
    ):
        t = bytearray(_TABLE_SIZE)
        self.table = t
        self._put("model_number", model)
        defaults = {
            "firmware_version": 36,
            "id": servo_id,
            "baud_rate": baud_register,
            "return_delay_time": 250,
            "cw_angle_limit": 0,
            "ccw_angle_limit": 4095,
            "temperature_limit": _SPEC.temperature_limit,
            "min_voltage_limit": 60,
            "max_voltage_limit": 240,
            "max_torque": _SPEC.max_torque_register,
            "status_return_level": 2,
            "alarm_led": 36,
            "shutdown": 36,
            "resolution_divider": 1,
            "goal_position": position,
            "torque_limit": _SPEC.max_torque_register,
            "present_position": position,
            "present_voltage": 120,
            "present_temperature": 35,
        }
        for name, value in defaults.items():
            self._put(name, value)
        t[28] = 32  # P gain
        self.pending: tuple[int, bytes] | None = None
        self.real = position  # encoder ticks counted over turns (what the shaft is at)
        self.alarm = 0  # error bits reported in every status packet
        self.goals = 0  # Goal Position writes received
        self.fault_after: tuple[int, int] | None = None  # (goals, error bit)

    def power_cycle(self) -> None:
        """Power off and on: RAM to its defaults, the turn count lost, EEPROM kept."""
        fresh = EmulatedServo(self.id, self.get("model_number"))
        self.table[EEPROM_END:] = fresh.table[EEPROM_END:]
        self.real %= TICKS_PER_REV  # multi-turn position restarts within one turn
        self.alarm, self.pending = 0, None
        self._put("torque_limit", self.get("max_torque"))
        self._sync_present()
        self.table[30:32] = self.table[36:38]

    def _sync_present(self) -> None:
        if self.multi_turn:
            div = max(1, self.get("resolution_divider"))
            offset = from_unsigned16(self.get("multi_turn_offset"))
            self._put("present_position", self.real // div + offset)
        else:
            self._put("present_position", self.real % TICKS_PER_REV)

    @property
    def id(self) -> int:
        """The servo's ID (address 3)."""
        return self.table[3]

    def get(self, name: str) -> int:
        """Unsigned value of a named register."""
        addr, size = ADDR[name]
        return int.from_bytes(self.table[addr : addr + size], "little")

    def _put(self, name: str, value: int) -> None:
        addr, size = ADDR[name]
        self.table[addr : addr + size] = (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")

    @property
    def multi_turn(self) -> bool:
        """CW = CCW = 4095 selects multi-turn mode."""
        return self.get("cw_angle_limit") == 4095 and self.get("ccw_angle_limit") == 4095

    def read(self, addr: int, count: int) -> tuple[int, bytes]:
        """(error, data) of a READ."""
        if addr + count > _TABLE_SIZE:
            return ERR_RANGE, b""
        return 0, bytes(self.table[addr : addr + count])

    def write(self, addr: int, data: bytes) -> int:
        """Apply a WRITE; returns the error byte."""
        end = addr + len(data)
        if end > _TABLE_SIZE or any(a in _READ_ONLY for a in range(addr, end)):
            return ERR_RANGE
        goal_addr = ADDR["goal_position"][0]
        if addr <= goal_addr < end - 1:
            raw = int.from_bytes(data[goal_addr - addr : goal_addr - addr + 2], "little")
            if self.multi_turn:
                signed = raw - 0x10000 if raw > 0x7FFF else raw
                if abs(signed) > MULTI_TURN_LIMIT:
                    return ERR_ANGLE
            elif not self.get("cw_angle_limit") <= raw <= self.get("ccw_angle_limit"):
                return ERR_ANGLE
        self.table[addr:end] = data
        if addr <= goal_addr < end - 1:
            # the emulated servo reaches its goal at once
            goal = self.get("goal_position")
            if self.multi_turn:
                div = max(1, self.get("resolution_divider"))
                offset = from_unsigned16(self.get("multi_turn_offset"))
                self.real = (from_unsigned16(goal) - offset) * div
            else:
                self.real = goal
            self.goals += 1
            if self.fault_after is not None and self.goals >= self.fault_after[0]:
                self.alarm |= self.fault_after[1]
                if self.alarm & ERR_OVERHEAT:
                    self._put("present_temperature", self.get("temperature_limit") + 1)
                if self.alarm & ERR_OVERLOAD:
                    self._put("present_load", self.get("max_torque"))
                if self.alarm & self.get("shutdown"):
                    self._put("torque_limit", 0)
        if addr < 24 or addr <= goal_addr < end - 1:
            self._sync_present()
        return 0


class EmulatedBus:
    """Servos on one pseudo-terminal; use as a context manager, pass ``port`` to the SDK.

    Parameters
    ----------
    ids : iterable of int
        Servo IDs on the bus.
    models : mapping, optional
        Model number per ID (default 310).
    silent : iterable of int
        IDs that never answer.
    bad_checksum : iterable of int
        IDs whose status packets carry a wrong checksum.
    late : mapping, optional
        Seconds of delay before the given IDs answer.
    positions : mapping, optional
        Initial Present Position per ID (ticks).
    duplicates : iterable of int
        IDs two servos answer to (both reply, as two servos on one bus would).
    bauds : mapping, optional
        Bit rate per ID, any of the servo's table (``SERVO_BAUD_REGISTER``; default
        1,000,000, the design's); a servo answers only when the host's port runs at its
        rate, so one set to a rate the SDK cannot open (200,000) never answers.
    reply_level : {"new", "old"}
        Which Status Return Level decides whether a WRITE of that register is answered: the
        one it sets ("new", the default) or the one it replaces ("old"). The control table
        does not say; the host must work with either.
    """

    #: Status timeout (ms) a host should use with this bus. A servo answers within half a
    #: millisecond; this bus answers from a Python thread, which a busy machine can hold up
    #: for longer than the SDK's default timeout (about 34 ms at 1 Mbps).
    timeout_ms = 500.0

    def __init__(
        self,
        ids: Iterable[int] = (1, 2, 3, 4, 5, 6),
        *,
        models: Mapping[int, int] | None = None,
        silent: Iterable[int] = (),
        bad_checksum: Iterable[int] = (),
        late: Mapping[int, float] | None = None,
        positions: Mapping[int, int] | None = None,
        duplicates: Iterable[int] = (),
        bauds: Mapping[int, int] | None = None,
        reply_level: str = "new",
    ):
        if reply_level not in ("new", "old"):
            raise ValueError(f"reply_level: expected 'new' or 'old', got {reply_level!r}")
        self.reply_level = reply_level
        models = dict(models or {})
        positions = dict(positions or {})
        bauds = dict(bauds or {})
        self.servos = {
            i: EmulatedServo(
                i,
                models.get(i, MODEL_NUMBER),
                positions.get(i, 2048),
                SERVO_BAUD_REGISTER[bauds.get(i, 1_000_000)],
            )
            for i in ids
        }
        self.duplicates = set(duplicates)
        self.silent = set(silent)
        self.bad_checksum = set(bad_checksum)
        self.late = dict(late or {})
        self.log: list[tuple[int, int, bytes]] = []  # (id, instruction, params) received
        self._master = self._slave = -1
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.port = ""

    # -- lifecycle ---------------------------------------------------------------------------

    def start(self) -> EmulatedBus:
        """Open the pty and answer packets in a background thread."""
        self._master, self._slave = os.openpty()
        tty.setraw(self._master)
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._stop.clear()
        self._thread = threading.Thread(target=self._serve, name="mx64-emulator", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop answering and close the pty."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> EmulatedBus:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- packets -----------------------------------------------------------------------------

    def _serve(self) -> None:
        buf = bytearray()
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.02)
            if not ready:
                continue
            try:
                chunk = os.read(self._master, 4096)
            except OSError:
                return
            buf += chunk
            while True:
                start = buf.find(b"\xff\xff")
                if start < 0:
                    buf.clear()
                    break
                del buf[:start]
                if len(buf) < 4:
                    break
                total = 4 + buf[3]
                if len(buf) < total:
                    break
                packet = bytes(buf[:total])
                del buf[:total]
                self._handle(packet)

    def power_cycle(self) -> None:
        """Power every servo off and on (see ``EmulatedServo.power_cycle``)."""
        for servo in self.servos.values():
            servo.power_cycle()

    def host_baud(self) -> int | None:
        """The bit rate the host set on the port (0 if not a termios standard), None if closed."""
        if self._slave < 0:
            return None
        return _TERMIOS_BAUD.get(termios.tcgetattr(self._slave)[5], 0)

    def _hears(self, servo: EmulatedServo) -> bool:
        host = self.host_baud()
        return host is None or _REGISTER_BAUD.get(servo.get("baud_rate"), 0) == host

    def _reply(self, servo: EmulatedServo, error: int, params: bytes = b"") -> None:
        sid = servo.id
        if sid in self.silent:
            return
        error |= servo.alarm
        body = bytes([sid, len(params) + 2, error]) + params
        chk = _checksum(body)
        if sid in self.bad_checksum:
            chk ^= 0x5A
        packet = b"\xff\xff" + body + bytes([chk])
        if sid in self.late:
            # answer after the host has given up, without holding up the rest of the bus
            threading.Timer(self.late[sid], self._write, args=(packet,)).start()
        else:
            self._write(packet)
        if sid in self.duplicates:
            self._write(packet)  # a second servo with the same ID answers too

    def _write(self, packet: bytes) -> None:
        if self._master >= 0 and not self._stop.is_set():
            os.write(self._master, packet)

    def _handle(self, packet: bytes) -> None:
        sid, length, inst = packet[2], packet[3], packet[4]
        params = packet[5 : 3 + length]
        self.log.append((sid, inst, params))
        targets = (
            list(self.servos.values())
            if sid == BROADCAST
            else ([self.servos[sid]] if sid in self.servos else [])
        )
        targets = [servo for servo in targets if self._hears(servo)]
        if _checksum(packet[2:-1]) != packet[-1]:
            for servo in targets if sid != BROADCAST else []:
                self._reply(servo, ERR_CHECKSUM)
            return
        if inst == SYNC_WRITE:
            self._sync_write(params)
            return
        if inst == BULK_READ:
            self._bulk_read(params)
            return
        for servo in targets:
            before = servo.get("status_return_level")
            error, data = self._execute(servo, inst, params)
            level = servo.get("status_return_level") if self.reply_level == "new" else before
            answers = inst == PING or (inst == READ and level >= 1) or level >= 2
            if sid != BROADCAST and answers:
                self._reply(servo, error, data)

    def _execute(self, servo: EmulatedServo, inst: int, params: bytes) -> tuple[int, bytes]:
        if inst == PING:
            return 0, b""
        if inst == READ and len(params) == 2:
            return servo.read(params[0], params[1])
        if inst == WRITE and len(params) >= 2:
            old_id = servo.id
            error = servo.write(params[0], params[1:])
            if servo.id != old_id:
                self.servos[servo.id] = self.servos.pop(old_id)
            return error, b""
        if inst == REG_WRITE and len(params) >= 2:
            servo.pending = (params[0], params[1:])
            return 0, b""
        if inst == ACTION:
            if servo.pending is None:
                return ERR_INSTRUCTION, b""
            addr, data = servo.pending
            servo.pending = None
            return servo.write(addr, data), b""
        if inst == RESET:
            fresh = EmulatedServo(servo.id, servo.get("model_number"))
            servo.table[:] = fresh.table
            return 0, b""
        return ERR_INSTRUCTION, b""

    def _sync_write(self, params: bytes) -> None:
        addr, size = params[0], params[1]
        for k in range(2, len(params) - size, size + 1):
            sid = params[k]
            if sid in self.servos and self._hears(self.servos[sid]):
                self.servos[sid].write(addr, params[k + 1 : k + 1 + size])

    def _bulk_read(self, params: bytes) -> None:
        for k in range(1, len(params) - 2, 3):
            size, sid, addr = params[k], params[k + 1], params[k + 2]
            if sid in self.servos:
                error, data = self.servos[sid].read(addr, size)
                self._reply(self.servos[sid], error, data)
