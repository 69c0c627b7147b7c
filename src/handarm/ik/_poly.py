"""Real roots of small polynomials (ascending coefficients), exactly up to rounding."""

from __future__ import annotations

import numba as nb

from handarm.ik._common import JIT


@nb.njit(**JIT)
def _horner(c, n, x):
    y = c[n]
    for k in range(n - 1, -1, -1):
        y = y * x + c[k]
    return y


@nb.njit(**JIT)
def _bracketed_root(c, n, dc, x0, x1, f0):
    """Root of the polynomial (degree n, derivative dc) on [x0, x1] where it changes sign once.

    Newton steps kept inside a shrinking bracket, bisection when Newton misbehaves.
    """
    lo, hi = x0, x1
    flo = f0
    x = 0.5 * (lo + hi)
    for _ in range(100):
        f = _horner(c, n, x)
        if f == 0.0:
            return x
        if (f < 0.0) == (flo < 0.0):
            lo, flo = x, f
        else:
            hi = x
        df = _horner(dc, n - 1, x)
        step_ok = False
        if df != 0.0:
            xn = x - f / df
            if lo < xn < hi:
                step_ok = True
        if not step_ok:
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 4e-16 * (1.0 + abs(x)) or hi - lo <= 4e-16 * (1.0 + abs(x)):
            return xn
        x = xn
    return x


@nb.njit(**JIT)
def poly_real_roots(c, n, lo, hi, out, ws):
    """All real roots in [lo, hi] of the degree-n polynomial c (ascending); returns the count.

    Exact up to rounding: the roots of the k-th derivative split [lo, hi] into pieces on
    which the (k-1)-th derivative is monotone, so each piece holds at most one of its
    roots, found by a bracketed Newton iteration. Starting from the (n-1)-th derivative
    (linear) and going down to the polynomial itself isolates every real root.
    """
    # ws holds the derivatives (row k: the k-th, degree n - k), then break points and roots.
    w = n + 1
    derivs = ws[: w * w].reshape((w, w))
    for i in range(n + 1):
        derivs[0, i] = c[i]
    for k in range(1, n + 1):
        for i in range(n - k + 1):
            derivs[k, i] = derivs[k - 1, i + 1] * (i + 1)
    breaks = ws[w * w : w * w + n + 2]
    roots = ws[w * w + n + 2 : w * w + 2 * n + 3]
    n_roots = 0  # roots of derivs[k + 1] found so far (none for the constant)
    for k in range(n - 1, -1, -1):
        deg = n - k
        nb_ = 0
        breaks[nb_] = lo
        nb_ += 1
        for i in range(n_roots):
            if lo < roots[i] < hi:
                breaks[nb_] = roots[i]
                nb_ += 1
        breaks[nb_] = hi
        nb_ += 1
        new = 0
        ck = derivs[k]
        dk = derivs[k + 1]
        f0 = _horner(ck, deg, breaks[0])
        for i in range(nb_ - 1):
            x0, x1 = breaks[i], breaks[i + 1]
            f1 = _horner(ck, deg, x1)
            if f0 == 0.0:
                if new == 0 or roots[new - 1] != x0:
                    out[new] = x0
                    new += 1
            elif f1 != 0.0 and (f0 < 0.0) != (f1 < 0.0):
                out[new] = _bracketed_root(ck, deg, dk, x0, x1, f0)
                new += 1
            f0 = f1
        if f0 == 0.0:
            out[new] = breaks[nb_ - 1]
            new += 1
        for i in range(new):
            roots[i] = out[i]
        n_roots = new
    return n_roots


@nb.njit(**JIT)
def _pmul(a, na, b, nb_, out):
    for i in range(na + nb_ + 1):
        out[i] = 0.0
    for i in range(na + 1):
        for j in range(nb_ + 1):
            out[i + j] += a[i] * b[j]


@nb.njit(**JIT)
def _sextic(r2, s, t, w, out, s2, t2):
    """Set out = r2 * s^2 - w * t^2 for quadratics r2, s, t (ascending) and scalar w."""
    _pmul(s, 2, s, 2, s2)
    _pmul(t, 2, t, 2, t2)
    _pmul(r2, 2, s2, 4, out)
    for i in range(5):
        out[i] -= w * t2[i]
