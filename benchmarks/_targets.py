"""Targets the benchmarks share: tool poses of random valid configurations."""

from __future__ import annotations

import numpy as np

import handarm


def fk_targets(design: handarm.ArmDesign, rng: np.random.Generator, n: int):
    """(P, E), shape (n, 3) each: the tool poses of n random valid configurations."""
    found = []
    while sum(len(q) for q in found) < n:
        q = rng.uniform(design.lower, design.upper, (8 * n, 6))
        found.append(q[handarm.is_valid(design, q)])
    return handarm.forward(design, np.concatenate(found)[:n])
