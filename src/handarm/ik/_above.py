"""Numba kernels of level 2 over the base (``handarm.ik.degrade._above_the_disk``).

A point straight above or below the base's reach and out of it is met nearest by the
configurations with joint 4 under it and the tip chain vertical: a one-parameter family over
the tip plane's azimuth psi (and the base's elbow), each member in closed form
(``member``). Where the family meets a joint limit its valid azimuths can be a sliver far
narrower than any grid of samples (0.003 deg in a hostile check); ``limit_crossings`` finds
where each of joints 1-3 crosses a limit between two samples, to a hair, so that the
sliver's ends are candidates too.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm.ik._common import JIT, wrap

#: How far c2 (the cosine of joint 2) may round beyond +-1 at the ends of its reach.
_C2_ROUNDING = 1e-12
#: Bisection steps of a crossing: a sample spacing of up to 0.6 deg to below 1e-13 rad.
_BISECTIONS = 48


@nb.njit(**JIT)
def member(p, a, psi, elbow, out):
    """The family's configuration at tip-plane azimuth psi into out (6,); False out of reach.

    Joint 4 at (p_x, p_y), the tip chain vertical (joint 4 at +-90 deg, towards p_z),
    joints 1 and 2 reaching joint 3 (one link back from joint 4 along the tip plane) with
    the given elbow (the sign of q2).
    """
    j3x = p[0] - a[3] * math.cos(psi)
    j3y = p[1] - a[3] * math.sin(psi)
    c2 = (j3x * j3x + j3y * j3y - a[1] * a[1] - a[2] * a[2]) / (2.0 * a[1] * a[2])
    if c2 > 1.0:
        if c2 > 1.0 + _C2_ROUNDING:
            return False
        c2 = 1.0
    elif c2 < -1.0:
        if c2 < -1.0 - _C2_ROUNDING:
            return False
        c2 = -1.0
    q2 = elbow * math.acos(c2)
    q1 = wrap(math.atan2(j3y, j3x) - math.atan2(a[2] * math.sin(q2), a[1] + a[2] * math.cos(q2)))
    out[0] = q1
    out[1] = q2
    out[2] = wrap(psi - q1 - q2)
    out[3] = 0.5 * math.pi if p[2] >= 0.0 else -0.5 * math.pi
    out[4] = 0.0
    out[5] = 0.0
    return True


@nb.njit(**JIT)
def members(p, a, psis, elbow, out):
    """``member`` at each of psis into the rows of out (n, 6); NaN rows out of reach."""
    for i in range(psis.shape[0]):
        if not member(p, a, psis[i], elbow, out[i]):
            for k in range(6):
                out[i, k] = np.nan


@nb.njit(**JIT)
def _excess(q, j, limit, upper):
    """How far joint j of q lies beyond the limit (positive: outside)."""
    return q[j] - limit if upper else limit - q[j]


@nb.njit(**JIT)
def limit_crossings(p, a, lower, upper, psis, rows, elbow, out):
    """Azimuths either side of each limit crossing of joints 1-3 between samples psis.

    psis: increasing azimuths (one elbow); rows: their ``members`` (NaN out of reach).
    Where joint j's excess over a limit changes sign between neighbouring samples (both in
    reach, the joint not wrapping between them), the crossing is bisected to about 1e-13
    rad and the bracket's two ends go into out, the side within the limit among them.
    Where it comes within the limit and leaves it again between two samples (a dip, both
    outside), the least excess is found by golden-section search about the sample between,
    and the two crossings either side of it are bisected too. Returns how many azimuths
    were written (the crossings beyond out's capacity are dropped, the nearest the start
    first kept).
    """
    qm = np.empty(6)
    n = 0
    for i in range(1, psis.shape[0]):
        q0, q1 = rows[i - 1], rows[i]
        if math.isnan(q0[0]) or math.isnan(q1[0]):
            continue
        for j in range(3):
            if abs(q1[j] - q0[j]) > math.pi:
                continue  # wrapped between the samples, not a crossing
            for side in range(2):
                limit = upper[j] if side == 1 else lower[j]
                g0 = _excess(q0, j, limit, side == 1)
                g1 = _excess(q1, j, limit, side == 1)
                if (g0 > 0.0) == (g1 > 0.0):
                    continue
                inside, outside = (psis[i - 1], psis[i]) if g0 <= 0.0 else (psis[i], psis[i - 1])
                n = _crossing(p, a, elbow, j, limit, side == 1, inside, outside, qm, out, n)
            # a dip: the joint comes within the limit and leaves it again between two
            # samples, both outside (no sign change): the excess is least near sample i
            if i + 1 < psis.shape[0] and not math.isnan(rows[i + 1, 0]):
                q2 = rows[i + 1]
                if abs(q2[j] - q1[j]) > math.pi:
                    continue
                for side in range(2):
                    limit = upper[j] if side == 1 else lower[j]
                    g0 = _excess(q0, j, limit, side == 1)
                    g1 = _excess(q1, j, limit, side == 1)
                    g2 = _excess(q2, j, limit, side == 1)
                    if not (g1 > 0.0 and g1 <= g0 and g1 <= g2):
                        continue
                    # a smooth least value (a parabola through the three) lies at most a
                    # quarter of the larger rise below g1: far from the limit, none
                    if g1 > max(g0 - g1, g2 - g1):
                        continue
                    n = _dip(p, a, psis[i - 1], psis[i + 1], elbow, j, limit, side == 1, out, n)
    return n


@nb.njit(**JIT)
def _dip(p, a, lo, hi, elbow, j, limit, upper, out, n):
    """Both ends of the sliver where joint j dips within the limit on (lo, hi), into out[n:].

    Golden-section search for the least excess; where it is inside the limit, the two
    crossings either side are bisected and their brackets appended. Returns the new n.
    """
    q = np.empty(6)
    ratio = 0.5 * (math.sqrt(5.0) - 1.0)
    x_lo, x_hi = lo, hi
    for _ in range(_BISECTIONS + 12):
        x1 = x_hi - ratio * (x_hi - x_lo)
        x2 = x_lo + ratio * (x_hi - x_lo)
        if not (member(p, a, x1, elbow, q)):
            return n
        g1 = _excess(q, j, limit, upper)
        if not (member(p, a, x2, elbow, q)):
            return n
        g2 = _excess(q, j, limit, upper)
        if g1 <= 0.0 or g2 <= 0.0:
            x_lo, x_hi = (x1, x1) if g1 <= 0.0 else (x2, x2)
            break
        if g1 < g2:
            x_hi = x2
        else:
            x_lo = x1
    inside = 0.5 * (x_lo + x_hi)
    if not member(p, a, inside, elbow, q) or _excess(q, j, limit, upper) > 0.0:
        return n
    for outside in (lo, hi):
        n = _crossing(p, a, elbow, j, limit, upper, inside, outside, q, out, n)
    return n


@nb.njit(**JIT)
def _crossing(p, a, elbow, j, limit, upper, inside, outside, q, out, n):
    """Bisect where joint j crosses the limit between psi inside (within) and outside.

    The bracket's two ends, about 1e-13 rad apart, go into out[n:] (if there is room);
    returns the new n. Out of reach counts as outside.
    """
    for _ in range(_BISECTIONS):
        mid = 0.5 * (inside + outside)
        if member(p, a, mid, elbow, q) and _excess(q, j, limit, upper) <= 0.0:
            inside = mid
        else:
            outside = mid
    if n + 2 <= out.shape[0]:
        out[n] = inside
        out[n + 1] = outside
        n += 2
    return n
