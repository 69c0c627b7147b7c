"""What obstacles cost the IK: `solve` with scenes of 1, 10 and 100 boxes against free space.

    python benchmarks/bench_scene.py [--targets 200] [--seed 0]

Targets are FK targets of random valid configurations of the paper's arm; boxes (10-40 mm)
are placed at random in the arm's reach. Prints the median time per target, the ratio to the
free-space solve measured in the same run, and how many ranges the scenes leave.
"""

from __future__ import annotations

import time

import numpy as np
from _targets import arguments, fk_targets

import handarm
from handarm import ik
from handarm.scene import Scene


def boxes(rng, n) -> Scene:
    s = Scene.empty()
    for _ in range(n):
        s = s.with_box(
            rng.uniform(0.01, 0.04, 3),
            rng.uniform([-0.05, -0.25, -0.25], [0.3, 0.25, 0.25]),
            rng.uniform(-3, 3, 3),
        )
    return s


def main(argv=None) -> None:
    args = arguments(__doc__, 200, argv)
    rng = np.random.default_rng(args.seed)
    d = handarm.ArmDesign()
    P, E = fk_targets(d, rng, args.targets)
    scenes = {n: boxes(rng, n) for n in (1, 10, 100)}
    ik.solve(d, P[0], E[0], scene=scenes[1])  # compile
    rows = []
    t_free, ranges = [], 0
    for p, e in zip(P, E, strict=True):
        t = time.perf_counter()
        r = ik.solve(d, p, e, degrade=False)
        t_free.append(time.perf_counter() - t)
        ranges += r.count
    rows.append(("free space", np.median(t_free), ranges))
    for n, scene in scenes.items():
        times, ranges = [], 0
        for p, e in zip(P, E, strict=True):
            t = time.perf_counter()
            r = ik.solve(d, p, e, scene=scene, clearance=0.002)
            times.append(time.perf_counter() - t)
            ranges += r.count
        rows.append((f"{n} box{'es' if n > 1 else ''}", np.median(times), ranges))
    print(f"{args.targets} FK targets of the paper's arm, clearance 2 mm\n")
    print(f"{'scene':<14} {'p50 us':>10} {'vs free':>8} {'ranges left':>12}")
    base = rows[0][1]
    for name, t, ranges in rows:
        print(f"{name:<14} {t * 1e6:>10.0f} {t / base:>7.1f}x {ranges:>12}")


if __name__ == "__main__":
    main()
