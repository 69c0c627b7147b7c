"""The handheld follow loop: the user holds the arm, the tool keeps a target.

Targets arrive as JSON lines, one object per line, either in the handle frame (the arm's
base frame, which the user holds)::

    {"p": [x, y, z], "e": [ex, ey, ez]}

or in the world frame together with the handle's pose (rotation R, 3x3 row-major, and
position t, metres), which the loop turns into the handle frame (p_h = R^T (p - t),
e_h = R^T e)::

    {"p": [...], "e": [...], "handle": {"R": [[...], [...], [...]], "t": [...]}}

Each period the loop solves the newest target with ``handarm.ik.solve(..., current=...)``
(whose degradation gives the closest reachable pose), moves the command towards its
``follow`` configuration no farther than the motor velocity limit allows in one period,
checks the step's straight line is valid (``motion.segment_valid``), and sends it as Goal
Position and Moving Speed. A step that would not be valid is not taken (the arm holds).
"""

from __future__ import annotations

import json
import queue
import socket
import sys
import threading
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from handarm._checks import real_array
from handarm.design import ArmDesign
from handarm.firmware_bridge.bus import (
    ServoBus,
    ServoFault,
    check_health,
    check_state,
    expected_registers,
    hold,
    send_sample,
    set_torque,
)
from handarm.firmware_bridge.calibration import Calibration
from handarm.firmware_bridge.motion import (
    MotionLimits,
    check_clear,
    check_rate,
    check_step,
    scene_margin,
    segment_valid,
    serial_checks,
)

__all__ = [
    "parse_target", "TargetSource", "open_source", "follow_step", "Follower", "FollowStep",
    "follow", "JUMP_SPEED", "JUMP_RAMP",
]  # fmt: skip

#: A swing (the IK's answer jumped to another family of configurations, ``family_ended``:
#: the one the arm was on ended, or the target lies beyond a small motion from the present
#: pose) starts at this fraction of the velocity limit ...
JUMP_SPEED = 0.25
#: ... and the speed comes back up to the full limit over this time (s), so that a swing
#: the person holding the arm did not ask for starts slowly and nothing jumps in speed.
JUMP_RAMP = 0.75
#: rad: a file or stdin source ends once the last target's step is no larger than this (far
#: below a servo's 1.5e-3 rad tick). An exact test never ended where the IK's answers, from
#: commands a rounding apart, alternated between two configurations 1.3e-14 rad apart.
SETTLED = 1e-9


def _vector(obj, key: str, where: str) -> np.ndarray:
    v = real_array(obj.get(key)) if key in obj else None
    if v is None:  # missing, or strings, booleans ("0.1", true): not converted
        raise ValueError(f"{where}: '{key}' missing or not numbers")
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{where}: '{key}' must be 3 finite numbers")
    return v


def _known_keys(obj: dict, known: tuple[str, ...], where: str) -> None:
    """Refuse a key not in ``known``: a misspelt 'handle' would change the target's frame."""
    unknown = sorted(set(obj) - set(known))
    if unknown:
        raise ValueError(
            f"{where}: unknown key {unknown[0]!r} (expected {', '.join(map(repr, known))})"
        )


def parse_target(line: str, where: str = "target") -> tuple[np.ndarray, np.ndarray]:
    """(p, e) in the handle frame from one JSON line; ValueError naming ``where``."""
    try:
        obj = json.loads(line)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{where}: not JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise ValueError(f"{where}: expected a JSON object")
    _known_keys(obj, ("p", "e", "handle"), where)
    p, e = _vector(obj, "p", where), _vector(obj, "e", where)
    if "handle" in obj:
        handle = obj["handle"]
        if not isinstance(handle, dict):
            raise ValueError(f"{where}: 'handle' must be an object with R and t")
        _known_keys(handle, ("R", "t"), f"{where}: handle")
        r = real_array(handle.get("R")) if "R" in handle else None
        if r is None:
            raise ValueError(f"{where}: 'handle.R' missing or not numbers")
        if (
            r.shape != (3, 3)
            or not np.all(np.isfinite(r))
            or not np.allclose(r @ r.T, np.eye(3), atol=1e-6)
            or np.linalg.det(r) < 0
        ):
            raise ValueError(
                f"{where}: 'handle.R' must be a 3x3 rotation matrix (orthonormal, determinant "
                "+1: a mirror is no pose of the handle)"
            )
        t = _vector(handle, "t", f"{where}: handle")
        p, e = r.T @ (p - t), r.T @ e
    return p, e


