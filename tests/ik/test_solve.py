import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.ik.conftest import (
    HOSTILE_D3,
    generator_branch_and_u,
    random_design,
    valid_configurations,
)

import handarm
from handarm import ik


def test_fk_targets_are_solved_exactly_and_cover_their_generator(paper):
    """10000 targets from valid configurations: always solved, exact, generator inside."""
    rng = np.random.default_rng(0)
    q = valid_configurations(paper, rng, 10000)
    p, e = handarm.forward(paper, q)
    b = ik.solve_batch(paper, p, e)
    assert np.all(b.counts >= 1)
    rows = np.arange(b.solutions.shape[1])[None, :] < b.counts[:, None]
    sols = b.solutions[rows]
    target_p = np.repeat(p, b.counts, axis=0)
    target_e = np.repeat(e, b.counts, axis=0)
    p2, e2 = handarm.forward(paper, sols)
    np.testing.assert_allclose(p2, target_p, atol=1e-9, rtol=0)
    np.testing.assert_allclose(e2, target_e, atol=1e-9, rtol=0)
    assert handarm.is_valid(paper, sols).all()
    branch, u = generator_branch_and_u(paper, q)
    same = np.all(b.branches == branch[:, None, :], axis=-1) & rows
    inside = (b.intervals[..., 0] - 1e-9 <= u[:, None]) & (u[:, None] <= b.intervals[..., 1] + 1e-9)
    covered = np.any(same & inside, axis=1) | b.truncated
    assert covered.all(), np.flatnonzero(~covered)[:5]


@pytest.mark.parametrize("seed", [1, 2])
def test_random_designs_fk_targets(seed):
    rng = np.random.default_rng(seed)
    for _ in range(10):
        d = random_design(rng)
        q = valid_configurations(d, rng, 200)
        p, e = handarm.forward(d, q)
        b = ik.solve_batch(d, p, e)
        assert np.all(b.counts >= 1)
        branch, u = generator_branch_and_u(d, q)
        rows = np.arange(24)[None, :] < b.counts[:, None]
        same = np.all(b.branches == branch[:, None, :], axis=-1) & rows
        inside = (b.intervals[..., 0] - 1e-9 <= u[:, None]) & (
            u[:, None] <= b.intervals[..., 1] + 1e-9
        )
        assert np.all(np.any(same & inside, axis=1) | b.truncated)


def _dense_check(design, p, e, n=5000, tol=1e-9):
    """Sample u densely on every branch; validity by is_valid must match the ranges."""
    r = ik.solve(design, p, e, degrade=False)
    reach = design.lengths.sum()
    mismatches = 0
    for br in itertools.product((1, -1), repeat=3):
        coarse = np.linspace(-reach, reach, 20001)
        _, ok = ik.configurations_along(design, p, e, br, coarse, azimuth=r.azimuth)
        mine = r.intervals[np.all(r.branches == br, axis=1)]
        if not ok.any() and len(mine) == 0:
            continue
        step = coarse[1] - coarse[0]
        # the span where the branch exists, and every returned range
        ends = np.concatenate([coarse[ok], mine.reshape(-1)])
        u = np.linspace(ends.min() - step, ends.max() + step, n)
        q, ok = ik.configurations_along(design, p, e, br, u, azimuth=r.azimuth)
        valid = np.zeros(n, bool)
        valid[ok] = handarm.is_valid(design, q[ok])
        if ok.any():
            p2, e2 = handarm.forward(design, q[ok])
            np.testing.assert_allclose(p2, np.broadcast_to(p, p2.shape), atol=1e-9, rtol=0)
        inside = np.zeros(n, bool)
        near = np.zeros(n, bool)
        for lo, hi in mine:
            inside |= (u > lo) & (u < hi)
            near |= (np.abs(u - lo) < tol) | (np.abs(u - hi) < tol)
        mismatches += int(np.sum((inside != valid) & ~near))
    return mismatches


