"""Compile (or load) every kernel a control loop calls, before the loop starts.

The IK kernels are numba functions compiled on their first call and cached on disk. A loop
that starts cold meets each kernel the first time its case comes up: on a fresh install, the
first target that needs a level-3 answer stalls the loop while that search compiles (1.5 s
measured on one tracking step of ``benchmarks/bench_ik.py`` with the cache emptied; about a
minute for all kernels). ``warm_up`` solves one target of each kind the loop can meet, so
the stall happens before the loop: 85 s measured with an empty cache, 0.7 s in a fresh
process with a warm one (the kernels' code is loaded from disk), 0.04 s after that.
"""

from __future__ import annotations

import math
import time

import numpy as np

from handarm.design import ArmDesign
from handarm.ik.exact import check_current
from handarm.kinematics import forward, is_valid

__all__ = ["warm_up"]

#: how far the tool point is pushed out from a reachable pose to meet each degraded level (m)
_PUSHES = (0.003, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15)


def _valid_configurations(design: ArmDesign, n: int, seed: int, first=None) -> np.ndarray:
    """Up to ``n`` valid configurations: ``first``'s valid rows, then uniform draws."""
    found = np.empty((0, 6))
    if first is not None:
        first = check_current(first, "configurations", rows=True)
        found = first[is_valid(design, first)]
    rng = np.random.default_rng(seed)
    for _ in range(_DRAWS):
        if len(found) >= n:
            break
        q = rng.uniform(design.lower, design.upper, (64 * n, 6))
        found = np.concatenate([found, q[is_valid(design, q)]])
    return found[:n]


#: rounds of uniform draws (64 x the configurations wanted each) before giving up
_DRAWS = 20
#: solves spent on a scene at most (each degraded one in a scene can take 0.1-1 s)
_SCENE_SOLVES = 12


def warm_up(
    design: ArmDesign,
    scene=None,
    clearance: float = 0.0,
    *,
    configurations=None,
    batch: bool = True,
    seed: int = 0,
) -> dict:
    """Solve one target of every kind a control loop meets, so that no kernel compiles later.

    Covers: exact targets with and without ``current``, a near-vertical direction (the
    tolerance cone), targets pushed out of reach until answers at 4, 3 and 2 DoF have been
    seen (each level's search), a point beyond the stretched arm's reach, both degradation
    orders and, with ``batch``, ``count_solutions`` and ``solve_batch``. With a ``scene``,
    what ``bridge follow`` asks of it: exact solves keeping ``clearance`` from configurations
    that keep it, and targets pushed out of reach degraded in the scene when no obstacle
    blocks them (at most ``_SCENE_SOLVES`` solves). The targets come from ``configurations``
    (for example the arm's present pose) and then from valid configurations drawn at random.
    Nothing is stored: the compiled code stays in the process (and in numba's cache on disk).

    Returns
    -------
    dict
        ``levels``: the ``reached_dof`` of the answers met without the scene (sorted),
        ``scene_levels``: those met in the scene (empty without one), ``targets``: solves
        run, ``seconds``: wall time.

    Raises
    ------
    TypeError
        If ``design`` is not an ArmDesign.
    ValueError
        If neither ``configurations`` nor 20 rounds of random draws give a valid
        configuration; if ``configurations`` are not joint angles (k, 6) in radians within
        +-2 pi, or ``clearance`` is not a distance in [0, 1] m (or not 0 without a scene).
    """
    from handarm.ik.api import solve
    from handarm.ik.exact import check_clearance, count_solutions, solve_batch

    if not isinstance(design, ArmDesign):
        raise TypeError(f"design: expected an ArmDesign, got {type(design).__name__}")
    check_clearance(clearance, scene)
    t0 = time.perf_counter()
    q = _valid_configurations(design, 6, seed, configurations)
    if len(q) == 0:
        raise ValueError(
            f"design: no valid configuration to warm up with in {_DRAWS * 64 * 6:,} random "
            "draws; pass the arm's present pose as configurations"
        )
    P, E = forward(design, q)
    P, E = np.atleast_2d(P), np.atleast_2d(E)
    levels: set[int] = set()
    scene_levels: set[int] = set()
    n = 0

    def run(p, e, current=None, into=levels, **kw):
        nonlocal n
        n += 1
        result = solve(design, p, e, current, **kw)
        if result.count:  # an empty answer (reached_dof 0) reached no level
            into.add(int(result.reached_dof))
        return result

    if batch:
        count_solutions(design, P, E)
        solve_batch(design, P, E)
    reach = float(np.sum(design.lengths))
    for i in range(len(q)):
        p, e = P[i], E[i]
        run(p, e)
        run(p, e, q[i])
        # a direction inside the vertical tolerance cone, reached in current's tip plane
        run(p, np.array([1e-4, 0.0, 1.0]), q[i])
        out = p / max(float(np.linalg.norm(p)), 1e-300)
        for push in _PUSHES:
            run(p + push * out, e, q[i])
            if {2, 3, 4} <= levels:
                break
        if {2, 3, 4} <= levels and i >= 1:
            break
    out = P[0] / max(float(np.linalg.norm(P[0])), 1e-300)
    run(1.2 * reach * out, E[0], q[0])  # beyond the stretched arm: straight to level 2
    # straight above joint 2 and out of reach: level 2's family over the base (closed form)
    a, q1 = design.lengths, float(q[0][0])
    above = float(a[4] + a[5] + a[6]) + 0.1 * reach
    run(np.array([a[1] * math.cos(q1), a[1] * math.sin(q1), above]), E[0], q[0])
    # straight above the base axis and out of reach: no closed form, so level 2 polishes its
    # seeds and slides those a contact cut short (its kernel compiled inside a loop took 16 s
    # on one level-2 step of benchmarks/bench_ik.py with the cache emptied)
    run(np.array([0.0, 0.0, above + 0.4 * reach]), E[0], q[0])
    run(P[0] + 0.02 * out, E[0], q[0], order="angle")
    if scene is not None and len(scene):
        from handarm.scene import scene_free

        free = q[scene_free(design, q, scene, clearance)]
        budget = _SCENE_SOLVES
        kw = {"scene": scene, "clearance": clearance, "into": scene_levels}
        for qi in free[:2]:
            pi, ei = forward(design, qi)
            run(pi, ei, qi, degrade=False, **kw)
            out = pi / max(float(np.linalg.norm(pi)), 1e-300)
            for push in _PUSHES:
                if budget <= 0 or {2, 3, 4} <= scene_levels:
                    break
                # as bridge follow asks: exact first, degraded only when nothing blocks it
                budget -= 1
                r = run(pi + push * out, ei, qi, degrade=False, **kw)
                if r.count == 0 and not r.blocked_by:
                    budget -= 1
                    run(pi + push * out, ei, qi, **kw)
    return {
        "levels": sorted(levels),
        "scene_levels": sorted(scene_levels),
        "targets": n,
        "seconds": time.perf_counter() - t0,
    }
