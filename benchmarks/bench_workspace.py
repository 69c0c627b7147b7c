"""Workspace map speed: the default map (10 mm voxels, 100 directions) and its peers.

    python benchmarks/bench_workspace.py [--voxel 0.01] [--directions 100]

Prints one table, all measured in this run on the paper's arm: handarm's map (counting
kernel, mirror symmetries), the same map without the symmetries, and the same queries through
solve_batch (which stores every solution, as a user without the counting kernel would).
Target: the default map in <= 60 s on this 2-core machine.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import handarm
from handarm import ik
from handarm.workspace.maps import direction_set, reachability_map


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--voxel", type=float, default=0.01)
    ap.add_argument("--directions", type=int, default=100)
    args = ap.parse_args()
    d = handarm.ArmDesign()
    reachability_map(d, 0.05, 16)  # load the compiled kernels

    t = time.perf_counter()
    m = reachability_map(d, args.voxel, args.directions)
    t_map = time.perf_counter() - t
    t = time.perf_counter()
    full = reachability_map(d, args.voxel, args.directions, use_symmetry=False)
    t_full = time.perf_counter() - t
    same = np.array_equal(m.index, full.index)
    # solve_batch on a sample of the same queries, scaled to the whole map
    dirs = direction_set(args.directions)
    c = full.centres
    gx, gy, gz = np.meshgrid(c, c, c, indexing="ij")
    inside = np.flatnonzero(gx**2 + gy**2 + gz**2 <= (full.reach + args.voxel) ** 2)
    rng = np.random.default_rng(0)
    pick = rng.choice(inside, min(len(inside), 3000), replace=False)
    P = np.repeat(np.stack([gx.flat[pick], gy.flat[pick], gz.flat[pick]], 1), len(dirs), 0)
    E = np.tile(dirs, (len(pick), 1))
    t = time.perf_counter()
    ik.solve_batch(d, P, E)
    rate_batch = len(P) / (time.perf_counter() - t)
    t_batch = full.queries / rate_batch

    print(
        f"reachability map of the paper's arm: {args.voxel * 1000:g} mm voxels, "
        f"{len(dirs)} directions, {int(full.reachable.sum())} reachable voxels"
    )
    print(f"{'method':<46} {'seconds':>8} {'IK queries':>11} {'queries/s':>11}")
    print(
        f"{'handarm map (counting kernel, mirrored)':<46} {t_map:8.1f} {m.queries:11d} "
        f"{m.queries / m.seconds:11,.0f}"
    )
    print(
        f"{'same, without the mirror symmetries':<46} {t_full:8.1f} {full.queries:11d} "
        f"{full.queries / full.seconds:11,.0f}   {t_full / t_map:.1f}x slower"
    )
    print(
        f"{'same queries through solve_batch (estimated)':<46} {t_batch:8.1f} "
        f"{full.queries:11d} {rate_batch:11,.0f}   {t_batch / t_map:.1f}x slower"
    )
    print(f"mirrored map identical to the full one: {same}; target: <= 60 s")


if __name__ == "__main__":
    main()
