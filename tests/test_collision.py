"""The printed-link collision model against the carved meshes it stands for.

Truth is independent of ``handarm.collision``: the carved link solids, placed by the URDF
frames, tested pair by pair with python-fcl and measured with manifold3d (``mesh_truth``).
"""

from __future__ import annotations

import dataclasses
import math

import fcl
import numpy as np
import pytest
from manifold3d import CrossSection, Manifold, OpType

import handarm
from handarm import collision, ik
from handarm.carve.properties import to_trimesh
from handarm.carve.sweep import frame_to_link
from handarm.links import link_blank
from mesh_truth import PAIRS, MeshArm


def other_design(seed: int) -> handarm.ArmDesign:
    """A legal design with other link lengths, beam, hubs and limits than the paper's."""
    rng = np.random.default_rng(seed)
    lim = np.radians(rng.uniform(60, 170, (6, 2)))
    return handarm.ArmDesign(
        name=f"other{seed}",
        link_lengths=rng.uniform(0.03, 0.07, 7),
        joint_limits=[(-lo, hi) for lo, hi in lim],
        beam_width=float(rng.uniform(0.008, 0.014)),
    )


DESIGNS = {"paper": handarm.ArmDesign(), "other1": other_design(1), "other2": other_design(2)}


@pytest.fixture(scope="module", params=list(DESIGNS))
def mesh_arm(request):
    return MeshArm(DESIGNS[request.param], resolution_deg=3.0)


def _stadium_prism(piece: collision.Piece, segments: int = 96) -> Manifold:
    """The piece as a solid (mm), its circles circumscribed so the solid contains the piece."""
    r = piece.radius * 1e3 / math.cos(math.pi / segments)
    a, b = piece.segment * 1e3
    circle = CrossSection.circle(r, segments)
    cs = CrossSection.batch_hull([circle.translate(tuple(a)), circle.translate(tuple(b))])
    z0, z1 = (z * 1e3 for z in piece.z)
    return cs.extrude(z1 - z0).translate([0.0, 0.0, z0])


def _envelope_solid(design, k: int) -> Manifold:
    """Union of link k's envelope pieces, in the link's frame (mm)."""
    blank = link_blank(design, k)
    solids = []
    for piece in collision.envelopes(design).pieces:
        if piece.link != k:
            continue
        m = frame_to_link(blank, "prox" if piece.frame == 0 else "dist")
        solids.append(_stadium_prism(piece).transform(m[:3, :4].tolist()))
    return Manifold.batch_boolean(solids, OpType.Add)


def test_envelopes_contain_the_carved_links(mesh_arm):
    design = mesh_arm.design
    for k, solid in enumerate(mesh_arm.solids):
        outside = (solid - _envelope_solid(design, k)).volume()
        assert outside < 1e-6 * solid.volume(), (design.name, k, outside)


def test_is_valid_never_accepts_overlapping_printed_links(mesh_arm):
    """No accepted configuration has two links in contact; few collision-free ones rejected."""
    design = mesh_arm.design
    q = np.random.default_rng(3).uniform(design.lower, design.upper, (600, 6))
    ok = handarm.is_valid(design, q)
    touching = np.array([bool(mesh_arm.contacts(qi)) for qi in q])
    assert not np.any(ok & touching), q[ok & touching][:3]
    # conservative, but not much: the target is 3 % over 20,000 configurations
    # (benchmarks/bench_collision_model.py); 600 samples get a looser bound
    free = ~touching
    assert np.sum(~ok & free) <= 0.06 * np.sum(free)


def test_colliding_pairs_name_the_pairs_that_touch(mesh_arm):
    """Every pair whose meshes overlap by more than 1 mm^3 is among the pairs reported."""
    design = mesh_arm.design
    q = np.random.default_rng(4).uniform(design.lower, design.upper, (300, 6))
    reported = handarm.colliding_pairs(design, q)
    assert reported.shape == (300, 15)
    np.testing.assert_array_equal(
        handarm.is_valid(design, q), ~reported.any(axis=1) & handarm.within_limits(design, q)
    )
    for i in range(len(q)):
        for a, b, _ in mesh_arm.colliding(q[i]):
            assert reported[i, collision.LINK_PAIRS.index((a, b))], (q[i], a, b)


