"""Constants and small helpers shared by the IK kernels (numba)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

PI = math.pi
TWO_PI = 2.0 * math.pi
MAX_CAND = 96  # candidate events per canonical problem (at most 74 are generated)
MAX_IV = 40  # intervals per canonical problem and elbow
VERTICAL_EPS = 1e-12  # |horizontal part of e| below this: the direction is vertical
# Ranges closer than this (m) are one range: a constraint that only touches its bound inside a
# range leaves a hole of a single point, which rounding turns into ~1e-9 m or nothing.
MERGE_GAP = 2e-9
WS_SIZE = 128

#: rad: a joint angle this far or less beyond a limit is the limit, rounded (a range that
#: ends where a joint meets its limit, or a zero-length one there).
LIMIT_SNAP = 1e-10
#: m: a range this narrow or less is one configuration, where two joints meet their limits
#: at once (the valid set is a point); its limits are checked with ``LIMIT_SNAP`` of slack,
#: the rounding of the events that bound it (their u differs by ~1e-16 m, by 1e-10 rad of
#: joint angle only along ~5e-12 m of the line).
POINT_GAP = 1e-12

JIT = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}
#: For thin wrappers and one-caller helpers on hot paths. At every call numba counts a
#: reference up and down for each array argument, each member of a tuple argument included:
#: a solvability probe of degradation's searches passes about 190 arrays through four
#: calls, and a probe that ends at once (out of reach) took 0.97 us, 0.37 us with all four
#: inlined. Not for big functions with several callers: each caller compiles its own copy
#: (inlining ``_solve_target`` too doubled the first compile).
INLINE = {**JIT, "inline": "always"}


def horizontal_length(ex, ey):
    """|horizontal part of e| as every part of the IK computes it: vertical below VERTICAL_EPS.

    sqrt(ex^2 + ey^2), the same operations in Python, numpy and the kernels
    (``horizontal``), not ``hypot``, which rounds differently: at a tilt of VERTICAL_EPS the
    two disagreed, and a solve that found e vertical was reported as not.
    """
    return math.sqrt(ex * ex + ey * ey)


def horizontal_lengths(E):
    """``horizontal_length`` of each row of E (n, 3), the same operations element by element."""
    return np.sqrt(E[:, 0] * E[:, 0] + E[:, 1] * E[:, 1])


@nb.njit(**JIT)
def widened(lim):
    """Limits (lo, hi, lo, hi, lo, hi) widened by ``LIMIT_SNAP`` on each side."""
    out = np.empty(6)
    for k in range(3):
        out[2 * k], out[2 * k + 1] = lim[2 * k] - LIMIT_SNAP, lim[2 * k + 1] + LIMIT_SNAP
    return out


#: ``horizontal_length`` in the kernels.
horizontal = nb.njit(**JIT)(horizontal_length)


@nb.njit(**JIT)
def wrap(x):
    """Angle to (-pi, pi]."""
    y = x - TWO_PI * math.floor((x + PI) / TWO_PI)
    if y <= -PI:
        y += TWO_PI
    return y