def _completeness(n_targets, seed):
    """n targets; 5000 samples of u per branch: no valid u outside a range, none invalid in."""
    rng = np.random.default_rng(seed)
    bad = []
    for k in range(n_targets):
        design = handarm.ArmDesign() if k % 2 == 0 else random_design(rng)
        if k % 3 == 0:  # arbitrary targets, mostly partly reachable
            p, e = rng.uniform(-0.25, 0.25, 3), rng.normal(size=3)
        else:
            q = valid_configurations(design, rng, 1)[0]
            p, e = handarm.forward(design, q)
        if _dense_check(design, p, e / np.linalg.norm(e)):
            bad.append(k)
    assert not bad


def test_completeness_by_dense_sampling():
    """Printed-link model (the default), paper's arm and random designs."""
    _completeness(60, 7)


@pytest.mark.slow
def test_completeness_by_dense_sampling_many():
    _completeness(600, 11)


def test_completeness_of_the_paper_model_by_dense_sampling():
    """collision_model = "paper" stays exact and complete too."""
    rng = np.random.default_rng(13)
    bad = []
    for k in range(60):
        design = (handarm.ArmDesign() if k % 2 == 0 else random_design(rng)).replace(
            collision_model="paper"
        )
        q = valid_configurations(design, rng, 1)[0]
        p, e = handarm.forward(design, q)
        if _dense_check(design, p, e):
            bad.append(k)
    assert not bad


def test_batch_equals_solve(paper):
    rng = np.random.default_rng(3)
    q = valid_configurations(paper, rng, 100)
    p, e = handarm.forward(paper, q)
    p = np.concatenate([p, rng.uniform(-0.3, 0.3, (100, 3)), [[0.1, 0.05, 0.05]]])
    e = np.concatenate([e, rng.normal(size=(100, 3)), [[0.0, 0.0, 1.0]]])
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    b = ik.solve_batch(paper, p, e)
    for i in range(len(p)):
        r = ik.solve(paper, p[i], e[i], degrade=False)
        assert b.counts[i] == r.count
        np.testing.assert_array_equal(b.solutions[i, : r.count], r.solutions)
        np.testing.assert_array_equal(b.branches[i, : r.count], r.branches)
        np.testing.assert_array_equal(b.intervals[i, : r.count], r.intervals)
        assert np.isnan(b.solutions[i, r.count :]).all()


def test_solve_batch_chunks_give_the_same_answer(paper):
    rng = np.random.default_rng(4)
    q = valid_configurations(paper, rng, 300)
    p, e = handarm.forward(paper, q)
    a = ik.solve_batch(paper, p, e)
    b = ik.solve_batch(paper, p, e, chunk=7)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_array_equal(a.solutions, b.solutions)


def test_solve_batch_iter_and_counts_match_solve_batch(paper):
    rng = np.random.default_rng(8)
    q = valid_configurations(paper, rng, 250)
    p, e = handarm.forward(paper, q)
    p = np.concatenate([p, rng.uniform(-0.3, 0.3, (250, 3))])
    e = np.concatenate([e, rng.normal(size=(250, 3))])
    whole = ik.solve_batch(paper, p, e)
    starts = []
    for start, part in ik.solve_batch_iter(paper, p, e, chunk=64):
        starts.append(start)
        np.testing.assert_array_equal(part.counts, whole.counts[start : start + 64])
        np.testing.assert_array_equal(part.solutions, whole.solutions[start : start + 64])
    assert starts == list(range(0, 500, 64))
    counts = ik.count_solutions(paper, p, e)
    np.testing.assert_array_equal(np.minimum(counts, ik.MAX_SOLUTIONS), whole.counts)


def test_configuration_at_any_u_inside_a_range(paper):
    rng = np.random.default_rng(5)
    for q0 in valid_configurations(paper, rng, 50):
        p, e = handarm.forward(paper, q0)
        r = ik.solve(paper, p, e)
        for br, (lo, hi) in zip(r.branches, r.intervals, strict=True):
            u = rng.uniform(lo, hi, 5)
            for uu in u:
                q = ik.configuration_at(paper, p, e, br, uu)
                p2, e2 = handarm.forward(paper, q)
                np.testing.assert_allclose(p2, p, atol=1e-9)
                np.testing.assert_allclose(e2, e, atol=1e-9)
                assert handarm.is_valid(paper, q)


