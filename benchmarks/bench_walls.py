"""Walls that print, on random legal designs: each carved link's thinnest wall against min_wall.

    python benchmarks/bench_walls.py [--designs 20] [--seed 0] [--parts]

Draws random designs (link lengths 35-80 mm, hubs 6-12 mm, beams 8-16 mm, cables 0.8-2 mm,
clearances 0.2-0.4 mm; the rest the paper's, ``min_wall`` 1.2 mm), skips those the design
checks refuse, carves the others and measures every link's thinnest wall as
``links/*.json`` reports it (``handarm.carve.properties.wall_thickness`` on the carved
mesh), and with ``--parts`` whether every printed part closes as written (binary STL read
back). Prints one row per design (the links under ``min_wall`` with their walls, the parts
that do not close) and a summary line for each.
"""

from __future__ import annotations

import argparse
import io
import time

import numpy as np
import trimesh

import handarm
from handarm.carve import carve
from handarm.carve.properties import to_trimesh, wall_thickness


def random_design(rng: np.random.Generator, k: int) -> handarm.ArmDesign:
    return handarm.ArmDesign(
        name=f"random{k}",
        link_lengths=tuple(rng.uniform(0.035, 0.08, 7)),
        hub_radius=float(rng.uniform(0.006, 0.012)),
        beam_width=float(rng.uniform(0.008, 0.016)),
        cable_diameter=float(rng.uniform(0.0008, 0.002)),
        clearance=float(rng.uniform(0.0002, 0.0004)),
    )


def closed(solid) -> bool:
    data = to_trimesh(solid).export(file_type="stl")
    return trimesh.load(io.BytesIO(data), file_type="stl").is_watertight


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--parts", action="store_true", help="also split and check printed parts")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    tried = legal = thick = closes = 0
    print(f"{'design':<10} {'cable':>6} {'hub':>6} {'beam':>6} {'s':>5}  links under min_wall")
    while legal < args.designs and tried < 10 * args.designs:
        tried += 1
        try:
            design = random_design(rng, tried)
        except ValueError:
            continue
        legal += 1
        t = time.perf_counter()
        try:
            result = carve(design)
        except ValueError as exc:  # a range no printable link allows: refused, one line
            print(f"{design.name:<10} refused: {exc}")
            continue
        mw = design.min_wall * 1e3
        thin = []
        for link in result.links:
            wall, _ = wall_thickness(link.solid, mw, samples=link.walls)
            if wall < mw - 1e-9:
                thin.append(f"{link.name} {wall:.3f}")
        thick += not thin
        open_ = []
        if args.parts:
            parts = [p for s in result.printed for p in s.parts]
            open_ = [f"{p.name} open" for p in parts if not closed(p.solid)]
            closes += not open_
        print(
            f"{design.name:<10} {design.cable_diameter * 1e3:6.2f} {design.hub_radius * 1e3:6.2f}"
            f" {design.beam_width * 1e3:6.2f} {time.perf_counter() - t:5.1f}  "
            + (", ".join(thin + open_) or "none")
        )
    print(f"{thick} of {legal} legal designs keep min_wall in every link ({tried} drawn)")
    if args.parts:
        print(f"{closes} of {legal} close every printed part as an STL")


if __name__ == "__main__":
    main()
