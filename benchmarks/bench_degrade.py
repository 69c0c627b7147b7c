"""What degradation costs: `solve` on unreachable targets, by the level it ends at.

    python benchmarks/bench_degrade.py [--targets 40] [--seed 0]

Targets are FK targets of random valid configurations of the paper's arm, pushed out along
the tool point by 2-150 mm (so 5, 4, 3 and 2 DoF answers all occur), with the approach direction
kept. Prints the median time per target for each level reached, against the exact solve of
reachable FK targets measured in the same run (the peer), and the ratio.
"""

from __future__ import annotations

import collections
import time

import numpy as np
from _targets import arguments, fk_targets

import handarm
from handarm import ik


def main(argv=None) -> None:
    args = arguments(__doc__, 40, argv)
    rng = np.random.default_rng(args.seed)
    d = handarm.ArmDesign()
    P, E = fk_targets(d, rng, args.targets)
    push = rng.uniform(0.002, 0.15, len(P))[:, None]
    far = P + push * P / np.linalg.norm(P, axis=1, keepdims=True)
    ik.solve(d, far[0], E[0])  # compile
    exact = []
    for p, e in zip(P, E, strict=True):
        t = time.perf_counter()
        ik.solve(d, p, e, degrade=False)
        exact.append(time.perf_counter() - t)
    by_level = collections.defaultdict(list)
    for p, e in zip(far, E, strict=True):
        t = time.perf_counter()
        r = ik.solve(d, p, e)
        by_level[r.reached_dof].append(time.perf_counter() - t)
    peer = float(np.median(exact))
    print(f"{args.targets} targets of the paper's arm, pushed out 2-150 mm\n")
    print(f"{'answer':<22} {'targets':>8} {'median':>12} {'vs exact':>10}")
    print(f"{'exact (reachable)':<22} {len(exact):>8} {peer * 1e3:>9.2f} ms {1.0:>9.0f}x")
    for level in sorted(by_level, reverse=True):
        times = by_level[level]
        med = float(np.median(times))
        print(f"{f'{level} DoF kept':<22} {len(times):>8} {med * 1e3:>9.2f} ms {med / peer:>9.0f}x")


if __name__ == "__main__":
    main()
