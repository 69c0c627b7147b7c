"""Design search: NSGA-II against a grid of the same budget, on the paper arm's neighbourhood.

    python benchmarks/bench_optimize.py [--trials 196] [--workers 2] [--voxel 0.05]
        [--directions 16] [--samplers grid,nsga2,tpe] [--seeds 1] [--out DIR]

Every run uses the same variables (symmetric limits of joints 2 and 5 in 90..170 degrees),
the same objectives (dexterous volume and payload up, printed mass down, minimum cross-section
up), the same map settings and the same number of trials (the grid is k x k with k^2 =
--trials rounded down to a square): designs measured. A parameter set a sampler asks for
again is answered from the journal (column "repeats") and measures nothing. The searching
samplers run once per seed (1..--seeds; the grid is deterministic and runs once). Prints
one table: hypervolume of each feasible front (references 0 L, 0 kg, 200 g, 0 mm^2) and its
ratio to the grid's, wall time, and whether each found a design that beats the paper's arm
on dexterous volume and payload at no more mass and no less minimum cross-section; then
each sampler's median over its seeds.
Targets: 200 trials at the study map settings in <= 10 minutes on 2 cores; the optimizer's
hypervolume >= the grid's.
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
from pathlib import Path

import handarm
from handarm.workspace.opt_file import load_opt
from handarm.workspace.optimize import measure_design, run_optimization

OPT = """
name = "{name}"
sampler = "{sampler}"
grid_points = {k}
seed = {seed}
[map]
voxel = {voxel}
directions = {directions}
[variables]
limit_deg_2 = {{low = 90, high = 170}}
limit_deg_5 = {{low = 90, high = 170}}
[objectives]
dexterous_volume = "maximize"
payload = "maximize"
mass = {{direction = "minimize", reference = 200}}
min_cross_section = "maximize"
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=196)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--voxel", type=float, default=0.05)
    ap.add_argument("--directions", type=int, default=16)
    ap.add_argument("--samplers", default="grid,nsga2,tpe", help="comma-separated")
    ap.add_argument("--seeds", type=int, default=1, help="runs of each searching sampler")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    samplers = args.samplers.split(",")
    unknown = set(samplers) - {"grid", "nsga2", "tpe", "gp"}
    if unknown or args.seeds < 1:
        ap.error(f"--samplers: unknown {sorted(unknown)}" if unknown else "--seeds: must be >= 1")
    out = Path(args.out or tempfile.mkdtemp())
    k = math.isqrt(args.trials)
    trials = k * k
    runs = [(s, 1) for s in samplers if s == "grid"]
    runs += [(s, seed) for s in samplers if s != "grid" for seed in range(1, args.seeds + 1)]
    settings = None
    rows = []
    for sampler, seed in runs:
        name = f"{sampler}-seed{seed}"
        path = out / f"{name}.toml"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(
            OPT.format(
                name=name,
                sampler=sampler,
                k=k,
                seed=seed,
                voxel=args.voxel,
                directions=args.directions,
            )
        )
        opt = load_opt(path)
        settings = opt.map
        t = time.perf_counter()
        res = run_optimization(opt, out / name, trials=trials, workers=args.workers)
        wall = time.perf_counter() - t
        rows.append((sampler, seed, res, wall))
        print(f"{name}: hypervolume {res['hypervolume']:.5g}, {wall:.0f} s", flush=True)
    paper = measure_design(handarm.ArmDesign().to_dict(), settings)
    print(
        f"paper arm: dexterous {paper['dexterous_volume_L']:.2f} L, payload "
        f"{paper['payload_kg']:.3f} kg, mass {paper['mass_g']:.1f} g, min section "
        f"{paper['min_cross_section_mm2']:.1f} mm^2 (voxel {args.voxel} m, "
        f"{args.directions} directions)"
    )
    grid_hv = next((res["hypervolume"] for s, _, res, _ in rows if s == "grid"), None)
    print(
        f"{'sampler':>8} {'seed':>4} {'trials':>6} {'repeats':>7} {'front':>5} {'hypervolume':>12} "
        f"{'/ grid':>7} {'wall s':>7}  beats paper"
    )
    for sampler, seed, res, wall in rows:
        beats = [
            d["trial"]
            for d in res["front"]
            if d["measurements"]["dexterous_volume_L"] > paper["dexterous_volume_L"]
            and d["measurements"]["payload_kg"] > paper["payload_kg"]
            and d["measurements"]["mass_g"] <= paper["mass_g"]
            and d["measurements"]["min_cross_section_mm2"] >= paper["min_cross_section_mm2"]
        ]
        ratio = f"{res['hypervolume'] / grid_hv:7.4f}" if grid_hv else f"{'-':>7}"
        print(
            f"{sampler:>8} {seed:>4} {trials:>6} {res['repeats']:>7} {len(res['front']):>5} "
            f"{res['hypervolume']:>12.5g} {ratio} {wall:>7.0f}  {beats or 'no'}"
        )
    print("median over seeds:")
    for sampler in dict.fromkeys(s for s, *_ in rows):
        hv = statistics.median(res["hypervolume"] for s, _, res, _ in rows if s == sampler)
        wall = statistics.median(w for s, _, _, w in rows if s == sampler)
        ratio = f", {hv / grid_hv:.4f} x the grid's" if grid_hv else ""
        print(f"  {sampler:>6}: hypervolume {hv:.5g}{ratio}, wall {wall:.0f} s")
    print(f"results in {out}")


if __name__ == "__main__":
    main()
