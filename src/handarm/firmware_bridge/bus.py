"""The live servo bus through dynamixel_sdk, Protocol 1.0: apply, read, move, stop, scan.

Every operation first pings all six IDs and checks their model numbers; a missing servo, a
wrong model (311 is the MX(2.0) firmware), two servos on one ID or a timeout aborts before
anything is written. Before any move the bridge reads back every servo's registers and its
present pose and refuses (``ArmStateError``) unless both are what ``apply`` and
``calibrate`` left: the servos lose their multi-turn count at power-up, and ``calibrate``
lights each servo's LED, a RAM register that power-up clears, so a power cycle is named.
Reads go servo by servo (the SDK's GroupBulkRead is broken under Protocol 1.0); goal
positions and speeds go in one SYNC_WRITE per period.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from handarm.collision import LINK_PAIRS
from handarm.design import ArmDesign
from handarm.firmware_bridge.calibration import Calibration
from handarm.firmware_bridge.export import angle_limit_registers, controller_config
from handarm.firmware_bridge.motion import (
    MotionLimits,
    PlanningError,
    plan_path,
    serial_checks,
    time_path,
)
from handarm.firmware_bridge.mx64 import (
    ADDR,
    BAUD_VALUES,
    ERROR_BITS,
    MODEL_NUMBER_MX2,
    MONITOR_ADDR,
    MONITOR_SIZE,
    STOP_BITS,
    baud_register,
    from_unsigned16,
    to_unsigned16,
)
from handarm.kinematics import colliding_pairs, is_valid
from handarm.transmission import (
    joint_from_motor,
    motor_from_joint,
    motor_from_ticks,
    motor_ranges,
    ticks_from_motor,
)

__all__ = [
    "BusError",
    "ArmStateError",
    "PlanningError",
    "ServoBus",
    "check_servos",
    "expected_registers",
    "apply_settings",
    "check_state",
    "read_joint_angles",
    "pose_slack",
    "present_pose",
    "goal_ticks",
    "plan_move",
    "stream",
    "send_sample",
    "check_health",
    "ServoFault",
    "goto",
    "hold",
    "set_torque",
    "scan",
    "setup_servo",
    "record_calibration",
]

#: RAM register ``calibrate`` sets and power-up clears (value 1 = calibrated this power-on).
MARKER = "led"
#: Registers ``apply`` writes, in order (torque off first: EEPROM writes need it off).
APPLIED = (
    "torque_enable",
    "status_return_level",
    "return_delay_time",
    "cw_angle_limit",
    "ccw_angle_limit",
    "multi_turn_offset",
    "resolution_divider",
    "max_torque",
    "torque_limit",
)
#: Registers checked before every move.
CHECKED = APPLIED[1:]


class BusError(RuntimeError):
    """The bus or a servo did not answer as asked (message says which servo and why)."""

    exit_status = 5


class DuplicateIdError(BusError):
    """Two servos answered to one ID."""


class ArmStateError(RuntimeError):
    """The arm or its servos are not in a state the bridge can move from; nothing was sent."""

    exit_status = 4


#: ms: the longest status timeout taken (the SDK's default is about 34 ms); longer, a silent
#: servo would hang every command (``inf`` never returned)
MAX_TIMEOUT_MS = 10_000.0


class ServoBus:
    """An open serial port with a Protocol 1.0 packet handler.

    Parameters
    ----------
    port : str
        Serial device, e.g. ``/dev/ttyUSB0`` (or an emulator's pty).
    baud : int
        Bit rate (bit/s).
    timeout : float, optional
        Milliseconds to wait for a status packet (default: the SDK's, about 34 ms; a
        loaded machine running the emulator needs more).

    Raises
    ------
    BusError
        If the port cannot be opened or set to ``baud``.
    """

    def __init__(self, port: str, baud: int, timeout: float | None = None):
        from dynamixel_sdk import PacketHandler, PortHandler

        if isinstance(baud, bool) or baud not in BAUD_VALUES:
            raise ValueError(
                f"baud: {baud} is not a rate the MX-64 and the SDK share; choose one of "
                f"{sorted(BAUD_VALUES)}"
            )
        self.port_name = port
        self.baud = int(baud)
        self.port = PortHandler(port)
        if timeout is not None:
            if not 0 < timeout <= MAX_TIMEOUT_MS:
                raise ValueError(
                    f"timeout: expected 0 < ms <= {MAX_TIMEOUT_MS:g} (a silent servo would "
                    f"hold every read that long), got {timeout}"
                )
            self.port.setPacketTimeout = lambda _n: self.port.setPacketTimeoutMillis(timeout)
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
        try:
            self.port.closePort()
        except Exception:  # noqa: BLE001 - a lost port cannot be closed twice
            pass

    def __enter__(self) -> ServoBus:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _io(self, what: str, call, *args):
        try:
            return call(*args)
        except (OSError, ValueError, TypeError, AttributeError, IndexError) as exc:
            # pyserial's SerialException is an OSError; a closed port raises the others
            self.port.is_using = False
            raise BusError(f"port: {self.port_name} lost during {what}: {exc}") from None

    def _check(self, sid: int, what: str, comm: int, error: int) -> None:
        from dynamixel_sdk import COMM_SUCCESS

        if comm != COMM_SUCCESS:
            raise BusError(f"servo {sid}: {what}: {self.packet.getTxRxResult(comm).strip()}")
        if error & ~STOP_BITS:
            raise BusError(f"servo {sid}: {what}: {error_text(error)}")

    def ping(self, sid: int) -> int | None:
        """Model number of servo ``sid``; BusError if it does not answer.

        None when the servo answers PING but not READ (Status Return Level 0).
        """
        packet = [0xFF, 0xFF, sid, 2, 0x01, 0]  # PING
        _, comm, error = self._io("ping", self.packet.txRxPacket, self.port, packet)
        self._check(sid, "ping", comm, error & ~STOP_BITS)
        if self.echoes():
            raise DuplicateIdError(f"servo {sid}: two servos answer as ID {sid} (duplicate ID)")
        value, comm, error = self._io("ping", self.packet.read2ByteTxRx, self.port, sid, 0)
        from dynamixel_sdk import COMM_SUCCESS

        return int(value) if comm == COMM_SUCCESS else None

    def echoes(self, wait: float = 0.004) -> bool:
        """Whether more bytes arrived after the last status packet (two servos, one ID)."""
        time.sleep(wait)
        return self._io("read", self.port.getBytesAvailable) > 0

    def read(self, sid: int, name: str) -> int:
        """Unsigned value of a named register."""
        addr, size = ADDR[name]
        call = self.packet.read1ByteTxRx if size == 1 else self.packet.read2ByteTxRx
        value, comm, error = self._io(f"read {name}", call, self.port, sid, addr)
        self._check(sid, f"read {name}", comm, error)
        return int(value)

    def read_block(self, sid: int, addr: int, size: int) -> tuple[bytes, int]:
        """(data, error bits) of a READ of ``size`` bytes from ``addr``."""
        data, comm, error = self._io("read", self.packet.readTxRx, self.port, sid, addr, size)
        self._check(sid, f"read {size} bytes at {addr}", comm, error & ~STOP_BITS)
        return bytes(data), int(error)

    def write(self, sid: int, name: str, value: int, *, status: bool | None = True) -> None:
        """Write a named register.

        ``status`` True: wait for and check the status packet; False: send only (the servo
        does not answer writes); None: the servo may or may not answer (writing its Status
        Return Level: whether the reply follows the old or the new level is firmware's
        choice), so wait for the reply window and accept silence, leaving no stray packet to
        be taken for the answer of the next instruction.
        """
        addr, size = ADDR[name]
        value = int(value)
        if status is None:
            from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS

            call = self.packet.write1ByteTxRx if size == 1 else self.packet.write2ByteTxRx
            comm, error = self._io(f"write {name}", call, self.port, sid, addr, value)
            if comm == COMM_RX_TIMEOUT:
                comm, error = COMM_SUCCESS, 0
        elif status:
            call = self.packet.write1ByteTxRx if size == 1 else self.packet.write2ByteTxRx
            comm, error = self._io(f"write {name}", call, self.port, sid, addr, value)
        else:
            call = self.packet.write1ByteTxOnly if size == 1 else self.packet.write2ByteTxOnly
            comm, error = self._io(f"write {name}", call, self.port, sid, addr, value), 0
        self._check(sid, f"write {name}={value}", comm, error)

    def sync_write(self, name: str, ids, values, size: int | None = None) -> None:
        """One SYNC_WRITE of ``size`` bytes from register ``name`` (several 2-byte values each)."""
        from dynamixel_sdk import COMM_SUCCESS, GroupSyncWrite

        addr, reg_size = ADDR[name]
        size = reg_size if size is None else size
        group = GroupSyncWrite(self.port, self.packet, addr, size)
        for sid, vals in zip(ids, values, strict=True):
            data = []
            for v in np.atleast_1d(vals):
                raw = to_unsigned16(int(v))
                data += [raw & 0xFF, raw >> 8]
            group.addParam(int(sid), data)
        comm = self._io("sync write", group.txPacket)
        if comm != COMM_SUCCESS:
            raise BusError(f"sync write: {self.packet.getTxRxResult(comm).strip()}")

    def sync_write_goals(self, ids, ticks) -> None:
        """One SYNC_WRITE of Goal Position (two's complement for multi-turn)."""
        self.sync_write("goal_position", ids, ticks)


def error_text(error: int) -> str:
    """The names of the error bits set in a status packet."""
    names = [name for bit, name in ERROR_BITS.items() if error & bit]
    return "error " + ", ".join(names) if names else "no error"


def check_servos(bus: ServoBus, design: ArmDesign) -> list[int]:
    """Ping every servo of the design, check its model and that no other servo shares its ID.

    A servo at Status Return Level 0 answers PING only; its model is checked once
    ``apply`` has raised the level (and ``check_state`` refuses it until then).

    Raises
    ------
    BusError
        Listing every problem; when no servo answers, suggesting ``bridge scan``.
    """
    expected = design.servo.model_number
    problems, models = [], []
    for joint, sid in enumerate(design.servo_ids, start=1):
        try:
            model = bus.ping(sid)
        except BusError as exc:
            problems.append(f"joint {joint}: {exc}")
            continue
        models.append(model)
        if model is None:
            pass  # Status Return Level 0: answers PING only; apply raises it
        elif model == MODEL_NUMBER_MX2:
            problems.append(
                f"joint {joint}: servo {sid} reports model {model}, the MX(2.0) "
                f"firmware; handarm needs the Protocol 1.0 firmware ({expected})"
            )
        elif model != expected:
            problems.append(
                f"joint {joint}: servo {sid} reports model {model}, "
                f"expected {expected} ({design.servo_model})"
            )
    if not models:
        raise BusError(
            f"nothing was written: no servo answers at {bus.baud} bit/s on {bus.port_name}; "
            "check power and wiring, or find the servos' IDs and baud with 'handarm bridge scan'"
        )
    if problems:
        raise BusError("nothing was written: " + "; ".join(problems))
    return models


def expected_registers(
    design: ArmDesign, calibration: Calibration | None = None, max_torque_fraction: float = 1.0
) -> dict[int, dict[str, int]]:
    """What ``apply`` writes to each servo, by ID: the values of ``APPLIED``.

    Angle limits and Max Torque come from the controller configuration (``export``), so
    the servos and the exported files cannot disagree; Torque Limit equals Max Torque (the
    value the servo itself copies at power-up), Multi Turn Offset 0, Resolution Divider 1.
    """
    config = controller_config(design, calibration, max_torque_fraction=max_torque_fraction)
    out = {}
    for s in config["servos"]:
        out[s["id"]] = {
            "torque_enable": 0,
            "status_return_level": 2,
            "return_delay_time": 0,
            "cw_angle_limit": s["cw_angle_limit"],
            "ccw_angle_limit": s["ccw_angle_limit"],
            "multi_turn_offset": 0,
            "resolution_divider": 1,
            "max_torque": s["max_torque"],
            "torque_limit": s["max_torque"],
        }
    return out


def _status_level(bus: ServoBus, sid: int) -> int:
    try:
        return bus.read(sid, "status_return_level")
    except BusError:
        return 0  # answers PING only


def apply_settings(
    bus: ServoBus, design: ArmDesign, calibration=None, max_torque_fraction: float = 1.0
) -> dict[int, dict]:
    """Check every servo, write the settings of ``expected_registers``, read them back.

    Handles every Status Return Level: a servo that answers only PING (0) or also READ (1)
    gets its Status Return Level written first without waiting for a status packet, then
    read back. Torque ends off (``set_torque`` turns it on).

    Returns
    -------
    dict
        ``{id: {register: value}}`` as written and verified.

    Raises
    ------
    BusError
        Before writing, if a servo is missing or wrong (nothing written); after writing has
        begun, naming every register already written.
    """
    if calibration is not None:
        calibration.check_matches(design)
    baud_register(design.baud_rate)
    settings = expected_registers(design, calibration, max_torque_fraction)
    check_servos(bus, design)
    levels = {sid: _status_level(bus, sid) for sid in settings}
    written: list[str] = []
    try:
        for sid, regs in settings.items():
            for name in APPLIED:
                confirmed = levels[sid] >= 2
                if name == "status_return_level" and not confirmed:
                    confirmed = None  # the answer may follow the old level or the new one
                bus.write(sid, name, regs[name], status=confirmed)
                written.append(f"servo {sid} {name}={regs[name]}")
                if name == "status_return_level":
                    levels[sid] = 2
                    if bus.read(sid, name) != 2:
                        raise BusError(f"servo {sid}: status_return_level did not take 2")
                    model = bus.read(sid, "model_number")
                    if model != design.servo.model_number:
                        raise BusError(f"servo {sid}: reports model {model} once it answers")
    except BusError as exc:
        raise BusError(
            f"{exc}; written before the failure: {', '.join(written) or 'nothing'}"
        ) from None
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
    """Read every motor at the zero pose (the arm held straight) into a Calibration.

    Also sets each servo's power-on marker (its LED, a RAM register power-up clears), so a
    later power cycle is detected.
    """
    check_servos(bus, design)
    cal = Calibration.record(design, _present_ticks(bus, design))
    for sid in design.servo_ids:
        bus.write(sid, MARKER, 1, status=_status_level(bus, sid) >= 2)
    return cal


def read_joint_angles(bus: ServoBus, design: ArmDesign, calibration: Calibration) -> np.ndarray:
    """Joint angles (rad) from the present positions through K^-1 and the calibration."""
    calibration.check_matches(design)
    check_servos(bus, design)
    phi = motor_from_ticks(design, _present_ticks(bus, design), calibration.offsets)
    return joint_from_motor(design, phi)


#: Times ``goto`` plans again when the arm moved while its path was planned.
REPLANS = 2

#: Ticks a servo may rest away from its goal: the goal's rounding to whole ticks (half a
#: tick) and the servo's own dead band. A present pose read that far past a joint limit is
#: at the limit (a goal at +150 deg read back as +150.03 deg), not a wrong calibration.
POSE_SLACK_TICKS = 2


def pose_slack(design: ArmDesign) -> np.ndarray:
    """Per joint (rad): how far ``POSE_SLACK_TICKS`` on every motor can move it, (6,)."""
    per_motor = np.abs(joint_from_motor(design, np.eye(6)))  # row m: motor m's unit turn
    return POSE_SLACK_TICKS / design.servo.ticks_per_radian * per_motor.sum(axis=0)


def _pose_problem(design: ArmDesign, q: np.ndarray) -> str | None:
    for k in range(6):
        lo, hi = design.joint_limits[k]
        if not lo - 1e-9 <= q[k] <= hi + 1e-9:
            return (
                f"joint {k + 1} at {np.degrees(q[k]):.2f} deg is outside its limits "
                f"[{np.degrees(lo):.2f}, {np.degrees(hi):.2f}] deg"
            )
    if not is_valid(design, q):
        pairs = [
            f"l{a}-l{b}"
            for (a, b), c in zip(LINK_PAIRS, colliding_pairs(design, q), strict=True)
            if c
        ]
        return "links " + ", ".join(pairs) + " would touch"
    return None


def present_pose(bus: ServoBus, design: ArmDesign, calibration: Calibration) -> np.ndarray:
    """The present joint angles (rad), refused unless the pose is within limits and valid.

    A pose read within ``pose_slack`` of a joint limit (a goal at the limit, rounded to
    whole ticks, reads back a few hundredths of a degree past it) is taken at the limit.

    Raises
    ------
    ArmStateError
        If the servos were power-cycled since ``calibrate`` (their marker is cleared), or
        the present pose maps outside the joint limits or to touching links.
    """
    cycled = [sid for sid in design.servo_ids if bus.read(sid, MARKER) != 1]
    if cycled:
        raise ArmStateError(
            f"present pose unknown: servo(s) {', '.join(map(str, cycled))} were powered off "
            "since the calibration and lost their turn count; hold the arm straight and run "
            "'handarm bridge calibrate'. Nothing was sent"
        )
    q = read_joint_angles(bus, design, calibration)
    slack = pose_slack(design)
    if np.all((q >= design.lower - slack) & (q <= design.upper + slack)):
        # within a few ticks of a limit (a goal there, rounded to ticks): at the limit
        q = np.clip(q, design.lower, design.upper)
    problem = _pose_problem(design, q)
    if problem is not None:
        raise ArmStateError(
            f"present pose: {problem}; the calibration does not match the arm, recalibrate "
            "with the arm held straight ('handarm bridge calibrate'). Nothing was sent"
        )
    return q


def check_state(
    bus: ServoBus,
    design: ArmDesign,
    calibration: Calibration,
    max_torque_fraction: float = 1.0,
) -> np.ndarray:
    """Before a move: servos present, registers as ``apply`` leaves them, pose known.

    Reads back every register of ``CHECKED`` from every servo and compares it with
    ``expected_registers`` for this design and calibration.

    Returns
    -------
    ndarray, shape (6,)
        The present joint angles (rad).

    Raises
    ------
    ArmStateError
        Naming every servo register that differs, or the reason the pose is unknown.
    BusError
        If a servo is missing or does not answer.
    """
    calibration.check_matches(design)
    check_servos(bus, design)
    expected = expected_registers(design, calibration, max_torque_fraction)
    diffs = []
    for sid, regs in expected.items():
        if _status_level(bus, sid) != 2:
            diffs.append(f"servo {sid} status_return_level: not 2")
            continue
        for name in CHECKED:
            got = bus.read(sid, name)
            if got != regs[name]:
                diffs.append(f"servo {sid} {name}: reads {got}, apply writes {regs[name]}")
    if diffs:
        raise ArmStateError(
            "servo settings differ from this design and calibration ("
            + "; ".join(diffs)
            + "); run 'handarm bridge apply' with the same calibration. Nothing was sent"
        )
    return present_pose(bus, design, calibration)


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
    problem = _pose_problem(design, q)
    if problem is not None:
        raise ValueError(f"q: {problem}; nothing was sent")
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


def plan_move(
    design: ArmDesign,
    calibration: Calibration,
    start,
    goal,
    *,
    rate: float = 50.0,
    limits: MotionLimits | None = None,
    timeout: float = 5.0,
    seed: int | None = 0,
    scene=None,
    clearance: float = 0.0,
) -> np.ndarray:
    """Timed joint samples from ``start`` to ``goal`` at ``rate`` Hz, shape (n, 6) rad.

    Plans a collision-free path (``motion.plan_path``; with a ``scene`` it keeps
    ``clearance`` from the obstacles too), times it (``motion.time_path``) and checks every
    sample's Goal Position ticks (``goal_ticks``).

    Raises
    ------
    ValueError
        If the goal is outside the limits, invalid, or out of a servo's range.
    PlanningError
        If no valid path was found.
    """
    goal_ticks(design, calibration, goal)
    limits = MotionLimits(design) if limits is None else limits
    path = plan_path(
        design, start, goal, timeout=timeout, seed=seed, scene=scene, clearance=clearance
    )
    samples = time_path(design, path, limits, rate)
    for q in samples:
        goal_ticks(design, calibration, q)
    return samples


def _speed_registers(design: ArmDesign, dphi: np.ndarray, dt: float) -> np.ndarray:
    """Moving Speed values that cover ``dphi`` (rad of motor) in ``dt``: 1..max, never 0."""
    servo = design.servo
    rpm = np.abs(dphi) / dt * 60.0 / (2.0 * np.pi)
    reg = np.ceil(rpm / servo.speed_unit_rpm) + 1
    return np.clip(reg, 1, servo.max_speed_register).astype(int)


class ServoFault(ArmStateError):
    """A servo reported overload, overheating or an over-limit reading during a move."""


def monitor(bus: ServoBus, design: ArmDesign, sid: int) -> dict:
    """Load (fraction of full scale, signed), voltage (V), temperature (C), error bits."""
    data, error = bus.read_block(sid, MONITOR_ADDR, MONITOR_SIZE)
    raw = data[0] | data[1] << 8
    load = (raw & 0x3FF) / design.servo.max_torque_register * (-1 if raw & 0x400 else 1)
    return {"load": load, "voltage": data[2] / 10.0, "temperature": data[3], "error": error}


def _check_health(design: ArmDesign, sid: int, state: dict, torque_limit: int) -> None:
    servo = design.servo
    reasons = []
    if state["error"] & STOP_BITS:
        reasons.append(error_text(state["error"] & STOP_BITS))
    if state["temperature"] >= servo.temperature_limit:
        reasons.append(f"temperature {state['temperature']} C")
    if abs(state["load"]) * servo.max_torque_register >= 0.95 * max(torque_limit, 1):
        reasons.append(f"load {abs(state['load']) * 100:.0f} %")
    if reasons:
        raise ServoFault(
            f"servo {sid} stopped the move: {', '.join(reasons)}; the arm holds its pose"
        )


def hold(bus: ServoBus, design: ArmDesign) -> np.ndarray:
    """Stop: set every Goal Position to the Present Position; returns the ticks held."""
    ranges = motor_ranges(design)
    ticks = []
    for m, sid in enumerate(design.servo_ids):
        raw = bus.read(sid, "present_position")
        ticks.append(from_unsigned16(raw) if ranges[m].mode == "multi-turn" else raw)
    bus.sync_write_goals(design.servo_ids, ticks)
    return np.array(ticks)


def set_torque(bus: ServoBus, design: ArmDesign, on: bool) -> None:
    """Torque on (holding the present position first) or off, on all six servos."""
    check_servos(bus, design)
    if on:
        hold(bus, design)
    for sid in design.servo_ids:
        bus.write(sid, "torque_enable", 1 if on else 0)


def send_sample(
    bus: ServoBus, design: ArmDesign, calibration: Calibration, q, prev_q, dt: float
) -> None:
    """One SYNC_WRITE of Goal Position and Moving Speed for joint angles ``q`` (rad).

    Moving Speed is set so that each servo covers its step from ``prev_q`` in ``dt`` (never
    0, which the servo reads as "no speed control"). ``goal_ticks`` checks ``q`` first.
    """
    ticks = goal_ticks(design, calibration, q)
    dphi = motor_from_joint(design, q) - motor_from_joint(design, prev_q)
    speed = _speed_registers(design, dphi, dt)
    values = list(zip(ticks, speed, strict=True))
    bus.sync_write("goal_position", design.servo_ids, values, size=4)


def check_health(bus: ServoBus, design: ArmDesign, i: int, torque_limit: int) -> dict:
    """Read servo ``i mod 6``'s load, voltage, temperature and error bits; ServoFault if bad."""
    sid = design.servo_ids[i % 6]
    state = monitor(bus, design, sid)
    _check_health(design, sid, state, torque_limit)
    return state


def stream(
    bus: ServoBus,
    design: ArmDesign,
    calibration: Calibration,
    samples,
    rate: float,
    *,
    torque_limit: int | None = None,
) -> int:
    """Send joint samples as Goal Position and Moving Speed at ``rate`` Hz.

    Each period sends one SYNC_WRITE (``send_sample``) and reads one servo's load,
    voltage, temperature and error bits, in turn (``check_health``). A fault or Ctrl-C
    stops the arm where it is (``hold``) and re-raises.

    Returns
    -------
    int
        Number of samples sent.
    """
    samples = np.asarray(samples, float)
    dt = 1.0 / rate
    limit = design.servo.max_torque_register if torque_limit is None else torque_limit
    sent = 0
    t0 = time.perf_counter()
    try:
        for i, q in enumerate(samples):
            send_sample(bus, design, calibration, q, samples[max(i - 1, 0)], dt)
            sent += 1
            check_health(bus, design, i, limit)
            delay = t0 + (i + 1) * dt - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
    except (KeyboardInterrupt, ServoFault):
        hold(bus, design)
        raise
    return sent


def _serial(fn):
    """Run ``fn`` with the collision kernels on one thread (see ``serial_checks``)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with serial_checks():
            return fn(*args, **kwargs)

    return wrapper


stream = _serial(stream)


def goto(
    bus: ServoBus,
    design: ArmDesign,
    calibration: Calibration,
    q,
    *,
    rate: float = 50.0,
    limits: MotionLimits | None = None,
    max_torque_fraction: float = 1.0,
    timeout: float = 5.0,
    seed: int | None = 0,
    scene=None,
    clearance: float = 0.0,
) -> np.ndarray:
    """Move to joint angles ``q`` (rad) along a collision-free timed path.

    With a ``scene`` (obstacles in the handle frame) the path keeps ``clearance`` (m) from
    them; a goal or present pose that does not is refused naming the obstacles.

    Checks the servos (``check_state``: registers and present pose), plans and times the
    path (``plan_move``), reads the pose again (the arm is limp while it plans: a pose moved
    by more than ``pose_slack`` is planned from again, up to ``REPLANS`` times), turns
    torque on holding the present pose, then streams the samples (``stream``). Nothing is
    written before every check has passed.

    Returns
    -------
    ndarray, shape (n, 6)
        The joint samples sent (rad); the last is ``q``.
    """
    calibration.check_matches(design)
    goal_ticks(design, calibration, q)  # refuses before touching the bus
    start = check_state(bus, design, calibration, max_torque_fraction)
    for _ in range(REPLANS + 1):
        samples = plan_move(
            design,
            calibration,
            start,
            q,
            rate=rate,
            limits=limits,
            timeout=timeout,
            seed=seed,
            scene=scene,
            clearance=clearance,
        )
        # the arm is limp while the path is planned (up to ``timeout`` s): torque on would
        # hold it where it is now, and the first sample would jump back to ``start``
        now = present_pose(bus, design, calibration)
        if np.all(np.abs(now - start) <= pose_slack(design)):
            break
        start = now
    else:
        raise ArmStateError(
            f"present pose: the arm moved while each of {REPLANS + 1} paths was planned; "
            "hold it still (torque is off until the move starts). Nothing was sent"
        )
    set_torque(bus, design, True)
    limit = expected_registers(design, calibration, max_torque_fraction)
    stream(
        bus,
        design,
        calibration,
        samples,
        rate,
        torque_limit=limit[design.servo_ids[0]]["torque_limit"],
    )
    return samples


def scan(port: str, bauds=None, ids=range(254), timeout: float | None = None) -> list[dict]:
    """Every servo that answers on ``port``: ID, baud, model number and firmware version.

    Parameters
    ----------
    port : str
    bauds : iterable of int, optional
        Rates to try (default every rate the MX-64 and the SDK share).
    ids : iterable of int
        IDs to ping at each rate (default 0..253; each silent ID costs about 35 ms).
    timeout : float, optional
        Status timeout (ms), as for ``ServoBus``.

    Returns
    -------
    list of dict
        ``{"id", "baud", "model_number", "firmware", "duplicate"}`` per answer.
    """
    found = []
    for baud in sorted(BAUD_VALUES if bauds is None else bauds):
        baud_register(baud)
        with ServoBus(port, baud, timeout) as bus:
            for sid in ids:
                duplicate = False
                try:
                    model = bus.ping(sid)
                except DuplicateIdError:
                    model, duplicate = None, True
                except BusError:
                    continue
                try:
                    firmware = None if duplicate else bus.read(sid, "firmware_version")
                except BusError:
                    firmware = None
                found.append(
                    {
                        "id": sid,
                        "baud": baud,
                        "model_number": model,
                        "firmware": firmware,
                        "duplicate": duplicate,
                    }
                )
    return found


def setup_servo(
    port: str,
    design: ArmDesign,
    joint: int,
    bauds=None,
    ids=range(254),
    timeout: float | None = None,
) -> dict:
    """Give the one servo on the bus the ID and baud of ``joint`` (1..6); read it back.

    Connect one servo at a time (a factory servo is ID 1 at 57,600 bit/s). The servo is
    found with ``scan`` (factory settings first); more than one answer is refused.

    Raises
    ------
    ValueError
        If ``joint`` is not 1..6.
    BusError
        If no servo or more than one answers, or the read-back differs.
    """
    if not 1 <= joint <= 6:
        raise ValueError(f"joint: expected 1..6, got {joint}")
    servo = design.servo
    target_id, target_baud = design.servo_ids[joint - 1], design.baud_rate
    target_reg = baud_register(target_baud)
    found = scan(port, [servo.factory_baud], [servo.factory_id], timeout)
    if not found:
        found = scan(port, bauds, ids, timeout)
    if len(found) != 1 or found[0]["duplicate"]:
        listed = ", ".join(f"ID {f['id']} at {f['baud']}" for f in found) or "none"
        raise BusError(
            f"setup: expected exactly one servo on the bus, found {len(found)} ({listed}); "
            "connect one servo at a time. Nothing was written"
        )
    f = found[0]
    if f["model_number"] != servo.model_number:
        raise BusError(
            f"setup: the servo reports model {f['model_number']}, expected "
            f"{servo.model_number}. Nothing was written"
        )
    with ServoBus(port, f["baud"], timeout) as bus:
        # the status packets of these writes come from the new ID / at the new rate:
        # send without waiting, then read everything back below
        if f["id"] != target_id:
            bus.write(f["id"], "id", target_id, status=False)
            time.sleep(0.05)
        if f["baud"] != target_baud:
            bus.write(target_id, "baud_rate", target_reg, status=False)
            time.sleep(0.05)
    with ServoBus(port, target_baud, timeout) as bus:
        model = bus.ping(target_id)
        got_id, got_baud = bus.read(target_id, "id"), bus.read(target_id, "baud_rate")
    if (model, got_id, got_baud) != (servo.model_number, target_id, target_reg):
        raise BusError(
            f"setup: read-back gives ID {got_id}, baud register {got_baud} (wanted "
            f"{target_id}, {target_reg})"
        )
    return {"id": target_id, "baud": target_baud, "was": {"id": f["id"], "baud": f["baud"]}}
