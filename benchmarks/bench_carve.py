"""Carving speed: handarm's 2D sweeps against a direct 3D union of rotated copies.

    python benchmarks/bench_carve.py [--repeats 3]

Measures carving all seven links of the paper's arm at 1 degree (sweeps, carving, achieved
limits), and beside it, on the same links in the same run, the straightforward peer: the
union of the neighbour rotated every degree as 3D meshes (manifold3d), for joint 2 only.
Also the cable limits alone (``tendons.cable_limits``, all six joints) against one proof of
a given range by manifold3d sweeps (``tendons.swept_overlap``, all six joints): finding the
limits by bisection on that proof would take about ten of them per side. Prints one table
of medians.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from manifold3d import Manifold, OpType

import handarm
from handarm.carve import carve, link_blank
from handarm.carve.carving import _blank_solid, _sweep_into_proximal
from handarm.tendons import cable_limits, swept_overlap


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times)), out


def naive_joint_sweep(design, j, step_deg=1.0):
    """The distal link's blank rotated every step, unioned as 3D meshes."""
    d = link_blank(design, j)
    solid = _blank_solid(d)
    lo, hi = (math.degrees(v) for v in design.joint_limits[j - 1])
    copies = [solid.rotate([0.0, 0.0, float(a)]) for a in np.arange(lo, hi + 1e-9, step_deg)]
    union = Manifold.batch_boolean(copies, OpType.Add)
    union.num_vert()  # force evaluation
    return union


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    design = handarm.ArmDesign()
    carve(design, 5.0)  # warm-up (imports, first allocations)
    t_all, result = median_time(lambda: carve(design, 1.0), args.repeats)
    blanks = [link_blank(design, k) for k in range(7)]
    solids = [_blank_solid(b) for b in blanks]
    lo, hi = design.joint_limits[1]

    def ours():
        s = _sweep_into_proximal(blanks, solids, 2, lo, hi, math.radians(1.0), 0.4)
        s.num_vert()
        return s

    t_ours, _ = median_time(ours, args.repeats)
    t_naive, _ = median_time(lambda: naive_joint_sweep(design, 2), 1)
    ranges = [j.links_meet for j in result.joints]
    t_cables, _ = median_time(lambda: cable_limits(design, result.links, ranges), args.repeats)
    achieved = [j.achieved for j in result.joints]
    t_proof, _ = median_time(lambda: swept_overlap(design, result, achieved), args.repeats)
    print("carving the paper's arm, 1 degree resolution (medians)")
    print(f"{'what':<52} {'seconds':>9}")
    print(f"{'handarm: all 7 links, 12 sweeps, achieved limits':<52} {t_all:9.2f}")
    print(f"{'handarm: one sweep (l2 about joint 2)':<52} {t_ours:9.3f}")
    print(
        f"{'peer: 3D union of 301 rotated copies of l2 (1 run)':<52} {t_naive:9.3f}"
        f"   {t_naive / t_ours:.0f}x slower"
    )
    print(f"{'handarm: cable limits of all 6 joints':<52} {t_cables:9.3f}")
    print(
        f"{'peer: one sweep proof of all 6 ranges (manifold3d)':<52} {t_proof:9.3f}"
        f"   x ~10 per side to bisect"
    )
    print("target: all seven links in <= 10 s on 2 cores")
    for j in result.joints:
        lo_r, hi_r = (math.degrees(v) for v in j.requested)
        lo_a, hi_a = (math.degrees(v) for v in j.achieved)
        lo_m, hi_m = (math.degrees(v) for v in j.links_meet)
        print(
            f"  joint {j.joint}: requested {lo_r:.1f}..{hi_r:.1f}, links meet at "
            f"{lo_m:.2f}..{hi_m:.2f}, achieved {lo_a:.2f}..{hi_a:.2f} ({j.stopped_by[1]})"
        )


if __name__ == "__main__":
    main()