def test_paper_example_is_rejected_and_overlaps():
    """The issue's example: accepted by the paper's model, l0 and l3 overlap in print."""
    design = handarm.ArmDesign()
    q = np.radians([107, 144, -77.7, -117.5, -33.5, 36.2])
    paper = dataclasses.replace(design, collision_model="paper")
    assert handarm.is_valid(paper, q)
    assert not handarm.is_valid(design, q)
    assert handarm.colliding_pairs(design, q)[collision.LINK_PAIRS.index((0, 3))]
    arm = MeshArm(design, resolution_deg=3.0)
    assert arm.overlap_volume(q, 0, 3) > 1000.0


def test_paper_model_is_the_segment_model():
    """collision_model = "paper" keeps the paper's zero-thickness same-plane segments."""
    design = dataclasses.replace(handarm.ArmDesign(), collision_model="paper")
    q = np.random.default_rng(5).uniform(design.lower, design.upper, (5000, 6))
    expected = handarm.within_limits(design, q) & ~handarm.link_crossings(design, q).any(axis=-1)
    np.testing.assert_array_equal(handarm.is_valid(design, q), expected)
    # the printed model is stricter: it never accepts what the paper's rejects for crossing
    printed = handarm.is_valid(handarm.ArmDesign(), q)
    assert not np.any(printed & ~expected)


