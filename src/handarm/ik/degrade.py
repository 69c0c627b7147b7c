"""Graceful degradation (paper III-D).

When a target (p, e) has no 5-DoF solution the closest reachable pose is returned:

4 DoF
    p exact; either the pitch of e (its elevation, yaw kept: the tip plane stays) or its yaw
    (azimuth, pitch kept) is relaxed, whichever needs the smaller change of direction.
3 DoF
    p exact; the reachable direction closest to e.
2 DoF
    p out of reach: the nearest reachable tool point, with the tool pointing at p when the
    arm can.

Searches over directions are exact at their final step: a grid finds the solvable region
closest to e and bisection pins its boundary, so the error is never worse than the grid's.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from scipy.optimize import least_squares

from handarm.design import ArmDesign
from handarm.ik import exact as S
from handarm.ik.results import IKResult
from handarm.kinematics import forward, is_valid

__all__ = ["degrade_target", "closest_direction_on_circle", "closest_direction"]

_FINE_STEP = math.radians(0.25)
_NEAR = math.radians(12.0)
_BISECT = 48
_SPHERE = 2000


def _solvable(design: ArmDesign, p: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    dirs = np.atleast_2d(dirs)
    return S.solve_batch(design, np.broadcast_to(p, dirs.shape).copy(), dirs).counts > 0


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between unit vectors, robust near 0 and pi."""
    return 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def closest_direction_on_circle(design, p, make_dir, theta0):
    """Solvable angles closest to theta0 on a one-parameter circle of directions.

    Parameters
    ----------
    design : ArmDesign
    p : ndarray, shape (3,)
    make_dir : callable
        Angles (n,) -> unit directions (n, 3); the cost grows with |angle - theta0|.
    theta0 : float

    Returns
    -------
    list of float
        The nearest solvable angle on each side of theta0 (none if the circle is unsolvable):
        the first solvable grid angle going out, refined by bisection to the boundary.
    """
    found = []
    for side in (1.0, -1.0):
        for lo, hi in ((_FINE_STEP, _NEAR), (_NEAR, math.pi)):
            offs = side * np.arange(lo, hi + 1e-12, _FINE_STEP)
            ok = _solvable(design, p, make_dir(theta0 + offs))
            if ok.any():
                k = int(np.argmax(ok))
                good = offs[k]
                bad = good - side * _FINE_STEP
                for _ in range(_BISECT):
                    mid = 0.5 * (good + bad)
                    if _solvable(design, p, make_dir(np.array([theta0 + mid])))[0]:
                        good = mid
                    else:
                        bad = mid
                found.append(theta0 + good)
                break
    return found


