"""Numba kernel: bring the tool point of a configuration to a target point, within limits.

Degradation polishes configurations towards a target point (levels 3 and 2, and the
stretched arm at level 5). The problem is small (3 residuals, 6 joints, box bounds), so a
projected Levenberg-Marquardt step in closed form replaces a general solver: a step is
``dq = -J_f^T (J_f J_f^T + lam I)^-1 r`` over the free joints (those not held at a bound by
the gradient), clipped to the limits, accepted when it lowers |r|. The damping is plain
(lam I): a scaled one (Marquardt's diagonal) turns the large residual of a point beyond the
reach, along the stretched arm where J J^T is singular, into useless bending steps. The
tool point and its Jacobian are the closed forms of ``handarm.kinematics`` (see its module
doc): with t_k = q1 + .. + qk, s_k = q4 + .. + qk and psi = t_3,

    j4 = sum_{k=1..3} a_k (cos t_k, sin t_k),   u = sum_{k=4..6} a_k cos s_k,
    v = sum_{k=4..6} a_k sin s_k,              p = (j4 + u (cos psi, sin psi), v).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from handarm.ik._common import JIT


@nb.njit(**JIT)
def _chain(q, a):
    """(t1, t2, t3, s1, s2, s3, u, v) of q: the summed angles and the tip plane's (u, v)."""
    t1 = q[0]
    t2 = t1 + q[1]
    t3 = t2 + q[2]
    s1 = q[3]
    s2 = s1 + q[4]
    s3 = s2 + q[5]
    u = a[4] * math.cos(s1) + a[5] * math.cos(s2) + a[6] * math.cos(s3)
    v = a[4] * math.sin(s1) + a[5] * math.sin(s2) + a[6] * math.sin(s3)
    return t1, t2, t3, s1, s2, s3, u, v


@nb.njit(**JIT)
def tool_point_and_jacobian(q, a, p, jac):
    """Fill p (3,) with the tool point of q and jac (3, 6) with dp/dq."""
    t1, t2, t3, s1, s2, s3, u, v = _chain(q, a)
    c1, n1 = math.cos(t1), math.sin(t1)
    c2, n2 = math.cos(t2), math.sin(t2)
    c3, n3 = math.cos(t3), math.sin(t3)
    p[0] = a[1] * c1 + a[2] * c2 + a[3] * c3 + u * c3
    p[1] = a[1] * n1 + a[2] * n2 + a[3] * n3 + u * n3
    p[2] = v
    # joints 1..3: the base chain from joint j on, and the tip plane turning about z
    tail_x = -(a[3] + u) * n3
    tail_y = (a[3] + u) * c3
    jac[0, 2], jac[1, 2] = tail_x, tail_y
    jac[0, 1], jac[1, 1] = tail_x - a[2] * n2, tail_y + a[2] * c2
    jac[0, 0], jac[1, 0] = jac[0, 1] - a[1] * n1, jac[1, 1] + a[1] * c1
    jac[2, 0] = jac[2, 1] = jac[2, 2] = 0.0
    # joints 4..6: in the tip plane, (du, dv) lifted along (cos psi, sin psi, 1)
    du, dv = 0.0, 0.0
    for j in range(5, 2, -1):
        s = s1 if j == 3 else (s2 if j == 4 else s3)
        du -= a[j + 1] * math.sin(s)
        dv += a[j + 1] * math.cos(s)
        jac[0, j], jac[1, j], jac[2, j] = du * c3, du * n3, dv


@nb.njit(**JIT)
def tool_pose(q, a, out):
    """Fill out (8,) with the tool point (3), tool direction (3) and joint 4's (x, y) of q."""
    t1, t2, t3, _, _, s3, u, v = _chain(q, a)
    c3, n3 = math.cos(t3), math.sin(t3)
    jx = a[1] * math.cos(t1) + a[2] * math.cos(t2) + a[3] * c3
    jy = a[1] * math.sin(t1) + a[2] * math.sin(t2) + a[3] * n3
    out[0], out[1], out[2] = jx + u * c3, jy + u * n3, v
    cs = math.cos(s3)
    out[3], out[4], out[5] = cs * c3, cs * n3, math.sin(s3)
    out[6], out[7] = jx, jy


