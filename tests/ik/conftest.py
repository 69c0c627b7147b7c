import math

import numpy as np
import pytest

import handarm

#: A random design of a hostile check (2026-11-27): joint 2's limit bounds a zero-length
#: range in a scene, and joint 3's a sliver of the family over the base.
HOSTILE_D3 = dict(
    link_lengths=(0.025138950028617463, 0.03420863039576598, 0.06807646791238381,
                  0.05492972216386206, 0.02564771853442395, 0.04598761641418843,
                  0.048743077888450045),
    joint_limits=((-1.0884475013548176, 2.4930422870793696),
                  (-0.9758848429006824, 1.6540825079053763),
                  (-1.9607661597716728, 1.750354453857918),
                  (-2.1319510972609916, 2.50100952354062),
                  (-3.034733398423394, 1.3925661471559663),
                  (-2.282831477339631, 2.3993083033704647)),
)  # fmt: skip


def random_design(rng):
    """Unequal lengths and asymmetric limits up to +-180 degrees.

    Drawn again while none of 512 random configurations is valid: with 20-30 mm links (less
    than a fork is long) the printed links can leave no valid configuration at all, and
    ``valid_configurations`` would look for one forever.
    """
    while True:
        lim = np.radians(rng.uniform(40, 180, (6, 2)))
        design = handarm.ArmDesign(
            link_lengths=rng.uniform(0.02, 0.08, 7),
            joint_limits=[(-lo, hi) for lo, hi in lim],
        )
        if handarm.is_valid(design, rng.uniform(design.lower, design.upper, (512, 6))).any():
            return design


def valid_configurations(design, rng, n):
    out = []
    while sum(len(o) for o in out) < n:
        q = rng.uniform(design.lower, design.upper, (4 * n, 6))
        out.append(q[handarm.is_valid(design, q)])
    return np.concatenate(out)[:n]


def generator_branch_and_u(design, q):
    """Branch and u of configurations, computed from joint positions (not by the IK)."""
    pos = handarm.joint_positions(design, q)
    p, e = handarm.forward(design, q)
    l3 = pos[..., 4, :2] - pos[..., 3, :2]
    d = l3 / np.linalg.norm(l3, axis=-1, keepdims=True)
    sign = np.where(np.sum(d * e[..., :2], axis=-1) >= 0, 1, -1)
    u = np.sum((pos[..., 4, :2] - p[..., :2]) * d, axis=-1)
    elbow_b = np.where(q[..., 1] >= 0, 1, -1)
    elbow_e = np.where(q[..., 4] >= 0, 1, -1)
    return np.stack([sign, elbow_b, elbow_e], axis=-1), u


@pytest.fixture(scope="session")
def paper():
    return handarm.ArmDesign()


__all__ = ["random_design", "valid_configurations", "generator_branch_and_u", "math"]