def test_solutions_sorted_by_distance_to_current(paper):
    rng = np.random.default_rng(6)
    q0 = valid_configurations(paper, rng, 20)
    for q in q0:
        p, e = handarm.forward(paper, q)
        cur = q + rng.normal(scale=0.1, size=6)
        r = ik.solve(paper, p, e, current=cur)
        dist = np.sum((r.solutions - cur) ** 2, axis=1)
        assert np.all(np.diff(dist) >= 0)
        np.testing.assert_array_equal(r.nearest(cur), r.solutions[0])
        # follow: inside the ranges, at least as near to current as any midpoint
        assert np.sum((r.follow - cur) ** 2) <= dist[0] + 1e-15
        p2, e2 = handarm.forward(paper, r.follow)
        np.testing.assert_allclose(p2, p, atol=1e-9)
        assert handarm.is_valid(paper, r.follow)


@pytest.mark.parametrize("up", [1.0, -1.0])
def test_vertical_direction(paper, up):
    p = np.array([0.12, 0.05, 0.08 * up])
    e = np.array([0.0, 0.0, up])
    r = ik.solve(paper, p, e, degrade=False)
    assert r.vertical and r.count > 0
    p2, e2 = handarm.forward(paper, r.solutions)
    np.testing.assert_allclose(p2, np.broadcast_to(p, p2.shape), atol=1e-9)
    np.testing.assert_allclose(e2, np.broadcast_to(e, e2.shape), atol=1e-9)
    # without current: the documented azimuth (from joint 1 towards the target), if solvable
    assert math.isclose(r.azimuth, math.atan2(p[1], p[0]), abs_tol=1e-12)
    # with current: the azimuth of current's l3
    cur = r.solutions[-1]
    psi = float(np.angle(np.exp(1j * cur[:3].sum())))
    r2 = ik.solve(paper, p, e, current=cur, degrade=False)
    assert r2.vertical
    assert math.isclose(math.cos(r2.azimuth - psi), 1.0, abs_tol=1e-9)
    assert np.allclose(handarm.forward(paper, r2.solutions)[0], p, atol=1e-9)


@pytest.mark.parametrize(
    ("p", "e", "message"),
    [
        ([0.1, 0, 0], [0, 0, 0], "e: direction has zero length"),
        ([0.1, 0, np.nan], [1, 0, 0], "p: contains NaN"),
        ([0.1, 0, 0], [1, 0, np.inf], "e: contains NaN or infinite"),
        ([0.1, 0], [1, 0, 0], r"p: expected shape \(\.\.\., 3\)"),
        ([0.1, 0, 0], [[1, 0, 0]], r"e: expected shape \(3,\)"),
        ("abc", [1, 0, 0], "p: expected real numbers"),
        (["0.1", "0", "0.1"], [1, 0, 0], "p: expected real numbers, got strings"),
        ([0.1, 0, 0.05j], [1, 0, 0], "p: expected real numbers, got complex"),
        ([0.1, 0, 0.05], [True, False, True], "e: expected real numbers, got booleans"),
    ],
)
def test_bad_input_names_the_argument(paper, p, e, message):
    with pytest.raises(ValueError, match=message):
        ik.solve(paper, p, e)


@pytest.mark.filterwarnings("error")  # no ComplexWarning: refused, not converted
def test_complex_input_is_refused_everywhere(paper):
    """A complex array used to lose its imaginary part with only a warning."""
    q = np.radians([10, 20, 30, 40, 50, 60])
    p, e = handarm.forward(paper, q)
    calls = {
        "p": lambda: ik.solve(paper, p + 5j, e),
        "current": lambda: ik.solve(paper, p, e, current=q + 1j),
        "q": lambda: handarm.is_valid(paper, q + 100j),
        "P": lambda: ik.count_solutions(paper, [p + 1j], [e]),
        "E": lambda: ik.solve_batch(paper, [p], [e + 0j]),
        "branch": lambda: ik.configuration_at(paper, p, e, np.array([1, 1, 1]) + 0j, 0.0),
    }
    for name, call in calls.items():
        with pytest.raises(ValueError, match=f"^{name}: expected "):
            call()