@nb.njit(**JIT)
def _solve3(m, b, x):
    """X = m^-1 b for a symmetric positive definite 3 x 3 m (Cholesky); False if singular."""
    l00 = m[0, 0]
    if l00 <= 0.0:
        return False
    l00 = math.sqrt(l00)
    l10 = m[1, 0] / l00
    l20 = m[2, 0] / l00
    d1 = m[1, 1] - l10 * l10
    if d1 <= 0.0:
        return False
    l11 = math.sqrt(d1)
    l21 = (m[2, 1] - l20 * l10) / l11
    d2 = m[2, 2] - l20 * l20 - l21 * l21
    if d2 <= 0.0:
        return False
    l22 = math.sqrt(d2)
    y0 = b[0] / l00
    y1 = (b[1] - l10 * y0) / l11
    y2 = (b[2] - l20 * y0 - l21 * y1) / l22
    x[2] = y2 / l22
    x[1] = (y1 - l21 * x[2]) / l11
    x[0] = (y0 - l10 * x[1] - l20 * x[2]) / l00
    return True


@nb.njit(**JIT)
def polish_to_point(q0, target, a, lower, upper, max_iter, out):
    """Configuration (into ``out``) within [lower, upper] whose tool point is nearest target.

    A local search from ``q0`` (clipped to the limits): projected Levenberg-Marquardt
    until |r| < 1e-13 m, no step lowers |r| any more, or ``max_iter`` steps. Returns the
    final distance |p(out) - target| (m). Collisions are not considered here.
    """
    q = np.empty(6)
    for j in range(6):
        q[j] = min(max(q0[j], lower[j]), upper[j])
    p = np.empty(3)
    jac = np.empty((3, 6))
    trial = np.empty(6)
    pt = np.empty(3)
    jt = np.empty((3, 6))
    r = np.empty(3)
    m = np.empty((3, 3))
    y = np.empty(3)
    free = np.empty(6, np.bool_)
    tool_point_and_jacobian(q, a, p, jac)
    for i in range(3):
        r[i] = p[i] - target[i]
    cost = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    lam = 1e-6
    for _ in range(max_iter):
        if cost < 1e-26:
            break
        # joints held at a bound by the gradient g = J^T r stay there
        for j in range(6):
            g = jac[0, j] * r[0] + jac[1, j] * r[1] + jac[2, j] * r[2]
            free[j] = not ((q[j] <= lower[j] and g > 0.0) or (q[j] >= upper[j] and g < 0.0))
        accepted = False
        while lam < 1e12:
            for i in range(3):
                for k in range(3):
                    acc = 0.0
                    for j in range(6):
                        if free[j]:
                            acc += jac[i, j] * jac[k, j]
                    m[i, k] = acc
                m[i, i] += lam
            if not _solve3(m, r, y):
                lam *= 10.0
                continue
            step = 0.0
            for j in range(6):
                dq = 0.0
                if free[j]:
                    dq = -(jac[0, j] * y[0] + jac[1, j] * y[1] + jac[2, j] * y[2])
                trial[j] = min(max(q[j] + dq, lower[j]), upper[j])
                step = max(step, abs(trial[j] - q[j]))
            if step < 1e-15:
                break
            tool_point_and_jacobian(trial, a, pt, jt)
            c = 0.0
            for i in range(3):
                c += (pt[i] - target[i]) ** 2
            if c < cost:
                q[:] = trial
                p[:] = pt
                jac[:, :] = jt
                for i in range(3):
                    r[i] = p[i] - target[i]
                cost = c
                lam = max(lam / 5.0, 1e-12)
                accepted = True
                break
            lam *= 4.0
        if not accepted:
            break
    out[:] = q
    return math.sqrt(cost)


@nb.njit(**JIT)
def least_motion(q, a, p, e):
    """|pinv(J) dx|: the least joint motion taking q's pose to (p, e) to first order (rad).

    J (6 x 6) stacks the tool point's Jacobian and the tool direction's (e = (cos s6 cos
    psi, cos s6 sin psi, sin s6) turns with psi = t_3 and s6 = s_6, so its rows have rank
    2); dx is the difference of the poses. Singular values under 1e-6 of the largest are
    dropped, as a damped controller would.
    """
    here = np.empty(3)
    jac = np.zeros((6, 6))
    tool_point_and_jacobian(q, a, here, jac[:3])
    psi = q[0] + q[1] + q[2]
    s6 = q[3] + q[4] + q[5]
    cp, sp, cs, ss = math.cos(psi), math.sin(psi), math.cos(s6), math.sin(s6)
    for j in range(3):
        jac[3, j], jac[4, j], jac[5, j] = -cs * sp, cs * cp, 0.0
        jac[3, j + 3], jac[4, j + 3], jac[5, j + 3] = -ss * cp, -ss * sp, cs
    dx = np.empty(6)
    dx[:3] = p - here
    dx[3], dx[4], dx[5] = e[0] - cs * cp, e[1] - cs * sp, e[2] - ss
    u, s, vt = np.linalg.svd(jac)
    dq = np.zeros(6)
    for k in range(6):
        if s[k] > 1e-6 * s[0]:
            dq += vt[k] * (u[:, k] @ dx) / s[k]
    return math.sqrt(dq @ dq)