def check_target_line(design: ArmDesign, line: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """``parse_target``, then the IK's own checks of p and e, naming ``where``.

    A position in millimetres (beyond 100 x the arm's reach) or a zero direction is refused
    here with the line's number, not by the IK mid-stream.
    """
    from handarm.ik.exact import check_scale, check_target

    p, e = parse_target(line, where)
    p, e = check_target(p, e, f"{where}: p", f"{where}: e")
    check_scale(design, p, f"{where}: p")
    return p, e


def check_source_lines(design: ArmDesign, source: TargetSource) -> int:
    """Check every line of a file source before the bus is touched; its target count.

    A live source (stdin, UDP) is checked line by line as it arrives instead.
    """
    if source.lines is None:
        return 0
    count = 0
    for n, line in enumerate(source.lines, start=1):
        if line.strip():
            check_target_line(design, line, f"target line {n}")
            count += 1
    if count == 0:
        raise ValueError("source: the file holds no target line (it is empty or blank)")
    return count


class TargetSource:
    """Lines from a file (one per period), stdin or a localhost UDP port (newest wins).

    A reader thread queues ``(arrival time, line number, line)``; ``poll`` returns the
    target for this period, ``done`` is True once a file or stdin has ended and been used.
    """

    def __init__(self, lines=None, sock: socket.socket | None = None, paced: bool = False):
        self.paced = paced
        #: every line, when known before the loop starts (a file; a list): checked first
        self.lines = list(lines) if isinstance(lines, (list, tuple)) else None
        lines = self.lines if self.lines is not None else lines
        self.queue: queue.Queue = queue.Queue()
        self.ended = threading.Event()
        self.sock = sock
        target = self._read_lines if sock is None else self._read_socket
        self._thread = threading.Thread(target=target, args=(lines,), daemon=True)
        self._thread.start()

    def _read_lines(self, lines) -> None:
        for n, line in enumerate(lines, start=1):
            if line.strip():
                self.queue.put((time.perf_counter(), n, line))
        self.ended.set()

    def _read_socket(self, _lines) -> None:
        n = 0
        while not self.ended.is_set():
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                break
            for line in data.decode("utf-8", "replace").splitlines():
                n += 1
                if line.strip():
                    self.queue.put((time.perf_counter(), n, line))

    def poll(self):
        """``(arrival, line number, line)`` for this period, or None."""
        if self.paced:  # a recorded stream: each line arrives when its period starts
            try:
                _, n, line = self.queue.get_nowait()
            except queue.Empty:
                return None
            return time.perf_counter(), n, line
        item = None
        while True:
            try:
                item = self.queue.get_nowait()
            except queue.Empty:
                return item

    @property
    def done(self) -> bool:
        """A file or stdin has ended and every line has been handed out."""
        return self.sock is None and self.ended.is_set() and self.queue.empty()

    def close(self) -> None:
        """Stop reading (closes the socket)."""
        self.ended.set()
        if self.sock is not None:
            self.sock.close()


def open_source(spec: str) -> TargetSource:
    """A TargetSource from ``-`` (stdin), ``udp:PORT`` (127.0.0.1) or a file path."""
    if spec == "-":
        return TargetSource(sys.stdin)
    if spec.startswith("udp:"):
        try:
            port = int(spec[4:])
        except ValueError:
            port = -1
        if not 1 <= port <= 65535:
            raise ValueError(f"source: expected udp:PORT with PORT in 1..65535, got {spec!r}")
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind(("127.0.0.1", port))
        except OSError as exc:
            sock.close()
            raise ValueError(f"source: cannot listen on UDP port {port}: {exc.strerror}") from None
        sock.settimeout(0.1)
        return TargetSource(sock=sock)
    path = Path(spec)
    if not path.is_file():
        raise FileNotFoundError(f"source: no such file: {spec}")
    return TargetSource(path.read_text().splitlines(), paced=True)


class FollowStep(NamedTuple):
    """One period of the follow loop (``follow_step``)."""

    #: The next command (rad), at most one period's motion from the present one, on a
    #: valid straight line; the present command itself when no such step exists.
    q: np.ndarray
    #: The degrees of freedom the IK answer achieves (0 when it gives no configuration).
    reached_dof: int
    #: With a scene: the obstacles that block every exact solution (the arm then holds).
    blocked_by: tuple[str, ...]
    #: The IK answer's ``follow`` configuration the step heads for (None: no answer).
    goal: np.ndarray | None
    #: A new swing: the answer jumped to another family (``family_ended``) and its goal
    #: jumped since the previous period's (by more than ``ANSWER_JUMP``), so the step ran
    #: at ``JUMP_SPEED``.
    swing: bool
    #: The speed fraction bound the step: the full limit would have moved farther.
    slowed: bool
    #: The straight step towards the goal met a link or an obstacle at every length tried:
    #: the arm holds short of a goal it has not reached (``follow`` does not plan around).
    held: bool = False


def follow_step(
    design: ArmDesign,
    q_cmd,
    target,
    dt: float,
    limits: MotionLimits,
    scene=None,
    clearance: float = 0.0,
    *,
    speed: float = 1.0,
    previous_goal=None,
) -> FollowStep:
    """The next command from ``q_cmd`` towards the IK answer for ``target`` = (p, e).

    With a ``scene`` the answer is solved keeping ``clearance + scene_margin`` from the
    obstacles and the step's line keeps ``clearance``. A target whose every exact solution
    meets an obstacle is refused: the arm holds, and the obstacles are returned (a target
    out of reach in free space still degrades, in the scene, as without one).

    The step moves at ``speed`` (a fraction of the velocity limit), or at ``JUMP_SPEED``
    when the answer is a new swing: flagged ``family_ended`` and its goal more than
    ``ANSWER_JUMP`` from ``previous_goal`` (the last period's goal; None: there was none).
    An answer flagged only because the command lags behind a goal that moves smoothly is
    not a new swing. ``Follower`` keeps both between periods.

    Raises
    ------
    ValueError
        A ``clearance`` outside [0, 1] m, or other than 0 without a scene (naming it).
    """
    from handarm.ik import solve
    from handarm.ik.api import ANSWER_JUMP
    from handarm.ik.exact import check_clearance

    check_clearance(clearance, scene)
    p, e = target
    if scene:
        margin = clearance + scene_margin(design)
        kw = {"current": q_cmd, "scene": scene, "clearance": margin}
        # exact ranges first: a blocked target is refused without paying for a degraded
        # answer the arm would not take; only an unreachable one is solved again, degraded
        result = solve(design, p, e, degrade=False, **kw)
        if result.blocked_by:
            return FollowStep(q_cmd, 0, result.blocked_by, None, False, False)
        if result.count == 0:
            result = solve(design, p, e, **kw)
    else:
        result = solve(design, p, e, current=q_cmd)
    goal = getattr(result, "follow", None)
    if goal is None:
        return FollowStep(q_cmd, 0, (), None, False, False)
    goal = np.asarray(goal, float)
    swing = bool(result.family_ended) and (
        previous_goal is None or float(np.linalg.norm(goal - previous_goal)) > ANSWER_JUMP
    )
    fraction = JUMP_SPEED if swing else speed
    q_full = check_step(design, q_cmd, goal, dt, limits)
    q_next = check_step(design, q_cmd, goal, dt * fraction, limits) if fraction < 1.0 else q_full
    slowed = not np.array_equal(q_next, q_full)
    dof = int(result.reached_dof)
    for _ in range(4):
        if segment_valid(design, q_cmd, q_next, scene, clearance):
            return FollowStep(q_next, dof, (), goal, swing, slowed)
        q_next = q_cmd + (q_next - q_cmd) / 2  # a shorter step along the same line
    held = bool(np.abs(goal - q_cmd).max() > SETTLED)
    return FollowStep(q_cmd, dof, (), goal, swing, False, held)


class Follower:
    """``follow_step`` with the loop's memory between periods.

    It keeps the last goal (so that a goal moving smoothly ahead of a lagging command is
    not taken for a new swing) and the speed fraction: ``JUMP_SPEED`` after a swing, back
    up to the full limit over ``JUMP_RAMP`` seconds, so that neither the start of a swing
    nor its end comes at once.
    """

    def __init__(self, design: ArmDesign, dt: float, limits: MotionLimits, scene=None,
                 clearance: float = 0.0):  # fmt: skip
        from handarm.ik.exact import check_clearance

        check_clearance(clearance, scene)
        self.design, self.dt, self.limits = design, dt, limits
        self.scene, self.clearance = scene, clearance
        self.speed = 1.0
        self.goal = None

    def step(self, q_cmd, target) -> FollowStep:
        """The next command from ``q_cmd`` towards ``target`` = (p, e) (``follow_step``)."""
        out = follow_step(
            self.design, q_cmd, target, self.dt, self.limits, self.scene, self.clearance,
            speed=self.speed, previous_goal=self.goal,
        )  # fmt: skip
        if out.goal is not None:
            self.goal = out.goal
        if out.swing:
            self.speed = JUMP_SPEED
        self.speed = min(1.0, self.speed + (1.0 - JUMP_SPEED) * self.dt / JUMP_RAMP)
        return out


def _warm_up(design: ArmDesign, q, dt: float, limits: MotionLimits, scene, clearance) -> float:
    """Compile the loop's kernels before torque is on: the IK's and one step's checks (s)."""
    from handarm.ik import warm_up
    from handarm.kinematics import forward

    t0 = time.perf_counter()
    if scene:
        margin = clearance + scene_margin(design)
        warm_up(design, scene, margin, configurations=q, batch=False)
    else:
        warm_up(design, configurations=q, batch=False)
    follow_step(design, q, forward(design, q), dt, limits, scene, clearance)
    return time.perf_counter() - t0


@serial_checks()  # the whole loop runs the collision kernels on this thread only
def follow(
    bus: ServoBus,
    design: ArmDesign,
    calibration: Calibration,
    source: TargetSource,
    *,
    rate: float = 100.0,
    limits: MotionLimits | None = None,
    max_torque_fraction: float = 1.0,
    max_periods: int | None = None,
    on_period=None,
    scene=None,
    clearance: float = 0.0,
) -> dict:
    """Run the follow loop until the source ends (file, stdin), ``max_periods``, or Ctrl-C.

    With a ``scene`` (obstacles in the handle frame) every streamed step keeps
    ``clearance`` (m) from them (``follow_step``); the present pose must too.

    Checks the servos and the present pose first (``check_state``), compiles every kernel
    the loop calls (``handarm.ik.warm_up`` and one step from the present pose, so that no
    period stalls on a first use: 85 s measured on a fresh install, about a second after,
    a few seconds with a scene), reads and checks the present pose again (the arm was limp
    meanwhile) and turns torque on holding it. Every period: newest target -> ``Follower.step`` ->
    ``send_sample`` -> one servo's health (``check_health``). A bad target line, a fault
    or Ctrl-C holds the arm and raises.

    Returns
    -------
    dict
        ``periods``, ``targets``, ``rate`` (achieved, Hz), ``latency_ms`` (target arrival,
        or the loop's start for a target that arrived before it, to its command on the bus:
        median, 95th percentile, max), ``period_ms`` (same),
        ``q`` (last command, rad), ``blocked_by`` (obstacles that blocked every exact
        solution of some target, which the arm held before), ``slowed_periods`` (periods
        whose step the swing speed shortened, ``Follower``),
        ``warm_up_s`` (the kernels' warm-up before torque on, s) and ``stalled``: the
        last period held short of its goal, because the straight step towards it meets a
        link or an obstacle (``FollowStep.held``); a file source then ended there, its last
        target not reached.
    """
    from handarm.ik.exact import check_clearance

    limits = MotionLimits(design) if limits is None else limits
    try:
        dt = 1.0 / check_rate(rate)
        check_clearance(clearance, scene)  # before the bus is touched
        check_source_lines(design, source)  # a file's bad line: refused before any motion
        q_cmd = check_state(bus, design, calibration, max_torque_fraction)
        check_clear(design, q_cmd, scene, clearance, "present pose")
        warm_up_s = _warm_up(design, q_cmd, dt, limits, scene, clearance)
        # the arm was limp during the warm-up (up to a minute): read its pose again, so the
        # loop starts from where it is now, and check that pose again
        q_cmd = check_state(bus, design, calibration, max_torque_fraction)
        check_clear(design, q_cmd, scene, clearance, "present pose")
    except BaseException:
        source.close()
        raise
    set_torque(bus, design, True)
    limit = expected_registers(design, calibration, max_torque_fraction)[design.servo_ids[0]]
    blockers: set[str] = set()  # obstacles that blocked a target (the arm held)
    target, latencies, periods, n_targets, n_slowed = None, [], [], 0, 0
    stalled = False  # the last step held short of its goal
    follower = Follower(design, dt, limits, scene, clearance)
    i = 0
    t0 = last = time.perf_counter()
    try:
        while max_periods is None or i < max_periods:
            item = source.poll()
            if item is None and source.done and target is None:
                break
            arrival = None
            if item is not None:
                arrival, n, line = item
                # a line that came during the warm-up waited for the loop, not in it
                arrival = max(arrival, t0)
                target = check_target_line(design, line, f"target line {n}")
                n_targets += 1
            if target is not None:
                step = follower.step(q_cmd, target)
                q_next = step.q
                blockers.update(step.blocked_by)
                n_slowed += step.slowed
                send_sample(bus, design, calibration, q_next, q_cmd, dt)
                if arrival is not None:
                    latencies.append(time.perf_counter() - arrival)
                stalled = step.held
                if item is None and source.done and np.abs(q_next - q_cmd).max() <= SETTLED:
                    break  # the last target is reached (or as near as it gets), or held
                q_cmd = q_next
            check_health(bus, design, i, limit["torque_limit"])
            if on_period is not None:
                on_period(q_cmd)
            now = time.perf_counter()
            periods.append(now - last)
            last = now
            i += 1
            delay = t0 + i * dt - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
    except (KeyboardInterrupt, ServoFault, ValueError):
        hold(bus, design)
        raise
    finally:
        source.close()
    elapsed = time.perf_counter() - t0

    def stats(v):
        v = np.asarray(v) * 1000.0
        if v.size == 0:
            return {"median": None, "p95": None, "max": None}
        return {
            "median": float(np.median(v)),
            "p95": float(np.percentile(v, 95)),
            "max": float(v.max()),
        }

    return {
        "periods": i,
        "targets": n_targets,
        "rate": i / elapsed if elapsed > 0 else 0.0,
        "latency_ms": stats(latencies),
        "period_ms": stats(periods),
        "q": q_cmd,
        "blocked_by": sorted(blockers),
        "slowed_periods": n_slowed,
        "warm_up_s": warm_up_s,
        "stalled": stalled,
    }
