import json
import math

import numpy as np
import pytest

import handarm
from handarm import ik
from handarm.workspace.maps import direction_set, reachability_map, symmetries
from handarm.workspace.scores import design_score, joint_sensitivity, map_scores, min_reach_check


@pytest.fixture(scope="module")
def design():
    return handarm.ArmDesign()


@pytest.fixture(scope="module")
def coarse(design):
    return reachability_map(design, 0.03, 36)


def test_direction_counts_are_known_without_building_them():
    """The arithmetic count and nearest counts agree with building and scanning every count."""
    from handarm.workspace.maps import _direction_bands, check_direction_count
    from handarm.workspace.maps import nearest_direction_counts as nearest

    valid = [n for n in range(4, 1100) if len(_direction_bands(n)) == n]
    for n in range(4, 1000):
        below = max(c for c in valid if c <= n)
        above = min(c for c in valid if c >= n)
        assert nearest(n) == (below, above), n
        if n in valid:
            check_direction_count(n)
        else:
            with pytest.raises(ValueError, match=f"^directions: {n} directions .* {below} and"):
                check_direction_count(n)
    with pytest.raises(ValueError, match="^directions: "):
        check_direction_count(10**18 + 1)  # at once, nothing built


def test_direction_set_is_even_and_mirror_symmetric():
    d = direction_set(100)
    assert len(d) == 100
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    for axis in (1, 2):
        m = d.copy()
        m[:, axis] *= -1
        assert {tuple(np.round(v, 12)) for v in m} == {tuple(np.round(v, 12)) for v in d}
    # spread: the mean direction is near zero and no two directions coincide
    assert np.linalg.norm(d.mean(axis=0)) < 0.05
    dots = d @ d.T - 2 * np.eye(len(d))
    assert dots.max() < 0.99


def test_mirrored_map_equals_the_full_computation(design):
    paper = design.replace(collision_model="paper")  # its segments are mirror-invariant
    half = reachability_map(paper, 0.03, 36)
    assert half.mirrored == (True, True)
    full = reachability_map(paper, 0.03, 36, use_symmetry=False)
    assert full.mirrored == (False, False)
    np.testing.assert_array_equal(half.index, full.index)
    np.testing.assert_array_equal(half.mean_solutions, full.mean_solutions)
    assert half.queries * 3.5 < full.queries


@pytest.mark.parametrize("model", ["printed", "paper"])
def test_a_claimed_mirror_is_one_of_the_collision_model(design, model):
    """Mirroring is claimed only where is_valid really is mirror-invariant.

    The default printed forks carry their idler stacks on one side, so the printed arm is
    not its own mirror image: the map must not be mirrored for it.
    """
    d = design.replace(collision_model=model)
    q = np.random.default_rng(4).uniform(d.lower, d.upper, (20000, 6))
    ok = handarm.is_valid(d, q)
    claims = symmetries(d)
    for claim, flip in zip(claims, ([-1, -1, -1, 1, 1, 1], [1, 1, 1, -1, -1, -1]), strict=True):
        same = np.array_equal(ok, handarm.is_valid(d, q * np.array(flip)))
        assert same or not claim
    if model == "printed":
        assert claims == (False, False)
        assert reachability_map(d, 0.05, 16).mirrored == (False, False)


def test_asymmetric_limits_are_not_mirrored(design):
    d = design.replace(
        joint_limits=((-2.0, 1.0),) + design.joint_limits[1:], collision_model="paper"
    )
    assert symmetries(d) == (False, True)
    m = reachability_map(d, 0.05, 16)
    assert m.mirrored == (False, True)


