"""How well ``is_valid`` matches the printed arm: both collision models against the meshes.

    python benchmarks/bench_collision_model.py [--configs 20000] [--seed 1] [--design FILE]

Draws configurations uniformly in the joint limits, places the carved link meshes by the
URDF frames, and takes as truth "two non-adjacent printed links overlap by more than 1 mm^3"
(python-fcl contact, confirmed by the manifold3d intersection volume; ``tests/mesh_truth.py``).
Prints, for the printed-link model (the default) and the paper's segment model: the fraction
accepted, the fraction of accepted configurations that collide (must be 0 for the printed
model), the fraction of collision-free configurations rejected (over-rejection), the worst
overlap accepted, and the time per configuration. Needs the test extra (python-fcl).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import handarm  # noqa: E402
from mesh_truth import PAIRS, MeshArm  # noqa: E402


def truth(arm: MeshArm, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per configuration: any fcl contact, largest overlap volume (mm^3), pair hit counts."""
    contact = np.zeros(len(q), bool)
    worst = np.zeros(len(q))
    pairs = np.zeros((len(q), len(PAIRS)), bool)
    for i in tqdm(range(len(q)), desc="meshes", unit="config", leave=False):
        hits = arm.contacts(q[i])
        contact[i] = bool(hits)
        for a, b in hits:
            v = arm.overlap_volume(q[i], a, b)
            worst[i] = max(worst[i], v)
            pairs[i, PAIRS.index((a, b))] |= v > 1.0
    return contact, worst, pairs


def timed(design, q, repeats=5) -> float:
    handarm.is_valid(design, q[:10])  # compile
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        handarm.is_valid(design, q)
        runs.append(time.perf_counter() - t)
    return float(np.median(runs)) / len(q)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--configs", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--design", type=Path, default=None, help="design TOML (default: the paper's)")
    args = ap.parse_args(argv)
    design = handarm.ArmDesign.from_toml(args.design) if args.design else handarm.ArmDesign()
    rng = np.random.default_rng(args.seed)
    q = rng.uniform(design.lower, design.upper, (args.configs, 6))
    t0 = time.perf_counter()
    arm = MeshArm(design)
    print(f"carved in {time.perf_counter() - t0:.1f} s")
    contact, worst, pairs = truth(arm, q)
    collide = worst > 1.0
    free = ~contact
    print(
        f"\n{args.configs} configurations uniform in the joint limits, seed {args.seed}: "
        f"{collide.mean():.1%} overlap by more than 1 mm^3, {free.mean():.1%} have no contact"
    )
    print(
        "\n| model | accepted | accepted that collide (>1 mm^3) | accepted with any contact "
        "| worst accepted overlap (mm^3) | collision-free rejected | us/config |"
    )
    print("|---|---|---|---|---|---|---|")
    for model in ("printed", "paper"):
        d = dataclasses.replace(design, collision_model=model)
        ok = handarm.is_valid(d, q)
        inside = handarm.within_limits(d, q)
        bad = ok & collide
        print(
            f"| {model} | {ok.mean():.1%} | {bad.sum() / max(ok.sum(), 1):.2%} ({bad.sum()}) "
            f"| {(ok & contact).sum() / max(ok.sum(), 1):.2%} "
            f"| {worst[ok].max() if ok.any() else 0.0:.1f} "
            f"| {(~ok & free & inside).sum() / max((free & inside).sum(), 1):.2%} "
            f"| {timed(d, q) * 1e6:.2f} |"
        )
    ok = handarm.is_valid(design, q)
    print("\nPrinted model: pairs of the configurations it rejects although no mesh touches")
    which = handarm.colliding_pairs(design, q[~ok & free])
    names = [f"l{a}-l{b}" for a, b in handarm.collision.LINK_PAIRS]
    counts = which.sum(axis=0)
    for k in np.argsort(-counts):
        if counts[k]:
            print(f"  {names[k]}: {counts[k]}")
    print("\nPaper model: link pairs that overlap (>1 mm^3) in accepted configurations")
    okp = handarm.is_valid(dataclasses.replace(design, collision_model="paper"), q)
    for k in np.argsort(-pairs[okp].sum(axis=0)):
        n = int(pairs[okp, k].sum())
        if n:
            a, b = PAIRS[k]
            print(f"  l{a}-l{b}: {n / okp.sum():.1%} of accepted")


if __name__ == "__main__":
    main()
