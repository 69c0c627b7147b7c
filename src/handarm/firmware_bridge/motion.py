"""Collision-free joint paths and their timing for the servo bus.

``plan_path`` returns waypoints from the present pose to a goal whose every straight edge
is valid under the design's collision model: the straight joint-space line when it is,
otherwise a path from OMPL's RRT-Connect, shortened, each edge checked again here.
``time_path`` times the waypoints with ruckig (rest to rest along each edge, the motor
velocity and acceleration limits taken through the coupling K) and samples them at a fixed
rate. ``segment_valid`` is the edge check every part of the bridge uses.

Edge check: between two samples no point of the arm moves farther than the design's
clearance allows. A joint step dq moves any point of the arm by at most
``|dq|_1 * lever``, ``lever`` the longest reach from a joint axis to an envelope point, so
samples ``clearance / lever`` apart (1-norm) leave two links, each within half a step of a
valid sample, still apart (the collision model already keeps them a clearance apart).

With a scene (``handarm.scene``) every sample must also keep ``clearance + scene_margin``
from the obstacles: between samples no envelope capsule moves farther than
``scene_margin`` (half a sample step times the lever), so the whole edge keeps
``clearance``. The margin is 0.2 mm on the default design.
"""

from __future__ import annotations

import contextlib
import functools
import math

import numpy as np

from handarm.design import ArmDesign
from handarm.kinematics import is_valid
from handarm.transmission import coupling_matrix

__all__ = [
    "serial_checks",
    "PlanningError",
    "MotionLimits",
    "check_step",
    "lever_arm",
    "segment_valid",
    "scene_margin",
    "scene_blockers",
    "plan_path",
    "time_path",
]


class PlanningError(RuntimeError):
    """No valid path to the goal (or the planner is missing); nothing was sent."""

    exit_status = 3


class MotionLimits:
    """Motor velocity and acceleration limits (rad/s, rad/s^2 of motor rotation).

    Parameters
    ----------
    design : ArmDesign
    speed_fraction : float
        Fraction of the servo's no-load speed a motor may run at (0 < f <= 1).
    acceleration : float
        Largest motor acceleration (rad/s^2, > 0).
    """

    def __init__(self, design: ArmDesign, speed_fraction: float = 0.5, acceleration: float = 20.0):
        if not 0.0 < speed_fraction <= 1.0:
            raise ValueError(f"speed_fraction: expected 0 < f <= 1, got {speed_fraction}")
        if not (math.isfinite(acceleration) and acceleration > 0.0):
            raise ValueError(f"acceleration: expected a positive number, got {acceleration}")
        self.velocity = speed_fraction * design.servo.no_load_speed
        self.acceleration = float(acceleration)


@contextlib.contextmanager
def serial_checks():
    """Run the collision kernels on this thread only while inside the block.

    The bridge checks a few poses at a time; waking numba's worker threads for each call
    costs tens of milliseconds on a busy machine, far more than the check itself.
    """
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


@functools.lru_cache(maxsize=8)
def lever_arm(design: ArmDesign) -> float:
    """Upper bound on the distance from any joint axis to any envelope point (m)."""
    from handarm.collision import envelopes

    env = envelopes(design)
    seg = np.asarray(env.seg, float)
    mid = np.column_stack([(seg[:, :2] + seg[:, 2:]) / 2, np.asarray(env.z, float).mean(axis=1)])
    # every envelope point lies within its piece's bounding sphere around that middle
    reach = float(np.max(np.linalg.norm(mid, axis=1) + np.asarray(env.sphere, float)))
    return float(np.sum(design.link_lengths)) + reach


def _step(design: ArmDesign) -> float:
    # the paper's zero-thickness model has no clearance: sample at 0.05 degrees instead
    if design.collision_model == "paper" or design.clearance <= 0.0:
        return math.radians(0.05)
    return design.clearance / lever_arm(design)


@functools.lru_cache(maxsize=16)
def scene_margin(design: ArmDesign) -> float:
    """How far an envelope capsule can move between two samples of an edge, at most (m)."""
    return 0.5 * _step(design) * lever_arm(design)


def scene_blockers(design: ArmDesign, q, scene, clearance: float) -> list[str]:
    """Names of the obstacles configuration ``q`` comes within ``clearance + margin`` of."""
    if not scene:
        return []
    from handarm.scene import scene_gaps

    gaps = scene_gaps(design, np.asarray(q, float), scene, clearance + scene_margin(design))
    return [name for name, g in zip(scene.names, gaps, strict=True) if g < 0]