def test_map_agrees_with_direct_ik_queries(design, coarse, rng):
    c = coarse.centres
    inside = np.argwhere(coarse.reachable)
    picks = inside[rng.choice(len(inside), 30, replace=False)]
    for i, j, k in picks:
        p = np.array([c[i], c[j], c[k]])
        # ranges narrower than the map's min_width do not count (a printed arm cannot hold
        # them): the direct solver's intervals are filtered by width here
        counts = []
        for e in coarse.directions:
            iv = ik.solve(design, p, e, degrade=False).intervals
            counts.append(int(np.sum(iv[:, 1] - iv[:, 0] >= coarse.min_width)) if len(iv) else 0)
        assert coarse.index[i, j, k] == pytest.approx(np.mean(np.array(counts) > 0))
        assert coarse.mean_solutions[i, j, k] == pytest.approx(np.mean(counts), rel=1e-6)


def test_nothing_outside_the_reach_sphere(coarse):
    c = coarse.centres
    gx, gy, gz = np.meshgrid(c, c, c, indexing="ij")
    r = np.sqrt(gx**2 + gy**2 + gz**2)
    assert not coarse.reachable[r > coarse.reach + coarse.voxel].any()
    assert ((coarse.index >= 0) & (coarse.index <= 1)).all()


def test_npz_round_trip(coarse, tmp_path):
    path = coarse.save_npz(tmp_path / "m.npz")
    with np.load(path) as z:
        np.testing.assert_array_equal(z["index"], coarse.index)
        assert float(z["voxel"]) == coarse.voxel


def test_scores(coarse, design):
    s = map_scores(coarse)
    cell = coarse.voxel**3
    assert s["reachable_volume_m3"] == pytest.approx(coarse.reachable.sum() * cell)
    assert 0 < s["dexterous_volume_m3"] < s["reachable_volume_m3"] < s["reference_volume_m3"]
    # litres, not fractions of the design's own reach sphere (that rewarded small arms)
    assert design_score(s, 0.07, 5e-5) == pytest.approx(
        (s["reachable_volume_m3"] + s["dexterous_volume_m3"]) * 1e3 - 0.35
    )
    bigger = dict(s, reference_volume_m3=8 * s["reference_volume_m3"])
    assert design_score(bigger, 0.07, 5e-5) == design_score(s, 0.07, 5e-5)
    with pytest.raises(ValueError, match="weights: unknown weight 'speed'"):
        design_score(s, 0.07, 5e-5, {"speed": 1})
    with pytest.raises(ValueError, match="threshold"):
        map_scores(coarse, 0.0)


def test_paper_minimum_reach(design):
    check = min_reach_check(design)
    for section in ("base", "tip"):
        c = check[section]
        assert c["paper_formula_m"] == pytest.approx(2 * 0.05 * math.sin(math.radians(15)))
        assert c["agrees"]
        assert c["measured_m"] == pytest.approx(c["paper_formula_m"], abs=1e-6)
    json.dumps(check)


def test_joint_sensitivity_structure(design):
    s = joint_sensitivity(design, delta_deg=20, voxel=0.05, directions=16)
    assert [r["joint"] for r in s["joints"]] == [1, 2, 3, 4, 5, 6]
    # taking range away never adds workspace
    assert all(r["reachable_m3_per_deg"] >= 0 for r in s["joints"])
    assert 1 <= len(s["most_sensitive_reachable"]) <= 2
    for j in s["most_sensitive_reachable"]:
        assert s["joints"][j - 1]["reachable_m3_per_deg"] > 0
    json.dumps(s)


def test_maps_record_their_collision_model_and_printed_is_stricter(design, coarse, tmp_path):
    """The printed-link model only removes solutions: no voxel gains reach, none gains ranges."""
    import dataclasses

    paper = reachability_map(dataclasses.replace(design, collision_model="paper"), 0.03, 36)
    assert (coarse.collision_model, paper.collision_model) == ("printed", "paper")
    assert not np.any(coarse.reachable & ~paper.reachable)
    assert np.all(coarse.index <= paper.index + 1e-12)
    assert coarse.index.sum() < paper.index.sum()  # the printed links do cost reach
    with np.load(coarse.save_npz(tmp_path / "m.npz")) as z:
        assert str(z["collision_model"]) == "printed"
