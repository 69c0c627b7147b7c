"""Payload and pulley sizing with cvxpy (the transmission's statics).

Static gravity torques are linear in the gravity vector g and in the payload m at the tool:
tau_joint = (A + m B) g, with A from the link masses, B from the tool point, for each
configuration. Motor torques are tau_motor = K^-T tau_joint.

(a) ``max_payload``: the largest m with every motor within its torque limit in every given
    configuration and for gravity along *any* direction (a hand may hold the arm any way up):
    max over unit g of |row_k (A + m B) g| is a Euclidean norm, so this is a second-order
    cone program. With a finite set of gravity directions it is a linear program.
(b) ``size_pulleys``: joint pulley radii r_j in a manufacturable range that maximise that
    payload while each joint keeps a minimum speed. K = S diag(r) / rho makes the motor
    torques linear in w = 1/r for a fixed payload, and the speed limit a lower bound on w,
    so each payload is a feasibility LP; bisection on the payload finds the best.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import cvxpy as cp
import numpy as np

from handarm.carve import carve
from handarm.carve.properties import to_trimesh
from handarm.design import ArmDesign
from handarm.kinematics import forward, is_valid, joint_frames
from handarm.transmission import coupling_matrix

__all__ = [
    "GRAVITY",
    "LinkMasses",
    "design_link_masses",
    "default_configurations",
    "gravity_directions",
    "gravity_terms",
    "max_payload",
    "size_pulleys",
    "PulleySizing",
    "carved_link_masses",
    "sizing_report",
]

GRAVITY = 9.81


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class LinkMasses:
    """Masses (kg) of links l1..l6 and their centres of mass in their link frames (m)."""

    masses: np.ndarray  # (6,)
    coms: np.ndarray  # (6, 3)
    source: str


def design_link_masses(design: ArmDesign) -> LinkMasses:
    """Estimate from the design: each link a solid beam a_k x beam_width x beam_thickness."""
    a = np.array(design.link_lengths[1:])
    masses = a * design.beam_width * design.beam_thickness * design.density
    coms = np.zeros((6, 3))
    coms[:, 0] = a / 2
    return LinkMasses(masses, coms, "design estimate (solid beams)")


def carved_link_masses(carve_result) -> LinkMasses:
    """Masses and centres of mass of the carved links l1..l6 (from their meshes)."""
    masses, coms = [], []
    density = carve_result.design.density
    for link in carve_result.links[1:]:
        mesh = to_trimesh(link.solid)
        masses.append(mesh.volume * 1e-9 * density)
        coms.append(np.asarray(mesh.center_mass) * 1e-3)
    return LinkMasses(np.array(masses), np.array(coms), "carved meshes")


def default_configurations(design: ArmDesign, n: int = 60, seed: int = 0) -> np.ndarray:
    """Valid configurations to check.

    The straight arm, arms stretched up and to the side, and ``n`` random valid ones
    (seeded).
    """
    rng = np.random.default_rng(seed)
    fixed = [np.zeros(6)]
    for q1, q4 in itertools.product((-1.0, 0.0, 1.0), (-1.0, 0.0, 1.0)):
        fixed.append(np.array([q1, 0, 0, q4, 0, 0]) * 0.5 * np.minimum(design.upper, 3.0))
    q = rng.uniform(design.lower, design.upper, (20 * n, 6))
    q = q[is_valid(design, q)][:n]
    out = np.concatenate([np.array(fixed), q])
    out = np.clip(out, design.lower, design.upper)
    return out[is_valid(design, out)]


def gravity_directions() -> np.ndarray:
    """26 unit directions: the faces, edges and corners of a cube."""
    dirs = [v for v in itertools.product((-1, 0, 1), repeat=3) if any(v)]
    d = np.array(dirs, dtype=float)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def gravity_terms(design: ArmDesign, q: np.ndarray, links: LinkMasses):
    """(A, B), each (n, 6, 3): joint torques (N m) = (A + m B) @ g for gravity g (m/s^2).

    A comes from the link masses, B per kilogram of payload at the tool point.
    """
    q = np.atleast_2d(q)
    frames = joint_frames(design, q)  # (n, 7, 4, 4): joints 1..6 and the tool
    origins = frames[:, :6, :3, 3]
    axes = frames[:, :6, :3, 2]
    # centre of mass of link i (1..6) in the base frame: link i's frame is joint i's frame
    coms = np.einsum("nikl,il->nik", frames[:, :6, :3, :3], links.coms) + origins
    tool = forward(design, q)[0]
    a = np.zeros((len(q), 6, 3))
    b = np.zeros((len(q), 6, 3))
    for j in range(6):
        for i in range(j, 6):
            a[:, j] += links.masses[i] * np.cross(axes[:, j], coms[:, i] - origins[:, j])
        b[:, j] = np.cross(axes[:, j], tool - origins[:, j])
    return a, b


def _cases(design, configurations, links):
    """Configurations, link masses and their gravity terms, with the defaults filled in."""
    q = (
        default_configurations(design)
        if configurations is None
        else np.atleast_2d(np.asarray(configurations, float))
    )
    links = design_link_masses(design) if links is None else links
    return (q, links, *gravity_terms(design, q, links))


def max_payload(
    design: ArmDesign,
    configurations=None,
    links: LinkMasses | None = None,
    *,
    safety: float = 0.5,
    directions=None,
) -> tuple[float, dict]:
    """Largest tool payload (kg) with every motor within ``safety`` x stall torque.

    Parameters
    ----------
    design : ArmDesign
    configurations : array-like, shape (n, 6), optional
        Configurations to hold (default ``default_configurations``).
    links : LinkMasses, optional
        Default: ``design_link_masses``.
    safety : float
        Fraction of the servo's stall torque a motor may use (0 < s <= 1).
    directions : array-like, shape (d, 3), optional
        Gravity directions; default every direction (a second-order cone per motor).

    Returns
    -------
    payload : float
        kg; 0 if even the bare arm overloads a motor (see ``info["overloaded"]``).
    info : dict
        The binding configuration and motor, the torque limit, the solver status.
    """
    if not 0.0 < safety <= 1.0:
        raise ValueError(f"safety: expected 0 < s <= 1, got {safety}")
    q, links, a, b = _cases(design, configurations, links)
    m_inv_t = np.linalg.inv(coupling_matrix(design)).T
    ma = np.einsum("kj,njx->nkx", m_inv_t, a) * GRAVITY
    mb = np.einsum("kj,njx->nkx", m_inv_t, b) * GRAVITY
    limit = safety * design.servo.stall_torque
    m = cp.Variable(nonneg=True)
    cons = []
    if directions is None:
        # max over unit g of |r . g| = ||r||: one cone per configuration and motor
        rows_a = ma.reshape(-1, 3)
        rows_b = mb.reshape(-1, 3)
        cons.append(cp.norm(rows_a + m * rows_b, 2, axis=1) <= limit)
    else:
        g = np.asarray(directions, float)
        ta = np.einsum("nkx,dx->nkd", ma, g).reshape(-1)
        tb = np.einsum("nkx,dx->nkd", mb, g).reshape(-1)
        cons.append(cp.abs(ta + m * tb) <= limit)
    problem = cp.Problem(cp.Maximize(m), cons)
    _solve(problem)
    bare = (
        np.linalg.norm(ma, axis=-1)
        if directions is None
        else np.abs(np.einsum("nkx,dx->nkd", ma, np.asarray(directions, float))).max(axis=-1)
    )
    info = {
        "torque_limit_Nm": limit,
        "status": problem.status,
        "configurations": len(q),
        "links": links.source,
        "overloaded": bool(bare.max() > limit),
    }
    if problem.status not in ("optimal", "optimal_inaccurate"):
        return 0.0, info
    payload = float(m.value)
    load = (
        np.linalg.norm(ma + payload * mb, axis=-1)
        if directions is None
        else np.abs(np.einsum("nkx,dx->nkd", ma + payload * mb, np.asarray(directions, float))).max(
            -1
        )
    )
    n, k = np.unravel_index(np.argmax(load), load.shape)
    info.update(binding_configuration=q[n].tolist(), binding_motor=int(k) + 1)
    return payload, info


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class PulleySizing:
    """Best joint pulley radii (m) and the payload (kg) they allow."""

    radii: np.ndarray
    payload: float
    min_speed: float
    radius_range: tuple[float, float]


def size_pulleys(
    design: ArmDesign,
    configurations=None,
    links: LinkMasses | None = None,
    *,
    safety: float = 0.5,
    radius_range: tuple[float, float] = (0.004, 0.020),
    min_speed: float = math.radians(180.0),
    directions=None,
    tolerance: float = 1e-4,
) -> PulleySizing:
    """Joint pulley radii in ``radius_range`` (m) that maximise the payload.

    Each joint turning alone must reach ``min_speed`` (rad/s) with the motors at no-load
    speed. A sequence of feasibility programs in w = 1/r (bisection on the payload, to
    ``tolerance`` kg). Gravity along every direction by default: each motor torque is a
    3-vector linear in w whose norm is the worst direction's torque (second-order cones,
    as ``max_payload``); with ``directions``, linear programs over those directions.
    """
    r_lo, r_hi = radius_range
    if not 0.0 < r_lo < r_hi:
        raise ValueError(f"radius_range: expected 0 < min < max, got {radius_range}")
    if min_speed <= 0:
        raise ValueError(f"min_speed: must be > 0, got {min_speed}")
    q, links, a, b = _cases(design, configurations, links)
    g = np.eye(3) if directions is None else np.asarray(directions, float)
    ta = np.einsum("njx,dx->ndj", a, g).reshape(-1, 6) * GRAVITY  # joint torques per case
    tb = np.einsum("njx,dx->ndj", b, g).reshape(-1, 6) * GRAVITY
    signs = np.array(design.routing_signs, dtype=float)
    s_inv_t = np.linalg.inv(signs).T
    rho = design.motor_pulley_radius
    limit = safety * design.servo.stall_torque
    # joint j alone moves motor k at |S_kj| r_j / rho times its speed: r_j <= omega rho / ...
    speed_w = min_speed * np.abs(signs).max(axis=0) / (design.servo.no_load_speed * rho)
    w_lo = np.maximum(1.0 / r_hi, speed_w)
    w_hi = np.full(6, 1.0 / r_lo)
    if np.any(w_lo > w_hi):
        j = int(np.argmax(w_lo - w_hi))
        raise ValueError(
            f"min_speed: joint {j + 1} cannot reach {math.degrees(min_speed):.0f} deg/s with "
            f"pulleys of at least {r_lo * 1e3:g} mm"
        )
    w = cp.Variable(6)

    def feasible(m: float):
        joint = ta + m * tb  # joint torques of every (configuration, direction) case
        # motor torques = rho * S^-T diag(w) tau_joint: linear in w for a fixed payload
        motor = rho * cp.multiply(joint, cp.reshape(w, (1, 6), order="C")) @ s_inv_t.T
        if directions is None:
            # rows are (configuration, x|y|z): gather each motor's 3-vector, bound its norm
            vec = cp.reshape(motor.T, (6 * len(q), 3), order="C")
            torque = [cp.norm(vec, 2, axis=1) <= limit]
        else:
            torque = [cp.abs(motor) <= limit]
        prob = cp.Problem(cp.Minimize(cp.sum(w)), [*torque, w >= w_lo, w <= w_hi])
        _solve(prob)
        return prob.status in ("optimal", "optimal_inaccurate"), w.value

    ok, best_w = feasible(0.0)
    if not ok:
        return PulleySizing(1.0 / w_lo, 0.0, min_speed, radius_range)
    lo, hi = 0.0, 0.1
    while True:
        ok, val = feasible(hi)
        if not ok:
            break
        lo, best_w, hi = hi, val, hi * 2
        if hi > 1e3:
            break
    while hi - lo > tolerance:
        mid = 0.5 * (lo + hi)
        ok, val = feasible(mid)
        if ok:
            lo, best_w = mid, val
        else:
            hi = mid
    return PulleySizing(1.0 / np.asarray(best_w), lo, min_speed, radius_range)


def sizing_report(
    design: ArmDesign,
    *,
    safety: float = 0.5,
    radius_range: tuple[float, float] = (0.004, 0.020),
    min_speed: float = math.radians(180.0),
    carve_links: bool = True,
    carving=None,
) -> dict:
    """The payload and pulley sizing of a design as a JSON-ready dict (``bridge size``).

    Parameters
    ----------
    design : ArmDesign
    safety : float
        Fraction of the servo's stall torque a motor may use (0 < s <= 1).
    radius_range : (float, float)
        Manufacturable joint pulley radii (m).
    min_speed : float
        Slowest acceptable speed of each joint turning alone (rad/s).
    carve_links : bool
        Take link masses from the carved meshes (coarse 2 degree carving); otherwise from
        solid beams of the design's cross-section.
    carving : CarveResult, optional
        Link masses from this carving (``handarm build`` passes its own) instead.

    Returns
    -------
    dict
        ``payload_kg`` (any gravity direction), ``binding_motor``, ``configurations``,
        ``link_masses_kg`` and their source, ``sized_joint_pulley_radii_mm`` and
        ``sized_payload_kg``, ``torque_limit_Nm``.
    """
    links = design_link_masses(design)
    if carving is not None:
        links = carved_link_masses(carving)
    elif carve_links:
        links = carved_link_masses(carve(design, 2.0))
    payload, info = max_payload(design, links=links, safety=safety)
    sized = size_pulleys(
        design, links=links, safety=safety, radius_range=radius_range, min_speed=min_speed
    )
    return {
        "torque_limit_Nm": info["torque_limit_Nm"],
        "link_masses_kg": links.masses.tolist(),
        "link_masses_from": links.source,
        "configurations": info["configurations"],
        "payload_kg": payload,
        "binding_motor": info.get("binding_motor"),
        "sized_joint_pulley_radii_mm": (sized.radii * 1000).tolist(),
        "sized_payload_kg": sized.payload,
        "sizing_gravity": "every gravity direction",
        "min_joint_speed_deg_s": math.degrees(min_speed),
    }


def _solve(problem) -> None:
    """Solve a cvxpy problem; a solver failure becomes RuntimeError (CLI exit status 3)."""
    try:
        problem.solve()
    except cp.SolverError as exc:
        raise RuntimeError(f"solver: cvxpy could not solve the sizing problem: {exc}") from None