def _piece_models(design):
    env = collision.envelopes(design)
    models = []
    for piece in env.pieces:
        mesh = to_trimesh(_stadium_prism(piece, 32))
        model = fcl.BVHModel()
        model.beginModel(len(mesh.vertices), len(mesh.faces))
        model.addSubModel(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
        model.endModel()
        models.append(model)
    return env, models


def test_kernel_never_misses_touching_envelopes():
    """Wherever two envelope solids intersect (fcl), the kernel reports their link pair."""
    design = handarm.ArmDesign()
    env, models = _piece_models(design)
    arm = MeshArm.__new__(MeshArm)
    arm.design = design
    q = np.random.default_rng(6).uniform(design.lower, design.upper, (400, 6))
    reported = handarm.colliding_pairs(design, q)
    blanks = [link_blank(design, k) for k in range(7)]
    request = fcl.CollisionRequest()
    for i in range(len(q)):
        tf = MeshArm.transforms(arm, q[i])
        objs = []
        for piece, model in zip(env.pieces, models, strict=True):
            m = tf[piece.link] @ frame_to_link(
                blanks[piece.link], "prox" if piece.frame == 0 else "dist"
            )
            objs.append(fcl.CollisionObject(model, fcl.Transform(m[:3, :3], m[:3, 3])))
        for x in range(len(objs)):
            for y in range(x + 1, len(objs)):
                la, lb = env.pieces[x].link, env.pieces[y].link
                if abs(la - lb) < 2:
                    continue
                if fcl.collide(objs[x], objs[y], request, fcl.CollisionResult()):
                    pair = (min(la, lb), max(la, lb))
                    assert reported[i, collision.LINK_PAIRS.index(pair)], (q[i], pair)


def test_every_returned_range_is_collision_free_for_the_meshes(mesh_arm):
    """Representatives and 50 points of every range of 30 targets: no two meshes touch."""
    design = mesh_arm.design
    rng = np.random.default_rng(8)
    q0 = rng.uniform(design.lower, design.upper, (400, 6))
    q0 = q0[handarm.is_valid(design, q0)][:30]
    p, e = handarm.forward(design, q0)
    checked = 0
    for pi, ei in zip(p, e, strict=True):
        r = ik.solve(design, pi, ei, degrade=False)
        assert r.count >= 1
        for k in range(r.count):
            lo, hi = r.intervals[k]
            qs = [r.solutions[k]]
            for u in np.linspace(lo, hi, 50):
                qs.append(ik.configuration_at(design, pi, ei, r.branches[k], u, azimuth=r.azimuth))
            for qk in qs:
                assert not mesh_arm.contacts(qk), (pi, ei, k, qk)
                checked += 1
    assert checked > 30 * 51


def test_pairs_are_the_non_adjacent_ones():
    assert collision.LINK_PAIRS == PAIRS


def test_serial_and_parallel_kernels_agree():
    """Small batches run on the calling thread, large ones in parallel: the same answers."""
    design = handarm.ArmDesign()
    q = np.random.default_rng(9).uniform(design.lower, design.upper, (4096, 6))
    whole = collision.collision_free(design, q)
    parts = np.concatenate(
        [collision.collision_free(design, q[i : i + 512]) for i in range(0, 4096, 512)]
    )
    np.testing.assert_array_equal(whole, parts)
    pairs = collision.printed_collisions(design, q)
    pairs_parts = np.concatenate(
        [collision.printed_collisions(design, q[i : i + 512]) for i in range(0, 4096, 512)]
    )
    np.testing.assert_array_equal(pairs, pairs_parts)
    np.testing.assert_array_equal(whole, ~pairs.any(axis=1))


@pytest.mark.parametrize("name", list(DESIGNS))
def test_link_reach_holds_every_piece_wherever_the_arm_is(name):
    """Placed by the URDF frames at any angles, each piece's bounding sphere stays within its
    link's reach of joint 1 (l0-l2) or joint 6 (l4-l6), and the reach is nearly attained."""
    design = DESIGNS[name]
    env = collision.envelopes(design)
    reach = collision.link_reach(design)
    assert sorted(reach) == [0, 1, 2, 4, 5, 6]
    blanks = [link_blank(design, k) for k in range(7)]
    arm = MeshArm.__new__(MeshArm)
    arm.design = design
    rng = np.random.default_rng(11)
    q = np.vstack([np.zeros(6), rng.uniform(-math.pi, math.pi, (400, 6))])
    seen = dict.fromkeys(reach, 0.0)
    for qi in q:
        tf = arm.transforms(qi)
        joint6 = tf[6][:3, 3]
        for i in range(len(env.link)):
            k = int(env.link[i])
            if k not in reach:
                continue
            frame = "prox" if env.frame[i] == 0 else "dist"
            mid = 0.5 * (env.seg[i, :2] + env.seg[i, 2:]) * 1e3
            centre = np.array([mid[0], mid[1], env.z[i].mean() * 1e3, 1.0])
            world = (tf[k] @ frame_to_link(blanks[k], frame) @ centre)[:3]
            anchor = np.zeros(3) if k <= 2 else joint6
            far = (np.linalg.norm(world - anchor) + env.sphere[i] * 1e3) * 1e-3
            assert far <= reach[k] + 1e-12, (name, k, far, reach[k])
            seen[k] = max(seen[k], far)
    for k in reach:
        assert seen[k] > 0.97 * reach[k], (k, seen[k], reach[k])


def test_far_groups_are_the_pairs_of_links_out_of_reach():
    """A group's threshold is its two links' reach and the clearance; only groups between
    l0-l2 and l4-l6 have one, and on FK targets whose joint 6 lies beyond it the link pair
    is never reported in contact."""
    design = handarm.ArmDesign()
    env = collision.envelopes(design)
    reach = collision.link_reach(design)
    far = collision.far_thresholds(design)
    for g, (bi, bj, _, _) in enumerate(env.groups):
        la, lb = int(env.link[bi]), int(env.link[bj])
        if la <= 2 and lb >= 4:
            assert far[g] == pytest.approx(reach[la] + reach[lb] + design.clearance)
        else:
            assert far[g] == np.inf
    q = np.random.default_rng(12).uniform(design.lower, design.upper, (20000, 6))
    joint6 = handarm.joint_positions(design, q)[:, 6]
    dist = np.linalg.norm(joint6, axis=1)
    pairs = collision.printed_collisions(design, q)
    excluded = 0
    for lp, (la, lb) in enumerate(collision.LINK_PAIRS):
        g0, g1 = env.lp_groups[lp]
        if g1 == g0 or not np.isfinite(far[g0:g1]).all():
            continue
        beyond = dist > far[g0:g1].max()
        excluded += beyond.sum()
        assert not pairs[beyond, lp].any(), (la, lb)
    assert excluded > 1000  # the thresholds leave groups out of many targets


@pytest.mark.parametrize("name", list(DESIGNS))
def test_pair_table_leaves_are_the_model(name):
    """Every FREE leaf of a joint-space table is free under the model and every HIT leaf
    in contact, at random configurations of several designs (asymmetric limits, other
    lengths and beams), and the tables decide almost every configuration."""
    from handarm import _pairtable as T

    design = DESIGNS[name]
    nodes, off, dom = collision.pair_tables(design)
    rng = np.random.default_rng(3)
    q = rng.uniform(design.lower, design.upper, (20000, 6))
    hits = collision.printed_collisions(design, q)
    stack, bounds = np.zeros(T.QUERY_STACK, np.int64), np.zeros((T.QUERY_STACK, 4))
    for k, lp in enumerate(collision.TABLE_PAIRS):
        box = [(x, x, y, y) for x, y in q[:, k : k + 2]]
        got = np.array([T.query_box(nodes, off[k], dom[k], *b, stack, bounds) for b in box])
        assert not np.any((got == T.FREE) & hits[:, lp]), (k, "FREE leaf in contact")
        assert not np.any((got == T.HIT) & ~hits[:, lp]), (k, "HIT leaf free")
        assert np.mean(got == T.UNSURE) < 0.02  # near a contact, within a cell


@pytest.mark.parametrize("name", list(DESIGNS))
def test_pair_table_boxes_hold_everywhere_in_them(name):
    """A box of joint angles that a table calls FREE (HIT) holds no configuration in
    contact (free): boxes of every size, checked at configurations spread over them."""
    from handarm import _pairtable as T

    design = DESIGNS[name]
    nodes, off, dom = collision.pair_tables(design)
    rng = np.random.default_rng(4)
    stack, bounds = np.zeros(T.QUERY_STACK, np.int64), np.zeros((T.QUERY_STACK, 4))
    decided = 0
    for k, lp in enumerate(collision.TABLE_PAIRS):
        for _ in range(150):
            width = 10.0 ** rng.uniform(-4, 0, 2)
            lo = rng.uniform(design.lower[k : k + 2], design.upper[k : k + 2] - width)
            hi = lo + width
            s = T.query_box(nodes, off[k], dom[k], lo[0], hi[0], lo[1], hi[1], stack, bounds)
            if s == T.UNSURE:
                continue
            decided += 1
            q = rng.uniform(design.lower, design.upper, (200, 6))
            q[:, k : k + 2] = rng.uniform(lo, hi, (200, 2))
            q[:4, k : k + 2] = [lo, hi, [lo[0], hi[1]], [hi[0], lo[1]]]  # the corners too
            hit = collision.printed_collisions(design, q)[:, lp]
            assert hit.all() if s == T.HIT else not hit.any(), (k, lo, hi, s)
    assert decided > 300


def _random_tree(rng, depth, kinds):
    """A random quadtree in the tables' layout (breadth first, children together)."""
    nodes = [None]
    level = [0]
    for d in range(depth):
        nxt = []
        for node in level:
            if d < depth - 1 and rng.random() < 0.7:
                nodes[node] = len(nodes)
                nxt += list(range(len(nodes), len(nodes) + 4))
                nodes += [None] * 4
            else:
                nodes[node] = int(rng.choice(kinds))
        level = nxt
    for node in level:
        nodes[node] = int(rng.choice(kinds))
    return np.array(nodes, np.int32)


@pytest.mark.parametrize("seed", range(6))
def test_a_collapsed_table_answers_every_box_as_before(seed):
    """Merging four leaves of one kind into their parent changes no answer of query_box:
    random trees (mostly FREE, some HIT, few MIXED), random boxes of every size."""
    from handarm import _pairtable as T

    rng = np.random.default_rng(seed)
    kinds = [-1] * 8 + [-2] * 3 + [-3] * (seed % 2)
    tree = _random_tree(rng, 6, kinds)
    merged = T._collapsed(tree)
    assert (merged != tree).any() or seed > 3  # the trees do merge
    stack, bounds = np.zeros(T.QUERY_STACK, np.int64), np.zeros((T.QUERY_STACK, 4))
    dom = np.array([0.0, 1.0, 0.0, 1.0])
    for _ in range(3000):
        w = 10.0 ** rng.uniform(-3, 0, 2)
        lo = rng.uniform(0.0, 1.0 - w)
        box = (lo[0], lo[0] + w[0], lo[1], lo[1] + w[1])
        assert T.query_box(merged, 0, dom, *box, stack, bounds) == T.query_box(
            tree, 0, dom, *box, stack, bounds
        )


def test_a_box_outside_its_table_is_unsure():
    from handarm import _pairtable as T

    design = handarm.ArmDesign()
    nodes, off, dom = collision.pair_tables(design)
    stack, bounds = np.zeros(T.QUERY_STACK, np.int64), np.zeros((T.QUERY_STACK, 4))
    lo, hi = design.lower[0], design.upper[0]
    assert T.query_box(nodes, off[0], dom[0], lo - 0.01, lo, 0.0, 0.0, stack, bounds) == T.UNSURE
    assert T.query_box(nodes, off[0], dom[0], 0.0, 0.0, 0.0, hi + 0.3, stack, bounds) == T.UNSURE


def _brute_cover_area(pts: np.ndarray) -> float:
    """Least stadium area over 360 axes and every segment end pair on a fine grid."""
    best = math.inf
    for th in np.radians(np.arange(0.0, 180.0, 0.5)):
        ax = np.array([math.cos(th), math.sin(th)])
        u, w = pts @ ax, pts @ np.array([-ax[1], ax[0]])
        mid = 0.5 * (w.max() + w.min())
        s = np.linspace(u.min(), u.max(), 41)
        s0, s1 = np.meshgrid(s, s, indexing="ij")
        ok = s0 <= s1
        s0, s1 = s0[ok], s1[ok]
        out = np.maximum(np.maximum(s0[:, None] - u, u - s1[:, None]), 0.0)
        r = np.sqrt((out**2 + (w - mid) ** 2).max(axis=1))
        best = min(best, float((2.0 * r * (s1 - s0) + math.pi * r * r).min()))
    return best


@pytest.mark.parametrize("seed", range(12))
def test_stadium_cover_holds_its_polygon_and_is_near_the_least(seed):
    """Every vertex within the radius of the segment, and an area within 12 % of a brute
    force over axes and segment ends (a rectangle: on its long middle line).

    Over 80 random polygons the cover's area is 0.3 % above the brute force's at the median,
    10.6 % at worst: only the principal axis and the longest edges are tried as axes."""
    from scipy.spatial import ConvexHull

    def area(seg, r):
        return 2.0 * r * float(np.linalg.norm(seg[1] - seg[0])) + math.pi * r * r

    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(int(rng.integers(4, 40)), 2)) * rng.uniform(0.5, 20.0, 2)
    pts = pts[ConvexHull(pts).vertices]
    seg, r = collision.stadium_cover(pts)
    ab = seg[1] - seg[0]
    t = np.clip((pts - seg[0]) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    assert np.linalg.norm(pts - (seg[0] + t[:, None] * ab), axis=1).max() <= r
    assert area(seg, r) <= 1.12 * _brute_cover_area(pts)
    turn = np.array([[math.cos(seed), math.sin(seed)], [-math.sin(seed), math.cos(seed)]])
    rect = np.array([[0.0, 0.0], [9.0, 0.0], [9.0, 2.0], [0.0, 2.0]]) @ turn + 3.0
    seg, r = collision.stadium_cover(rect)
    along = (seg[1] - seg[0]) @ turn.T  # in the rectangle's own axes
    assert abs(along[1]) <= 1e-9 * abs(along[0])
    np.testing.assert_allclose((0.5 * (seg[0] + seg[1]) - 3.0) @ turn.T, [4.5, 1.0], atol=1e-9)
    assert area(seg, r) <= 1.001 * _brute_cover_area(rect)


@pytest.mark.parametrize("name", list(DESIGNS))
def test_a_hint_orders_the_collision_tests_without_changing_the_verdict(name):
    """``collides`` (in the level-2 slide, its validity test) tests first the group that
    blocked the last configuration. Along random walks in joint space, each call taking the
    hint the last one left as a slide does, its verdict is ``collision_free``'s; after a hit
    the hint is a single group, and that group hits on its own."""
    from handarm import _collide

    design = DESIGNS[name]
    pi, pf, groups, _, rows, c = collision.kernel_env(design)
    frames, xy, stamp, coef, motion = _collide.scratch(len(pi))
    rng = np.random.default_rng(7)
    lo, hi = np.asarray(design.lower), np.asarray(design.upper)
    walks = [
        np.clip(rng.uniform(lo, hi) + np.cumsum(rng.normal(0, 0.05, (100, 6)), 0), lo, hi)
        for _ in range(20)
    ]
    q = np.concatenate(walks)
    free = collision.collision_free(design, q)
    hint = 0
    hits = 0
    for k in range(len(q)):
        hit, which = _collide.collides(
            q[k], design.lengths, pi, pf, groups, rows, c, frames, xy, stamp, coef, motion, hint
        )
        assert hit == (not free[k]), k
        if hit:
            hits += 1
            hint = g = int(which)
            assert g > 0 and g & (g - 1) == 0, g  # one group's bit
            _collide.place_frames(q[k], design.lengths, 0.0, frames)
            _collide.new_pose(stamp)
            alone, _ = _collide.groups_status(
                g, frames, stamp, xy, pi, pf, groups, rows, coef, motion, c
            )
            assert alone
    # the walks meet contacts often, and leave them: both verdicts were exercised
    assert 50 < hits < len(q) - 50, hits