@pytest.mark.parametrize("k", [0, 1, 2, 3, 5, 8, 13])
def test_at_the_vertical_threshold_every_path_agrees(paper, k):
    """e tilted by VERTICAL_EPS, give or take an ulp: vertical or not, the same everywhere.

    Python used hypot and the kernels sqrt(x^2 + y^2): at this tilt they disagreed, a solve
    the kernel did at a free azimuth was reported as not vertical, and configuration_at
    then rebuilt its ranges on another line (invalid poses).
    """
    from handarm.ik._common import VERTICAL_EPS

    p = np.array([-0.0873282353837029, -0.03949620267257718, 0.004612054374459974])
    rng = np.random.default_rng(k)
    for h in VERTICAL_EPS * (1.0 + np.arange(-4, 5) * 1.1e-16):
        phi = rng.uniform(-math.pi, math.pi)
        e = np.array([h * math.cos(phi), h * math.sin(phi), -1.0])
        r = ik.solve(paper, p, e, degrade=False)
        b = ik.solve_batch(paper, [p], [e])
        assert r.count == b.counts[0] == ik.count_solutions(paper, [p], [e])[0]
        assert r.vertical == bool(b.vertical[0])
        for br, (lo, hi), sol in zip(r.branches, r.intervals, r.solutions, strict=True):
            q = ik.configuration_at(paper, p, e, br, 0.5 * (lo + hi), result=r)
            assert handarm.is_valid(paper, q)
            np.testing.assert_allclose(q, sol, atol=1e-9)


@pytest.mark.parametrize("joint", [1, 4])
@pytest.mark.parametrize("angle", [1e-3, -4e-4, 2.5e-3, 1e-5])
def test_follow_holds_still_near_a_straight_elbow(paper, joint, angle):
    """current on the target, its elbow (joint 2 or 5) nearly straight: follow is current.

    A straight elbow ends a range on a reach circle, where the angle grows like the root
    of the distance to the end: the samples kept 1e-7 m off the end, a turn of 1e-3 rad.
    """
    q = np.array([0.3, 0.4, -0.4, 0.2, 0.3, 0.3])
    q[joint] = angle
    assert handarm.is_valid(paper, q)
    p, e = handarm.forward(paper, q)
    r = ik.solve(paper, p, e, current=q)
    assert r.reached_dof == 5 and not r.family_ended
    assert np.abs(r.follow - q).max() < 1e-6


def _at_two_limits(design, rng, n, same):
    """n valid configurations with two joints at a limit each: of one sub-problem or not."""
    out = []
    while len(out) < n:
        q = rng.uniform(design.lower, design.upper)
        if same:
            i, j = rng.choice(3, 2, replace=False) + 3 * rng.integers(2)
        else:
            i, j = rng.integers(3), 3 + rng.integers(3)
        for k in (i, j):
            q[k] = design.upper[k] if rng.random() < 0.5 else design.lower[k]
        if handarm.is_valid(design, q):
            out.append(q)
    return np.array(out)


