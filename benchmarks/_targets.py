"""Targets the benchmarks share: tool poses of random valid configurations."""

from __future__ import annotations

import argparse

import numpy as np

import handarm


def valid_configurations(design: handarm.ArmDesign, rng, n: int, batch: int) -> np.ndarray:
    """n configurations uniform in the joint limits that ``is_valid`` accepts, (n, 6).

    Drawn ``batch`` at a time until there are enough.
    """
    found = []
    while sum(len(q) for q in found) < n:
        q = rng.uniform(design.lower, design.upper, (batch, 6))
        found.append(q[handarm.is_valid(design, q)])
    return np.concatenate(found)[:n]


def fk_targets(design: handarm.ArmDesign, rng: np.random.Generator, n: int):
    """(P, E), shape (n, 3) each: the tool poses of n random valid configurations."""
    return handarm.forward(design, valid_configurations(design, rng, n, 8 * n))


def parser(doc: str, targets: int, help: str | None = None) -> argparse.ArgumentParser:
    """--targets (default ``targets``) and --seed, with the script's docstring as help."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--targets", type=int, default=targets, help=help)
    ap.add_argument("--seed", type=int, default=0)
    return ap


def arguments(doc: str, targets: int, argv=None) -> argparse.Namespace:
    """``parser``'s arguments, parsed."""
    return parser(doc, targets).parse_args(argv)