def _fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (1.0 + math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    omega = float(_angle(a, b))
    if omega < 1e-15:
        return b.copy()
    v = (math.sin((1 - t) * omega) * a + math.sin(t * omega) * b) / math.sin(omega)
    return v / np.linalg.norm(v)


def closest_direction(design, p, e0):
    """Solvable directions near e0 for the tool point p, closest first (empty if none).

    The three solvable samples of a Fibonacci sphere nearest e0 are each moved to the
    boundary by bisection along the arc towards e0, then by a shrinking pattern search.
    """
    sphere = _fibonacci_sphere(_SPHERE)
    ok = _solvable(design, p, sphere)
    if not ok.any():
        return []
    cand = sphere[ok]
    ang = _angle(cand, e0)
    found = []
    for k in np.argsort(ang)[:3]:
        good = cand[k]
        # bisection along the great circle from e0 (unsolvable) to the solvable sample
        lo, hi = 0.0, 1.0
        for _ in range(_BISECT):
            mid = 0.5 * (lo + hi)
            if _solvable(design, p, _slerp(e0, good, mid))[0]:
                hi = mid
            else:
                lo = mid
        good = _slerp(e0, good, hi)
        found.append(_pattern_search(design, p, e0, good))
    found.sort(key=lambda v: float(_angle(v, e0)))
    return found


def _pattern_search(design, p, e0, good):
    """Move a solvable direction towards e0 by shrinking rings of trial directions."""
    step = math.radians(2.0)
    ring = np.linspace(0, 2 * math.pi, 12, endpoint=False)
    while step > 1e-7:
        a0 = float(_angle(good, e0))
        # orthonormal frame around `good`
        t1 = np.cross(good, [0.0, 0.0, 1.0] if abs(good[2]) < 0.9 else [1.0, 0.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(good, t1)
        trial = math.cos(step) * good + math.sin(step) * (
            np.cos(ring)[:, None] * t1 + np.sin(ring)[:, None] * t2
        )
        closer = _angle(trial, e0) < a0
        if closer.any():
            trial = trial[closer]
            ok = _solvable(design, p, trial)
            if ok.any():
                trial = trial[ok]
                good = trial[int(np.argmin(_angle(trial, e0)))]
                continue
        step *= 0.5
    return good


def _pitch_yaw(e: np.ndarray) -> tuple[float, float]:
    return math.asin(max(-1.0, min(1.0, e[2]))), math.atan2(e[1], e[0])


#: With ``current``, a relaxed direction costs its angle plus this much per radian of joint
#: motion (the largest joint change): a handheld user should not see the arm jump between
#: two nearly equally good poses.
JOINT_MOTION_WEIGHT = 0.5


def _choose(design, p, e, candidates, dof, current) -> IKResult:
    """The best relaxed direction among candidates, as an IKResult at level ``dof``."""
    best, best_score = None, math.inf
    for v in candidates:
        r = S.solve_exact(design, p, v, current)
        if r.count == 0:
            continue
        err = float(_angle(v, e))
        score = err
        if current is not None:
            score += JOINT_MOTION_WEIGHT * float(np.max(np.abs(r.follow - current)))
        if score < best_score:
            best, best_score = (
                dataclasses.replace(
                    r, reached_dof=dof, direction_error=err, achieved_direction=v.copy()
                ),
                score,
            )
    return best


def degrade_target(design: ArmDesign, p: np.ndarray, e: np.ndarray, current=None) -> IKResult:
    """The closest reachable pose to (p, e), which has no 5-DoF solution (see module doc)."""
    pitch, yaw = _pitch_yaw(e)

    def along_pitch(th):
        # the full vertical great circle through e: the tip plane is kept
        return np.stack(
            [np.cos(th) * math.cos(yaw), np.cos(th) * math.sin(yaw), np.sin(th)], axis=-1
        )

    def along_yaw(ph):
        c = math.cos(pitch)
        return np.stack([c * np.cos(ph), c * np.sin(ph), np.full_like(ph, math.sin(pitch))], -1)

    candidates = [
        along_pitch(np.array([t]))[0]
        for t in closest_direction_on_circle(design, p, along_pitch, pitch)
    ]
    # straight up and down lie on every pitch circle; being vertical they leave L's azimuth
    # free, so they can be solvable where their neighbours on the circle are not
    for up in (1.0, -1.0):
        v = np.array([0.0, 0.0, up])
        if _solvable(design, p, v)[0]:
            candidates.append(v)
    if math.cos(pitch) > 1e-9:  # a vertical e has no yaw to relax
        candidates += [
            along_yaw(np.array([t]))[0]
            for t in closest_direction_on_circle(design, p, along_yaw, yaw)
        ]
    result = _choose(design, p, e, candidates, 4, current)
    if result is None:
        result = _choose(design, p, e, closest_direction(design, p, e), 3, current)
    if result is None:
        result = _two_dof(design, p, e, current)
    return result


@functools.lru_cache(maxsize=8)
def _position_cloud(design: ArmDesign) -> tuple[np.ndarray, np.ndarray]:
    """Tool points of many valid configurations (seeds for the nearest-position search)."""
    rng = np.random.default_rng(12345)
    q = rng.uniform(design.lower, design.upper, (40000, 6))
    q = q[is_valid(design, q)]
    return q, forward(design, q)[0]


def _two_dof(design: ArmDesign, p, e, current) -> IKResult:
    """Nearest reachable tool point; the tool points at p when the arm can."""
    seeds = []
    # the stretched arm aimed at p: only joints 1 and 4 move (paper III-D)
    q1 = float(np.clip(math.atan2(p[1], p[0]), design.lower[0], design.upper[0]))
    q4 = float(np.clip(math.atan2(p[2], math.hypot(p[0], p[1])), design.lower[3], design.upper[3]))
    stretched = np.array([q1, 0.0, 0.0, q4, 0.0, 0.0])
    seeds.append(np.clip(stretched, design.lower, design.upper))
    if current is not None:
        seeds.append(np.clip(current, design.lower, design.upper))
    cloud_q, cloud_p = _position_cloud(design)
    if len(cloud_q):
        seeds.extend(cloud_q[np.argsort(np.linalg.norm(cloud_p - p, axis=1))[:2]])
    best_q, best_err = None, math.inf
    for q0 in seeds:
        if not is_valid(design, q0):
            continue
        lo = design.lower - 1e-12
        hi = design.upper + 1e-12
        fit = least_squares(
            lambda q: forward(design, q)[0] - p, q0, bounds=(lo, hi), xtol=1e-12, ftol=1e-12
        )
        for q in (fit.x, q0):
            q = np.clip(q, design.lower, design.upper)
            if not is_valid(design, q):
                continue
            err = float(np.linalg.norm(forward(design, q)[0] - p))
            if err < best_err - 1e-12:
                best_q, best_err = q, err
            break
    if best_q is None:  # no valid seed at all: the zero pose is the fallback
        best_q = np.zeros(6)
        best_err = float(np.linalg.norm(forward(design, best_q)[0] - p))
    p_reached, e_reached = forward(design, best_q)
    # point at the target from there, if that pose has a solution
    aim = p - p_reached
    if np.linalg.norm(aim) > 1e-12:
        aim = aim / np.linalg.norm(aim)
        r = S.solve_exact(design, p_reached, aim, best_q if current is None else current)
        if r.count:
            return dataclasses.replace(
                r,
                reached_dof=2,
                position_error=best_err,
                direction_error=float(_angle(aim, e)),
                follow=r.follow if current is not None else None,
            )
    branch, u = S.branch_of(design, best_q)
    return IKResult(
        best_q[None, :],
        branch[None, :],
        np.array([[u, u]]),
        2,
        best_err,
        float(_angle(e_reached, e)),
        False,
        0.0,
        p_reached.copy(),
        e_reached.copy(),
        best_q.copy() if current is not None else None,
    )