@pytest.mark.parametrize("same", [True, False], ids=["one sub-problem", "one each"])
@pytest.mark.parametrize("model", ["printed", "paper"])
def test_two_joints_at_their_limits_are_solved(paper, same, model):
    """Where two limits meet, the valid set along u can be one point: it is a range.

    Rounding put the two limit events a hair apart either way; the wrong way (in a third
    of such poses) the point was dropped: no exact solution, and follow jumped.
    """
    design = paper.replace(collision_model=model)
    rng = np.random.default_rng(5 if same else 6)
    q = _at_two_limits(design, rng, 40, same)
    P, E = handarm.forward(design, q)
    br_q, u_q = generator_branch_and_u(design, q)
    counts = ik.count_solutions(design, P, E)
    for k in range(len(q)):
        r = ik.solve(design, P[k], E[k], current=q[k])
        assert r.reached_dof == 5 and r.count == counts[k]
        inside = [
            (b == br_q[k]).all() and lo - 1e-9 <= u_q[k] <= hi + 1e-9
            for b, (lo, hi) in zip(r.branches, r.intervals, strict=True)
        ]
        assert any(inside), (q[k].tolist(), r.intervals.tolist())
        assert handarm.is_valid(design, r.solutions).all()
        assert np.abs(r.follow - q[k]).max() < 1e-6 and not r.family_ended


def test_scale_check_follows_the_design_asked_about():
    """The reach each solve checks against is the design's own, whichever was solved before.

    (``solve`` keeps the last design's model and reach, found by identity.)
    """
    small = handarm.ArmDesign(link_lengths=(0.02,) * 7)  # 100 x its reach: 14 m
    large = handarm.ArmDesign(link_lengths=(0.3,) * 7)  # 210 m
    p = [20.0, 0.0, 0.0]
    for _ in range(2):
        with pytest.raises(ValueError, match=r"^p: .* x the arm's reach \(0\.14 m\)"):
            ik.solve(small, p, [1, 0, 0])
        assert ik.solve(large, p, [1, 0, 0]).reached_dof == 2
        # an equal design that is another object: the same answer
        again = handarm.ArmDesign(link_lengths=(0.3,) * 7)
        assert (
            ik.solve(again, [1.5, 0.3, 0.2], [1, 0, 0]).count
            == ik.solve(large, [1.5, 0.3, 0.2], [1, 0, 0]).count
        )


def test_bad_batch_row_is_named(paper):
    E = np.ones((5, 3))
    E[3] = 0
    with pytest.raises(ValueError, match=r"E\[3\]: direction has zero length"):
        ik.solve_batch(paper, np.zeros((5, 3)), E)
    with pytest.raises(ValueError, match="current: expected shape"):
        ik.solve(paper, [0.1, 0, 0], [1, 0, 0], current=[0, 0, 0])
    with pytest.raises(ValueError, match="branch: expected three signs"):
        ik.configuration_at(paper, [0.1, 0, 0], [1, 0, 0], (1, 0, 1), 0.0)


_POINTS = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)
_DIRECTIONS = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
    lambda v: np.linalg.norm(v) > 1e-6
)


def _check_no_nan(p, e, degrade):
    d = handarm.ArmDesign()
    r = ik.solve(d, p, e, degrade=degrade)
    for arr in (r.solutions, r.intervals):
        assert np.all(np.isfinite(arr))
    assert math.isfinite(r.position_error) and math.isfinite(r.direction_error)
    if r.count:
        p2, e2 = handarm.forward(d, r.solutions)
        np.testing.assert_allclose(p2, np.broadcast_to(r.achieved_position, p2.shape), atol=1e-9)
        np.testing.assert_allclose(e2, np.broadcast_to(r.achieved_direction, e2.shape), atol=1e-9)
        assert handarm.is_valid(d, r.solutions).all()


@settings(max_examples=150, deadline=None)
@given(p=_POINTS, e=_DIRECTIONS)
def test_never_a_nan(p, e):
    _check_no_nan(p, e, degrade=False)


@settings(max_examples=6, deadline=None)
@given(p=_POINTS, e=_DIRECTIONS)
def test_never_a_nan_degraded(p, e):
    """Degraded answers take about a second each: a few here, many under the slow marker."""
    _check_no_nan(p, e, degrade=True)


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(p=_POINTS, e=_DIRECTIONS)
def test_never_a_nan_degraded_many(p, e):
    _check_no_nan(p, e, degrade=True)


