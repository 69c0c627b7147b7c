"""Level 2 (the nearest reachable point) against a brute-force oracle, on the paper's arm.

    python benchmarks/bench_level2.py [--targets 40] [--seed 0] [--cloud 200000]

Targets that only level 2 answers, ``--targets`` of each kind: points within 6 cm of the
base axis (where the nearest point lies on a contact of two printed links), points inside
the reach sphere that no pose reaches, and points beyond the stretched arm. The oracle is
independent of the library's search: ``--cloud`` valid configurations drawn at random
(``handarm.is_valid``), the 24 whose tool points lie nearest each target polished by a
pattern search of its own (steps along each joint and random directions, kept valid,
halved down to 1e-8 rad; numpy on the public ``forward`` and ``is_valid``). Prints per kind:
how many answers are farther than the oracle's by more than 1e-7 m and the worst of them,
how many are nearer, and the library's time per target (p50 / p90 / worst).
"""

from __future__ import annotations

import math
import time

import numpy as np
from _targets import parser, valid_configurations
from tqdm import tqdm

import handarm
from handarm import ik

_NEAREST = 24
_TOL = 1e-7


def targets(design, rng, n):
    """(kind, p, e) of targets answered at level 2, ``n`` of each kind."""
    reach = float(np.sum(design.lengths[1:]))
    draw = {
        "base axis": lambda: np.array(
            [
                *(0.06 * math.sqrt(rng.uniform()) * _unit2(rng)),
                rng.choice([-1, 1]) * rng.uniform(0.1, 0.25),
            ]
        ),
        "inside": lambda: _unit3(rng) * reach * rng.uniform(0.2, 0.98) ** (1 / 3),
        "beyond": lambda: _unit3(rng) * reach * rng.uniform(1.02, 1.3),
    }
    out = []
    for kind, make in draw.items():
        found = 0
        for _ in range(200 * n):
            if found == n:
                break
            p, e = make(), _unit3(rng)
            if ik.count_solutions(design, p[None], e[None])[0] == 0 and not _reachable(design, p):
                out.append((kind, p, e))
                found += 1
    return out


def _reachable(design, p) -> bool:
    """Whether the library answers p at a level that keeps the position (5, 4 or 3)."""
    return ik.solve(design, p, _unit3(np.random.default_rng(0))).reached_dof >= 3


def _unit2(rng):
    t = rng.uniform(0, 2 * math.pi)
    return np.array([math.cos(t), math.sin(t)])


def _unit3(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def oracle(design, cloud_q, cloud_p, p, rng) -> float:
    """Distance from p of the best of the nearest configurations after a pattern search."""
    q = cloud_q[np.argsort(np.linalg.norm(cloud_p - p, axis=1))[:_NEAREST]].copy()
    dist = np.linalg.norm(handarm.forward(design, q)[0] - p, axis=1)
    step = np.full(len(q), 0.05)
    while (step > 1e-8).any():
        live = np.flatnonzero(step > 1e-8)
        random = rng.normal(size=(8, 6))
        polls = np.vstack([np.eye(6), -np.eye(6), random / np.linalg.norm(random, axis=1)[:, None]])
        trial = q[live, None, :] + step[live, None, None] * polls[None]
        flat = trial.reshape(-1, 6)
        d = np.linalg.norm(handarm.forward(design, flat)[0] - p, axis=1)
        d[~handarm.is_valid(design, flat)] = np.inf
        d = d.reshape(len(live), len(polls))
        k = np.argmin(d, axis=1)
        best = d[np.arange(len(live)), k]
        better = best < dist[live]
        moved = live[better]
        q[moved] = trial[better, k[better]]
        dist[moved] = best[better]
        step[moved] = np.minimum(2 * step[moved], 0.2)
        step[live[~better]] *= 0.5
    return float(dist.min())


def main(argv=None) -> None:
    ap = parser(__doc__, 40, help="targets of each kind")
    ap.add_argument("--cloud", type=int, default=200_000, help="oracle's valid configurations")
    args = ap.parse_args(argv)
    design = handarm.ArmDesign()
    rng = np.random.default_rng(args.seed)
    ik.solve(design, [0.5, 0.0, 0.0], [1.0, 0.0, 0.0])  # compile / load the kernels
    cases = targets(design, rng, args.targets)
    cloud_q = valid_configurations(design, rng, args.cloud, args.cloud)
    cloud_p = handarm.forward(design, cloud_q)[0]
    rows = {}
    for kind, p, e in tqdm(cases, desc="level 2 vs oracle", unit="target"):
        t = time.perf_counter()
        r = ik.solve(design, p, e)
        took = time.perf_counter() - t
        assert r.reached_dof == 2 and handarm.is_valid(design, r.solutions).all()
        best = oracle(design, cloud_q, cloud_p, p, rng)
        rows.setdefault(kind, []).append((r.position_error - best, took))
    print(f"level 2 against a brute-force oracle ({args.cloud:,} valid configurations, "
          f"the nearest {_NEAREST} searched), paper's arm")  # fmt: skip
    print(f"{'kind':<10} {'targets':>8} {'farther':>8} {'worst mm':>9} {'nearer':>7} "
          f"{'p50 ms':>7} {'p90 ms':>7} {'worst ms':>9}")  # fmt: skip
    for kind, vals in rows.items():
        gap = np.array([v[0] for v in vals])
        ms = np.array([v[1] for v in vals]) * 1e3
        print(
            f"{kind:<10} {len(vals):>8} {int(np.sum(gap > _TOL)):>8} "
            f"{max(0.0, gap.max()) * 1e3:>9.3f} {int(np.sum(gap < -_TOL)):>7} "
            f"{np.median(ms):>7.1f} {np.percentile(ms, 90):>7.1f} {ms.max():>9.1f}"
        )


if __name__ == "__main__":
    main()