def check_clear(design: ArmDesign, q, scene, clearance: float, name: str) -> None:
    """Refuse a pose (``name`` says which) that comes within the clearance of an obstacle.

    Raises
    ------
    PlanningError
        Naming the pose, the clearance with its sampling margin, and the obstacles.
    """
    blockers = scene_blockers(design, q, scene, clearance)
    if blockers:
        raise PlanningError(
            f"{name}: the pose comes within {1e3 * clearance:g} mm (+ "
            f"{1e3 * scene_margin(design):.2g} mm margin) of {', '.join(blockers)}; "
            "nothing was sent"
        )


def _samples(design: ArmDesign, qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    n = max(1, math.ceil(np.abs(qb - qa).sum() / _step(design)))
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    return qa + s * (qb - qa)


def segment_valid(design: ArmDesign, qa, qb, scene=None, clearance: float = 0.0) -> bool:
    """Whether the straight joint-space line from ``qa`` to ``qb`` is valid all along.

    Parameters
    ----------
    design : ArmDesign
    qa, qb : array-like, shape (6,)
        End configurations (rad).
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame) the whole line keeps ``clearance`` (m) from.

    Returns
    -------
    bool
        True when every sample (spaced so that the clearance certifies the gaps between
        them, see the module docstring) passes ``is_valid``.
    """
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    samples = _samples(design, qa, qb)
    if not np.all(is_valid(design, samples)):
        return False
    if not scene:
        return True
    from handarm.scene import scene_free

    return bool(np.all(scene_free(design, samples, scene, clearance + scene_margin(design))))


def check_step(design: ArmDesign, qa, qb, dt: float, limits: MotionLimits) -> np.ndarray:
    """The part of the move ``qa -> qb`` one period ``dt`` allows, shape (6,) rad.

    Motor speeds ``K (qb - qa) / dt`` above ``limits.velocity`` shrink the step along the
    same line.
    """
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    motor = np.abs(coupling_matrix(design) @ (qb - qa)).max()
    allowed = limits.velocity * dt
    if motor <= allowed:
        return qb
    return qa + (qb - qa) * (allowed / motor)


def plan_path(
    design: ArmDesign,
    start,
    goal,
    *,
    timeout: float = 5.0,
    seed: int | None = 0,
    scene=None,
    clearance: float = 0.0,
) -> np.ndarray:
    """Waypoints from ``start`` to ``goal`` (rad), every edge valid, shape (n, 6).

    Parameters
    ----------
    design : ArmDesign
    start, goal : array-like, shape (6,)
        Configurations (rad); both must be valid.
    timeout : float
        Seconds the planner may search.
    seed : int or None
        Seed of OMPL's random generator (None: OMPL's own).
    scene : handarm.scene.Scene, optional
        Obstacles (handle frame) every edge keeps ``clearance`` (m) from.

    Raises
    ------
    PlanningError
        If ``start`` or ``goal`` is invalid or meets an obstacle (named), or no path was
        found in time.
    """
    start, goal = np.asarray(start, float), np.asarray(goal, float)
    for name, q in (("start", start), ("goal", goal)):
        if not is_valid(design, q):
            raise PlanningError(f"{name}: the pose is not valid under the collision model")
        check_clear(design, q, scene, clearance, name)
    if segment_valid(design, start, goal, scene, clearance):
        return np.stack([start, goal])
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError:  # pragma: no cover - the test extra installs it
        raise PlanningError(
            "planner: the straight line collides and OMPL is not installed "
            "(pip install 'handarm[bridge]')"
        ) from None
    ou.setLogLevel(ou.LOG_WARN)
    if seed is not None:
        ou.RNG.setSeed(int(seed) + 1)
    space = ob.RealVectorStateSpace(6)
    bounds = ob.RealVectorBounds(6)
    for k in range(6):
        bounds.setLow(k, float(design.lower[k]))
        bounds.setHigh(k, float(design.upper[k]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)

    def valid(state) -> bool:
        q = np.array([state[k] for k in range(6)])
        return bool(is_valid(design, q)) and not scene_blockers(design, q, scene, clearance)

    ss.setStateValidityChecker(valid)
    extent = space.getMaximumExtent()
    ss.getSpaceInformation().setStateValidityCheckingResolution(math.radians(0.5) / extent)
    a, b = space.allocState(), space.allocState()
    for k in range(6):
        a[k], b[k] = float(start[k]), float(goal[k])
    ss.setStartAndGoalStates(a, b)
    ss.setPlanner(og.RRTConnect(ss.getSpaceInformation()))
    with serial_checks():
        solved = ss.solve(float(timeout))
    if not solved or not ss.haveExactSolutionPath():
        raise PlanningError(
            f"goal: no collision-free path from the present pose in {timeout:g} s; nothing was sent"
        )
    ss.simplifySolution()
    path = ss.getSolutionPath()
    pts = np.array([[path.getState(i)[k] for k in range(6)] for i in range(path.getStateCount())])
    pts[0], pts[-1] = start, goal
    # OMPL checks edges at a fixed resolution: certify each edge, split the ones that fail
    out = [pts[0]]
    for qa, qb in zip(pts[:-1], pts[1:], strict=True):
        if not segment_valid(design, qa, qb, scene, clearance):
            raise PlanningError(
                "goal: the planner's path grazes a link pair between its checks; "
                "nothing was sent (try again with another --seed)"
            )
        out.append(qb)
    return np.stack(out)


#: Hz: the fastest control rate taken. A period must hold a sync write of six goals and one
#: servo's health read (about 1 ms at 1 Mbaud); at 100 kHz a 0.66 s move took 72 s.
MAX_RATE_HZ = 1000.0


def check_rate(rate) -> float:
    """``rate`` (Hz) as a float in (0, ``MAX_RATE_HZ``]; ValueError naming ``rate``."""
    if isinstance(rate, bool) or not isinstance(rate, (int, float, np.integer, np.floating)):
        raise ValueError(f"rate: expected a number of Hz, got {rate!r}")
    if not (math.isfinite(rate) and 0 < rate <= MAX_RATE_HZ):
        raise ValueError(f"rate: expected 0 < Hz <= {MAX_RATE_HZ:g}, got {rate}")
    return float(rate)


def check_timing() -> None:
    """Raise PlanningError if ruckig, which times every move, is not installed.

    ``handarm bridge goto`` asks first, before it opens the port.
    """
    try:
        import ruckig  # noqa: F401
    except ImportError:  # pragma: no cover - the test extra installs it
        raise PlanningError(
            "timing: ruckig is not installed (pip install 'handarm[bridge]')"
        ) from None


def time_path(design: ArmDesign, waypoints, limits: MotionLimits, rate: float) -> np.ndarray:
    """Sample a waypoint path at ``rate`` Hz, timed with ruckig, shape (n, 6) rad.

    Each edge is a straight joint-space line run rest to rest: the path parameter is
    timed with ruckig (jerk-limited, time-optimal) under the tightest of the six motors'
    velocity and acceleration limits, motor motion being K times joint motion. The first
    sample is the first waypoint, the last is the goal, and every sample lies on an edge.

    Raises
    ------
    ValueError
        If ``rate`` is not within (0, ``MAX_RATE_HZ``].
    """
    check_timing()
    from ruckig import InputParameter, Result, Ruckig, Trajectory

    check_rate(rate)
    waypoints = np.asarray(waypoints, float)
    k = coupling_matrix(design)
    dt = 1.0 / rate
    out = [waypoints[0]]
    for qa, qb in zip(waypoints[:-1], waypoints[1:], strict=True):
        dphi = np.abs(k @ (qb - qa)).max()
        if dphi == 0.0:
            continue
        inp = InputParameter(1)
        inp.current_position, inp.target_position = [0.0], [1.0]
        inp.current_velocity = inp.current_acceleration = [0.0]
        inp.target_velocity = inp.target_acceleration = [0.0]
        inp.max_velocity = [limits.velocity / dphi]
        inp.max_acceleration = [limits.acceleration / dphi]
        inp.max_jerk = [20.0 * limits.acceleration / dphi]
        traj = Trajectory(1)
        result = Ruckig(1).calculate(inp, traj)
        if result != Result.Working:
            raise PlanningError(f"timing: ruckig could not time an edge ({result})")
        n = max(1, math.ceil(traj.duration / dt))
        for i in range(1, n):
            s = min(1.0, traj.at_time(i * dt)[0][0])
            out.append(qa + s * (qb - qa))
        out.append(qb.copy())  # exactly the waypoint (and the goal at the end)
    return np.stack(out)