@pytest.mark.parametrize("field", ["solutions", "intervals", "achieved_position", "follow"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_number_never_leaves_solve(paper, monkeypatch, field, bad):
    """The guard behind "no NaN out of the IK" catches one bad number in any array."""
    import dataclasses

    from handarm.ik import api

    real = api._exact

    def spoiled(*args):
        r = real(*args)
        arr = np.array(getattr(r, field), dtype=float)
        arr.flat[arr.size // 2] = bad
        return dataclasses.replace(r, **{field: arr})

    monkeypatch.setattr(api, "_exact", spoiled)
    q = np.radians([10, 20, 30, 40, 50, 60])
    p, e = handarm.forward(paper, q)
    with pytest.raises(RuntimeError, match="non-finite number"):
        ik.solve(paper, p, e, current=q)


def _pinned_configurations(design, rng, n):
    """Valid configurations with one or two joints exactly at a limit (ranges end there)."""
    out = []
    while len(out) < n:
        q = rng.uniform(design.lower, design.upper, 6)
        for j in rng.choice(6, rng.integers(1, 3), replace=False):
            q[j] = design.lower[j] if rng.random() < 0.5 else design.upper[j]
        if handarm.is_valid(design, q):
            out.append(q)
    return np.array(out)


@pytest.mark.parametrize("seed", [3, 4])
def test_joints_at_their_limits_come_back_within_them(seed):
    """Every configuration out of solve, solve_batch and follow keeps the limits exactly.

    A range ending where a joint meets its limit had its angle there computed by
    trigonometry, an ulp or two beyond the limit: is_valid failed on the only configuration
    of a zero-length range (a hostile check, 2026-11-27), and on follow.
    """
    rng = np.random.default_rng(seed)
    designs = [handarm.ArmDesign()] + [random_design(rng) for _ in range(3)]
    for design in designs:
        q = _pinned_configurations(design, rng, 150)
        p, e = handarm.forward(design, q)
        b = ik.solve_batch(design, p, e)
        rows = np.arange(b.solutions.shape[1])[None, :] < b.counts[:, None]
        sols = b.solutions[rows]
        assert np.all((sols >= design.lower) & (sols <= design.upper))
        assert handarm.is_valid(design, sols).all()
        for k in range(len(q)):
            r = ik.solve(design, p[k], e[k], current=q[k])
            assert r.reached_dof == 5
            for c in [*r.solutions, r.follow]:
                assert np.all((c >= design.lower) & (c <= design.upper)), (k, c - design.upper)
                assert handarm.is_valid(design, c), k
            for br, (lo, hi) in zip(r.branches, r.intervals, strict=True):
                for u in (lo, hi):
                    c = ik.configuration_at(design, p[k], e[k], br, u, result=r)
                    assert np.all((c >= design.lower) & (c <= design.upper)), (k, u)


def test_a_zero_length_range_at_a_limit_keeps_it_in_a_scene():
    """The hostile check's case: follow was 2.2e-16 rad beyond joint 2's upper limit."""
    from handarm.scene import Scene

    design = handarm.ArmDesign(**HOSTILE_D3)
    scene = (
        Scene.empty()
        .with_sphere([0.008951885411488603, 0.0669263421838676, 0.0080239411369136],
                     0.006061149546941331, name="b0")
        .with_sphere([-0.08280406324508115, -0.034642154225851964, -0.002694350649308273],
                     0.011950746530424867, name="b1")
        .with_sphere([0.060003740762369695, -0.04517705175845483, -0.0026188451529271474],
                     0.009490578372525524, name="b2")
    )  # fmt: skip
    current = np.array([
        0.9513255201677383, 1.6540825079053763, -0.4815699318132387, 2.148560224540722,
        1.315546904745446e-08, -7.2143557794390745e-09,
    ])  # fmt: skip
    r = ik.solve(
        design, [-0.024313829295841943, 0.035658333239118496, 0.13039164259803115], [0, 0, 1],
        current=current, scene=scene, clearance=0.001,
    )  # fmt: skip
    assert r.reached_dof == 2
    assert np.all(r.follow <= design.upper) and handarm.is_valid(design, r.follow)
