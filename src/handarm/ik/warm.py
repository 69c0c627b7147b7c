"""Compile (or load) every kernel a control loop calls, before the loop starts.

The IK kernels are numba functions compiled on their first call and cached on disk. A loop
that starts cold meets each kernel the first time its case comes up: on a fresh install, the
first target that needs a level-3 answer stalls the loop while that search compiles (1.5 s
measured on one tracking step of ``benchmarks/bench_ik.py`` with the cache emptied; about a
minute for all kernels). ``warm_up`` solves one target of each kind the loop can meet, so
the stall happens before the loop, and with a warm cache it costs a few tens of ms.
"""

from __future__ import annotations

import time

import numpy as np

from handarm.design import ArmDesign
from handarm.kinematics import forward, is_valid

__all__ = ["warm_up"]

#: how far the tool point is pushed out from a reachable pose to meet each degraded level (m)
_PUSHES = (0.003, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15)


def _valid_configurations(design: ArmDesign, n: int, seed: int) -> np.ndarray:
    """Up to ``n`` valid configurations drawn uniformly in the limits (reproducible)."""
    rng = np.random.default_rng(seed)
    found = np.empty((0, 6))
    for _ in range(20):
        q = rng.uniform(design.lower, design.upper, (64 * n, 6))
        found = np.concatenate([found, q[is_valid(design, q)]])
        if len(found) >= n:
            break
    return found[:n]


def warm_up(design: ArmDesign, scene=None, clearance: float = 0.0, *, seed: int = 0) -> dict:
    """Solve one target of every kind a control loop meets, so that no kernel compiles later.

    Covers: exact targets with and without ``current``, a near-vertical direction (the
    tolerance cone), targets pushed out of reach until answers at 4, 3 and 2 DoF have been
    seen (each level's search), a point beyond the stretched arm's reach, both degradation
    orders, ``count_solutions`` and ``solve_batch``; with a ``scene``, the same exact and
    degraded solves keeping ``clearance`` from it. Nothing is stored: the kernels' compiled
    code stays in the process (and in numba's cache on disk).

    Returns
    -------
    dict
        ``levels``: the ``reached_dof`` values met (sorted), ``targets``: solves run,
        ``seconds``: wall time.
    """
    from handarm.ik.api import solve
    from handarm.ik.exact import count_solutions, solve_batch

    if not isinstance(design, ArmDesign):
        raise TypeError(f"design: expected an ArmDesign, got {type(design).__name__}")
    t0 = time.perf_counter()
    q = _valid_configurations(design, 6, seed)
    if len(q) == 0:
        raise ValueError("design: no valid configuration found in 20 draws to warm up with")
    P, E = forward(design, q)
    P, E = np.atleast_2d(P), np.atleast_2d(E)
    levels: set[int] = set()
    n = 0

    def run(p, e, current=None, **kw):
        nonlocal n
        n += 1
        result = solve(design, p, e, current, **kw)
        levels.add(int(result.reached_dof))
        return result

    count_solutions(design, P, E)
    solve_batch(design, P, E)
    reach = float(np.sum(design.lengths))
    for i in range(len(q)):
        p, e = P[i], E[i]
        run(p, e)
        run(p, e, q[i])
        # a direction inside the vertical tolerance cone, reached in current's tip plane
        run(p, np.array([1e-4, 0.0, 1.0]), q[i])
        out = p / np.linalg.norm(p)
        for push in _PUSHES:
            run(p + push * out, e, q[i])
            if {2, 3, 4} <= levels:
                break
        if {2, 3, 4} <= levels and i >= 1:
            break
    out = P[0] / np.linalg.norm(P[0])
    run(1.2 * reach * out, E[0], q[0])  # beyond the stretched arm: straight to level 2
    run(P[0] + 0.02 * out, E[0], q[0], order="angle")
    if scene is not None:
        seen: set[int] = set()
        for i in range(len(q)):
            run(P[i], E[i], q[i], scene=scene, clearance=clearance, degrade=False)
            run(P[i], E[i], q[i], scene=scene, clearance=clearance)
            out = P[i] / np.linalg.norm(P[i])
            for push in _PUSHES:
                r = run(P[i] + push * out, E[i], q[i], scene=scene, clearance=clearance)
                seen.add(int(r.reached_dof))
                if {2, 3, 4} <= seen:
                    break
            if {2, 3, 4} <= seen and i >= 1:
                break
    return {
        "levels": sorted(levels),
        "targets": n,
        "seconds": time.perf_counter() - t0,
    }
