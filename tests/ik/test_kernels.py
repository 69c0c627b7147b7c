import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from handarm.ik import _common as C
from handarm.ik import _events as EV
from handarm.ik import _poly as PL

# well-scaled coefficients, as the event polynomials have: subnormal ones make near-triple
# roots at 0 that the companion-matrix reference itself misplaces by eps**(1/3)
coef = arrays(
    np.float64,
    7,
    elements=st.one_of(st.just(0.0), st.floats(1e-3, 10), st.floats(-10, -1e-3)),
)


@settings(max_examples=300, deadline=None)
@given(c=coef, lo=st.floats(-3, 0), width=st.floats(0.01, 3))
def test_poly_roots_match_companion_matrix(c, lo, width):
    c = c.copy()
    c[6] = 1.0  # monic sextic, as the boundary events are
    hi = lo + width
    out = np.empty(7)
    n = PL.poly_real_roots(c, 6, lo, hi, out, np.empty(C.WS_SIZE))
    ref = np.roots(c[::-1])
    real = np.sort(ref[np.abs(ref.imag) < 1e-7].real)
    # keep clearly interior simple roots; grazing double roots are ill-posed either way
    real = real[(real > lo + 1e-6) & (real < hi - 1e-6)]
    if len(real) > 1 and np.min(np.diff(real)) < 1e-5:
        return
    got = np.sort(out[:n])
    for r in real:
        assert len(got) and np.min(np.abs(got - r)) < 1e-7 * (1 + abs(r))
    for g in got:
        assert abs(np.polyval(c[::-1], g)) < 1e-6 * np.sum(np.abs(c) * (1 + abs(g)) ** np.arange(7))


def test_case7_roots_for_equal_lengths_solve_the_papers_equation():
    """Equal lengths: Q on l1 satisfies sin(phi) + sin(2 phi) = c (DESIGN.md section 3)."""
    # l1 along x (qa = 0): then Q = end of l3 on l1 means an isosceles fold
    b = 0.05
    for qb in np.radians([95, 100, 105, 110, 115]):
        # configuration: A = (b, 0), P = A + b w(qb); l3 from P along -w(qb)*... back to l1
        ax, ay = b, 0.0
        px, py = ax + b * np.cos(qb), ay + b * np.sin(qb)
        # choose l3's direction so that Q = P + b d lands on the x axis inside [0, b]
        # |Q - P| = b and Q_y = 0: Q_x = P_x - sqrt(b^2 - P_y^2)
        qx = px - np.sqrt(b * b - py * py)
        assert 0 < qx < b  # every chosen fold puts Q on l1: no case is skipped
        dx, dy = (qx - px) / b, (0 - py) / b
        # line through P along d; N is the foot from the origin
        t = px * dx + py * dy
        nx, ny = px - t * dx, py - t * dy
        buf = np.empty(C.MAX_CAND)
        tags = np.empty(C.MAX_CAND, np.int8)
        lim = np.array([-3.1, 3.1, -3.1, 3.1, -3.1, 3.1])
        n = EV.canonical_events(
            nx, ny, dx, dy, b, b, b, b, lim, -1.0, 1.0, buf, tags, np.empty(C.WS_SIZE), True
        )
        assert np.min(np.abs(buf[:n] - t)) < 1e-12


@settings(max_examples=200, deadline=None)
@given(q=arrays(np.float64, 6, elements=st.floats(-np.pi, np.pi)))
def test_polish_kernel_tool_point_and_jacobian_match_forward_kinematics(q):
    """The closed forms of the polish kernel against forward() and central differences."""
    import handarm
    from handarm.ik._polish import tool_point_and_jacobian

    design = handarm.ArmDesign()
    p, jac = np.empty(3), np.empty((3, 6))
    tool_point_and_jacobian(q, design.lengths, p, jac)
    np.testing.assert_allclose(p, handarm.forward(design, q)[0], atol=1e-15)
    h = 1e-6
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = h
        fd = (handarm.forward(design, q + dq)[0] - handarm.forward(design, q - dq)[0]) / (2 * h)
        np.testing.assert_allclose(jac[:, k], fd, atol=1e-9)


def test_polish_kernel_reaches_reachable_points_within_the_limits():
    """From a start near a configuration, the polish lands on its tool point, in limits;
    from afar, where it cannot, no configuration of a dense sample near its answer is
    nearer the target (a local minimum within the limits, not a premature stop)."""
    import handarm
    from handarm.ik._polish import polish_to_point

    design = handarm.ArmDesign()
    rng = np.random.default_rng(3)
    out = np.empty(6)
    lower, upper = design.lower, design.upper
    for _ in range(200):
        q = rng.uniform(lower, upper)
        target = handarm.forward(design, q)[0]
        start = np.clip(q + rng.normal(scale=0.2, size=6), lower, upper)
        err = polish_to_point(start, target, design.lengths, lower, upper, 500, out)
        assert err < 1e-9
        assert np.all(out >= lower) and np.all(out <= upper)
        np.testing.assert_allclose(handarm.forward(design, out)[0], target, atol=1e-9)
    for _ in range(50):
        target = rng.normal(size=3)
        target *= rng.uniform(0.3, 0.5) / np.linalg.norm(target)  # beyond the reach
        err = polish_to_point(
            rng.uniform(lower, upper), target, design.lengths, lower, upper, 500, out
        )
        assert err == pytest.approx(np.linalg.norm(handarm.forward(design, out)[0] - target))
        near = np.clip(out + rng.normal(scale=1e-3, size=(2000, 6)), lower, upper)
        dist = np.linalg.norm(handarm.forward(design, near)[0] - target, axis=1)
        assert dist.min() > err - 1e-9


def test_no_two_kernels_share_a_python_function():
    """numba's cache keys a kernel by its Python function: two dispatchers built from one
    function (a parallel and a serial build, say) share one cache entry, and in every later
    process both load whichever was saved last. ``count_many`` loaded its serial twin that
    way and counted on one core."""
    import importlib
    import pkgutil

    import numba

    import handarm

    owners = {}
    for info in pkgutil.walk_packages(handarm.__path__, "handarm."):
        if info.name.startswith("handarm.cli") or info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if isinstance(obj, numba.core.registry.CPUDispatcher):
                # one dispatcher imported under several names is fine; two are not
                owners.setdefault(id(obj.py_func), {})[id(obj)] = f"{info.name}.{name}"
    shared = [sorted(v.values()) for v in owners.values() if len(v) > 1]
    assert not shared, shared
    assert len(owners) > 50  # the walk found the kernels
