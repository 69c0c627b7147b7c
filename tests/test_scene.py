"""Obstacles: the scene model and the IK with a scene, against the carved meshes and fcl."""

from __future__ import annotations

import json

import fcl
import numpy as np
import pytest
import trimesh

import handarm
from handarm import ik
from handarm.scene import Scene, rpy_matrix, scene_free, scene_gaps
from mesh_truth import MeshArm


@pytest.fixture(scope="module")
def design():
    return handarm.ArmDesign()


@pytest.fixture(scope="module")
def arm(design):
    return MeshArm(design, resolution_deg=3.0)


def random_scene(rng, n=3) -> Scene:
    """Obstacles of every kind near the arm's workspace."""
    s = Scene.empty()
    for _ in range(n):
        kind = rng.integers(3)
        c = rng.uniform([-0.05, -0.2, -0.15], [0.25, 0.2, 0.15])
        if kind == 0:
            s = s.with_sphere(c, rng.uniform(0.005, 0.03))
        elif kind == 1:
            s = s.with_capsule(c, c + rng.normal(size=3) * 0.04, rng.uniform(0.003, 0.015))
        else:
            s = s.with_box(rng.uniform(0.01, 0.06, 3), c, rng.uniform(-3, 3, 3))
    return s


def _bvh(mesh: trimesh.Trimesh) -> fcl.BVHModel:
    model = fcl.BVHModel()
    model.beginModel(len(mesh.vertices), len(mesh.faces))
    model.addSubModel(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
    model.endModel()
    return model


def _fitted(mesh: trimesh.Trimesh, core: np.ndarray, radius: float, fit: str) -> trimesh.Trimesh:
    """A convex tessellation of a swept sphere, inside it or scaled until it holds it."""
    if fit == "inside":
        return mesh
    normals = mesh.face_normals
    v0 = mesh.vertices[mesh.faces[:, 0]]
    inradius = min(np.min(np.einsum("ij,ij->i", normals, v0 - c)) for c in core)
    grow = radius / inradius
    centre = core.mean(axis=0)
    out = mesh.copy()
    # spheres scale about the centre; capsules scale only across their axis
    if len(core) == 1:
        out.vertices = centre + (mesh.vertices - centre) * grow
    else:
        length = np.linalg.norm(core[1] - core[0])
        axis = (core[1] - core[0]) / length
        rel = mesh.vertices - centre
        spine = np.outer(np.clip(rel @ axis, -length / 2, length / 2), axis)
        out.vertices = centre + spine + (rel - spine) * grow
    return out


def fcl_obstacles(scene: Scene, fit: str = "inside") -> list:
    """The scene as (fcl object, inside test, trimesh) triples, in millimetres (the meshes' unit).

    fcl's mesh-to-primitive distance returns garbage (about 1e-320) for some poses, so every
    obstacle is a triangle mesh too. Boxes are exact; spheres and capsules are tessellated
    ``inside`` the true shape (distances at least the true ones) or scaled to hold it
    (``outside``: distances at most the true ones). The inside test (points in mm, world)
    is the exact primitive, for a link that lies wholly within an obstacle.
    """
    objs = []
    for row in scene.obstacles:
        kind = int(row[0])
        if kind == 0:
            c, r = row[1:4] * 1e3, row[4] * 1e3
            mesh = trimesh.creation.icosphere(4, r)
            mesh = _fitted(mesh, np.zeros((1, 3)), r, fit)
            mesh.apply_translation(c)

            def inside(pts, c=c, r=r):
                return np.linalg.norm(pts - c, axis=1) <= r

        elif kind == 1:
            a, b, r = row[1:4] * 1e3, row[4:7] * 1e3, row[7] * 1e3
            axis = b - a
            length = np.linalg.norm(axis)
            z = axis / length
            x = np.cross(z, [1.0, 0, 0] if abs(z[0]) < 0.9 else [0, 1.0, 0])
            x /= np.linalg.norm(x)
            tf = np.eye(4)
            tf[:3, :3] = np.column_stack([x, np.cross(z, x), z])
            tf[:3, 3] = (a + b) / 2
            mesh = trimesh.creation.capsule(height=length, radius=r, count=[64, 64])
            core = np.array([[0, 0, -length / 2], [0, 0, length / 2]])
            mesh = _fitted(mesh, core, r, fit)
            mesh.apply_transform(tf)

            def inside(pts, a=a, b=b, r=r):
                t = np.clip((pts - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
                return np.linalg.norm(pts - (a + t[:, None] * (b - a)), axis=1) <= r

        else:
            rot, c, half = row[4:13].reshape(3, 3), row[1:4] * 1e3, row[13:16] * 1e3
            tf = np.eye(4)
            tf[:3, :3], tf[:3, 3] = rot, c
            mesh = trimesh.creation.box(2 * half, tf)

            def inside(pts, rot=rot, c=c, half=half):
                return np.all(np.abs((pts - c) @ rot) <= half, axis=1)

        objs.append((fcl.CollisionObject(_bvh(mesh)), inside, mesh))
    return objs


def mesh_distance(arm: MeshArm, q, obstacles) -> float:
    """Smallest distance (m) between any carved link and any obstacle (0 on contact)."""
    tf = arm.transforms(q)
    best = np.inf
    for model, mesh, t in zip(arm.models, arm.meshes, tf, strict=True):
        link = fcl.CollisionObject(model, fcl.Transform(t[:3, :3], t[:3, 3]))
        verts = mesh.vertices @ t[:3, :3].T + t[:3, 3]
        for ob, inside, ob_mesh in obstacles:
            if fcl.collide(link, ob, fcl.CollisionRequest(), fcl.CollisionResult()):
                return 0.0
            local = (ob_mesh.vertices[0] - t[:3, 3]) @ t[:3, :3]
            if inside(verts[:1]).any() or mesh.contains(local[None])[0]:
                return 0.0  # one wholly inside the other: no surfaces cross
            best = min(best, fcl.distance(link, ob, fcl.DistanceRequest(), fcl.DistanceResult()))
    return best * 1e-3


def test_gaps_never_exceed_the_mesh_distance(design, arm):
    """The arm model covers the printed links: its gap is at most the true distance."""
    rng = np.random.default_rng(1)
    for _ in range(15):
        scene = random_scene(rng)
        obstacles = fcl_obstacles(scene, "inside")
        q = rng.uniform(design.lower, design.upper, (20, 6))
        gaps = scene_gaps(design, q, scene).min(axis=-1)
        for qi, g in zip(q, gaps, strict=True):
            assert g <= mesh_distance(arm, qi, obstacles) + 1e-9


def test_gap_of_each_shape_against_a_brute_force(design):
    """Exact distances: a single capsule-covered piece against sampled obstacle surfaces."""
    from handarm import _scene

    rng = np.random.default_rng(2)
    for _ in range(80):
        a, b = rng.normal(size=3) * 0.05, rng.normal(size=3) * 0.05
        size = rng.uniform(0.01, 0.05, 3)
        box = Scene.empty().with_box(size, rng.normal(size=3) * 0.05, rng.uniform(-3, 3, 3))
        row = box.obstacles[0]
        got = _scene.segment_box(*a, *b, row)
        # brute force: dense points of the segment against the box (local coordinates)
        t = np.linspace(0, 1, 4001)[:, None]
        pts = a + t * (b - a)
        local = (pts - row[1:4]) @ row[4:13].reshape(3, 3)
        d = np.linalg.norm(np.maximum(np.abs(local) - row[13:16], 0.0), axis=1)
        assert got <= d.min() + 1e-12
        assert got >= d.min() - np.linalg.norm(b - a) / 4000
        c0, c1 = rng.normal(size=3) * 0.05, rng.normal(size=3) * 0.05
        got = _scene.segment_segment(*a, *b, *c0, *c1)
        s = np.linspace(0, 1, 801)
        p1 = a + s[:, None] * (b - a)
        p2 = c0 + s[:, None] * (c1 - c0)
        brute = np.linalg.norm(p1[:, None] - p2[None], axis=-1).min()
        assert got <= brute + 1e-12
        assert got >= brute - (np.linalg.norm(b - a) + np.linalg.norm(c1 - c0)) / 800


def _inside(lo, hi, n):
    """n points inside [lo, hi]: range ends are exact to 5e-10 m, not on the valid side."""
    return lo + (hi - lo) * (np.arange(n) + 0.5) / n


def _scene_targets(design, rng, n):
    q = rng.uniform(design.lower, design.upper, (8 * n, 6))
    q = q[handarm.is_valid(design, q)][:n]
    return handarm.forward(design, q), q


def _keep_clear(design, arm, n_targets, seed):
    """Representatives and 50 points of every returned range: no carved link nearer than c."""
    rng = np.random.default_rng(seed)
    (P, E), _ = _scene_targets(design, rng, n_targets)
    checked = 0
    c = 0.002
    for k, (p, e) in enumerate(zip(P, E, strict=True)):
        scene = random_scene(rng, 4)
        obstacles = fcl_obstacles(scene, "outside")
        r = ik.solve(design, p, e, scene=scene, clearance=c)
        pa, ea = r.achieved_position, r.achieved_direction  # (p, e) unless degraded
        for j in range(r.count):
            qs = [r.solutions[j]] + [
                ik.configuration_at(design, pa, ea, r.branches[j], u, azimuth=r.azimuth)
                for u in _inside(*r.intervals[j], 50)
            ]
            for q in qs:
                assert handarm.is_valid(design, q)
                assert mesh_distance(arm, q, obstacles) >= c - 1e-9, (k, j)
                checked += 1
    assert checked > 10 * n_targets


def test_ranges_in_a_scene_keep_clear_of_the_meshes(design, arm):
    _keep_clear(design, arm, 3, 3)


@pytest.mark.slow
def test_ranges_in_a_scene_keep_clear_of_the_meshes_many(design, arm):
    _keep_clear(design, arm, 30, 33)


def test_ranges_in_a_scene_are_complete(design):
    """Dense u along every exact range: clear points lie in a returned range, others not."""
    rng = np.random.default_rng(4)
    (P, E), _ = _scene_targets(design, rng, 16)
    blocked_some = 0
    for p, e in zip(P, E, strict=True):
        scene = random_scene(rng, 4)
        free = ik.solve(design, p, e, degrade=False)
        r = ik.solve(design, p, e, scene=scene, clearance=0.001)
        for br, (lo, hi) in zip(free.branches, free.intervals, strict=True):
            u = np.linspace(lo, hi, 2000)
            q, ok = ik.configurations_along(design, p, e, br, u, azimuth=free.azimuth)
            clear = np.zeros(len(u), bool)
            clear[ok] = scene_free(design, q[ok], scene, 0.001) & handarm.is_valid(design, q[ok])
            mine = r.intervals[np.all(r.branches == br, axis=1)]
            inside = np.zeros(len(u), bool)
            near = np.zeros(len(u), bool)
            for a, b in mine:
                inside |= (u > a) & (u < b)
                near |= (np.abs(u - a) < 1e-9) | (np.abs(u - b) < 1e-9)
            assert not np.any((inside != clear) & ~near)
            blocked_some += int((~clear & ok).any())
    assert blocked_some > 3  # the scenes do remove something


def test_a_target_that_only_collides_names_the_obstacle(design):
    q0 = np.radians([20, 30, -40, 30, 40, -20])
    p, e = handarm.forward(design, q0)
    # a big box around the tool point's approach: every solution passes through it
    scene = Scene.empty().with_box([0.06, 0.06, 0.06], p - 0.04 * e, name="fixture")
    r = ik.solve(design, p, e, scene=scene, degrade=False)
    assert r.count == 0 and r.blocked_by == ("fixture",)


def test_nothing_clear_of_the_scene_is_an_empty_answer_that_reached_nothing(design):
    """The whole arm inside an obstacle: no exact or degraded answer keeps clear; the result
    is empty and says it reached nothing (0), not 5."""
    q0 = np.radians([20, 30, -40, 30, 40, -20])
    p, e = handarm.forward(design, q0)
    scene = Scene.empty().with_box([1.0, 1.0, 1.0], [0.0, 0.0, 0.0], name="room")
    r = ik.solve(design, p, e, scene=scene, current=q0)
    assert r.count == 0 and r.reached_dof == 0 and r.follow is None
    assert r.blocked_by == ("room",)


def test_degradation_searches_with_the_scene(design, arm):
    """Exact solutions all blocked: the degraded answer keeps clear (model and meshes)."""
    rng = np.random.default_rng(8)
    c = 0.002
    levels = []
    for q0 in (np.radians([20, 30, -40, 30, 40, -20]), np.radians([-30, 50, -20, -40, 30, 10])):
        p, e = handarm.forward(design, q0)
        scene = Scene.empty().with_box([0.06, 0.06, 0.06], p - 0.04 * e, name="fixture")
        assert ik.solve(design, p, e, scene=scene, clearance=c, degrade=False).count == 0
        assert ik.solve(design, p, e).reached_dof == 5  # it is the scene that degrades it
        r = ik.solve(design, p, e, scene=scene, clearance=c, current=q0)
        assert r.blocked_by == ("fixture",) and 2 <= r.reached_dof < 5 and r.count > 0
        levels.append(r.reached_dof)
        qs = [r.solutions, r.follow[None]]
        for br, (lo, hi) in zip(r.branches, r.intervals, strict=True):
            us = np.linspace(lo, hi, 52)[1:-1] if hi > lo else np.array([lo])
            q, ok = ik.configurations_along(
                design, r.achieved_position, r.achieved_direction, br, us, azimuth=r.azimuth
            )
            qs.append(q[ok])
        qs = np.concatenate(qs)
        assert handarm.is_valid(design, qs).all()
        assert scene_gaps(design, qs, scene, c).min() >= 0
        # the printed meshes, placed by the URDF, against the box (fcl, independent)
        obstacles = fcl_obstacles(scene, "outside")
        for q in qs[rng.choice(len(qs), min(len(qs), 12), replace=False)]:
            assert mesh_distance(arm, q, obstacles) >= c - 1e-9
        if r.reached_dof >= 3:
            np.testing.assert_allclose(handarm.forward(design, r.solutions)[0][0], p, atol=1e-9)
    assert levels


def test_world_scene_placed_by_the_handle_pose(design):
    rng = np.random.default_rng(5)
    scene = random_scene(rng, 5)
    pose = np.eye(4)
    pose[:3, :3] = rpy_matrix([0.3, -0.2, 1.1])
    pose[:3, 3] = [0.4, -0.1, 0.9]
    world = Scene(scene.obstacles.copy(), scene.names, "world")
    # obstacles given in the world: move the handle-frame scene out by the pose first
    moved = world.in_handle_frame(np.linalg.inv(pose))  # handle -> world coordinates
    back = Scene(moved.obstacles, moved.names, "world").in_handle_frame(pose)
    q = rng.uniform(design.lower, design.upper, (50, 6))
    np.testing.assert_allclose(
        scene_gaps(design, q, back), scene_gaps(design, q, scene), atol=1e-12
    )
    with pytest.raises(ValueError, match="scene: its frame is 'world'"):
        scene_gaps(design, q, world)


def test_scene_file(tmp_path, design):
    mesh = trimesh.creation.box(extents=(20, 30, 40))
    mesh.export(tmp_path / "fixture.stl")
    (tmp_path / "scene.toml").write_text(
        """
frame = "handle"
[[box]]
size = [0.06, 0.06, 0.06]
position = [0.12, 0.0, 0.0]
rpy = [0.0, 0.0, 0.3]
[[sphere]]
radius = 0.02
position = [0.0, 0.15, 0.05]
[[capsule]]
radius = 0.01
ends = [[0.1, -0.1, 0.0], [0.1, 0.1, 0.0]]
[[mesh]]
file = "fixture.stl"
units = "mm"
position = [0.0, -0.15, 0.0]
""",
        encoding="utf-8",
    )
    s = Scene.from_toml(tmp_path / "scene.toml")
    assert len(s) == 4
    assert s.names == ("box 1", "sphere 1", "capsule 1", "fixture.stl")
    np.testing.assert_allclose(sorted(2 * s.obstacles[3, 13:16]), [0.02, 0.03, 0.04], atol=1e-9)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[[box]]\nsize = [0.1, 0.1]\nposition = [0, 0, 0]", r"box\[0\]\.size: expected 3 numbers"),
        (
            "[[box]]\nsize = [0.1, -0.1, 0.1]\nposition = [0, 0, 0]",
            r"box\[0\]\.size: expected positive",
        ),
        ("[[sphere]]\nradius = 0.02", r"sphere\[0\]\.position: missing"),
        (
            "[[sphere]]\nradius = 'big'\nposition = [0, 0, 0]",
            r"sphere\[0\]\.radius: expected a number",
        ),
        (
            "[[sphere]]\nradius = inf\nposition = [0, 0, 0]",
            r"sphere\[0\]\.radius: expected a positive",
        ),
        (
            "[[capsule]]\nradius = 0.01\nends = [[0, 0, 0]]",
            r"capsule\[0\]\.ends: expected two points",
        ),
        ("[[mesh]]\nfile = 'nope.stl'", r"mesh\[0\]\.file: no such file"),
        ("[[cone]]\nradius = 1", r"scene: unknown key 'cone'"),
        ("frame = 'moon'", r"frame: expected one of"),
        (
            "[[box]]\nsize = [0.1, 0.1, 0.1]\nposition = [0, 0, 0]\ncolour = 'red'",
            r"box\[0\]: unknown key 'colour'",
        ),
    ],
)
def test_bad_scene_files_name_the_field(tmp_path, text, message):
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        Scene.from_toml(path)


def test_bad_clearance_and_scene_arguments(design):
    p, e = handarm.forward(design, np.radians([20, 30, -40, 30, 40, -20]))
    s = Scene.empty().with_sphere([0.5, 0.5, 0.5], 0.01)
    for bad in (-0.001, float("nan"), "1mm", True):
        with pytest.raises(ValueError, match="clearance"):
            ik.solve(design, p, e, scene=s, clearance=bad)
    with pytest.raises(TypeError, match="scene: expected a handarm.scene.Scene"):
        ik.solve(design, p, e, scene="box.toml")


def test_empty_scene_changes_nothing(design):
    rng = np.random.default_rng(6)
    (P, E), _ = _scene_targets(design, rng, 10)
    for p, e in zip(P, E, strict=True):
        a = ik.solve(design, p, e, degrade=False)
        b = ik.solve(design, p, e, scene=Scene.empty())
        np.testing.assert_array_equal(a.intervals, b.intervals)
    np.testing.assert_array_equal(
        ik.count_solutions(design, P, E, scene=Scene.empty()), ik.count_solutions(design, P, E)
    )
    batch = ik.solve_batch(design, P, E, scene=Scene.empty())
    np.testing.assert_array_equal(batch.counts, ik.solve_batch(design, P, E).counts)


def test_ik_command_with_a_scene(tmp_path):
    import subprocess
    import sys

    scene = tmp_path / "scene.toml"
    scene.write_text("[[box]]\nsize = [0.06, 0.06, 0.06]\nposition = [0.12, 0.0, 0.06]\n")
    base = [sys.executable, "-m", "handarm.cli", "ik", "--pos", "0.2", "0.05", "0.05"]
    base += ["--dir", "1", "0", "0.3", "--json"]
    out = subprocess.run(
        base + ["--scene", str(scene), "--clearance", "2"], capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    import json

    data = json.loads(out.stdout)
    assert data["solutions"] and all(lo >= 0.002 - 1e-12 for lo, _ in data["clearance_m"])
    for args, message in (
        (["--scene", str(tmp_path / "nope.toml")], "--scene: no such file"),
        (["--scene", str(tmp_path)], "is a folder, not a file"),
        (["--scene", str(scene), "--clearance", "-1"], "--clearance: expected 0 to 1000 mm"),
        (["--clearance", "2"], "--clearance: only with --scene"),
    ):
        out = subprocess.run(base + args, capture_output=True, text=True)
        assert out.returncode == 2 and message in out.stderr and "Traceback" not in out.stderr


def test_batch_and_count_in_a_scene_agree_with_solve(design):
    """count_solutions and solve_batch with a scene, target by target against solve."""
    rng = np.random.default_rng(12)
    nonzero = 0
    for k in range(8):
        scene = random_scene(rng, int(rng.integers(1, 5)))
        (P, E), _ = _scene_targets(design, rng, 20)
        P = P + rng.normal(scale=0.01, size=P.shape)  # some out of reach, some blocked
        E[0] = [0.0, 0.0, 1.0]  # a vertical direction: the azimuth search as well
        c = 0.003 * (k % 2)
        counts = ik.count_solutions(design, P, E, scene=scene, clearance=c)
        batch = ik.solve_batch(design, P, E, scene=scene, clearance=c)
        for i in range(len(P)):
            r = ik.solve(design, P[i], E[i], scene=scene, clearance=c, degrade=False)
            assert counts[i] == batch.counts[i] == r.count
            assert batch.vertical[i] == (i == 0)
            if r.count:  # the azimuth of L the ranges were solved at
                assert batch.azimuth[i] == pytest.approx(r.azimuth, abs=1e-12)
            # the batch normalises E once more: the same answer to a few ulps
            np.testing.assert_allclose(batch.intervals[i, : r.count], r.intervals, atol=1e-12)
            np.testing.assert_array_equal(batch.branches[i, : r.count], r.branches)
            # representatives: the clearest sample of each range, where near-ties may go
            # either way under a few ulps of E: as clear as solve's, and on the target
            sols = batch.solutions[i, : r.count]
            np.testing.assert_allclose(
                scene_gaps(design, sols, scene).min(axis=-1),
                scene_gaps(design, r.solutions, scene).min(axis=-1),
                atol=1e-9,
            )
            reached = handarm.forward(design, sols)[0]
            np.testing.assert_allclose(reached, np.broadcast_to(P[i], reached.shape), atol=1e-9)
            nonzero += r.count > 0
        wide = ik.count_solutions(design, P, E, scene=scene, clearance=c, min_width=0.02)
        widths = [
            int(np.sum(np.diff(batch.intervals[i, : batch.counts[i]], axis=1) >= 0.02))
            for i in range(len(P))
        ]
        # row 0 left out: for a vertical direction the azimuth search itself looks for a
        # range at least min_width wide, so it may settle on another azimuth
        np.testing.assert_array_equal(wide[1:], widths[1:])
    assert nonzero > 60


def test_workspace_map_in_a_scene(design):
    """Obstacles only take reach away, and a tool point deep inside a box is never reached."""
    from handarm.workspace.maps import reachability_map

    box_centre, box_size = np.array([0.12, 0.0, 0.06]), np.array([0.08, 0.08, 0.08])
    scene = Scene.empty().with_box(box_size, box_centre)
    free = reachability_map(design, 0.02, 12)
    boxed = reachability_map(design, 0.02, 12, scene=scene, clearance=0.001)
    assert boxed.mirrored == (False, False)
    assert np.all(boxed.index <= free.index)
    g = np.stack(np.meshgrid(*[boxed.centres] * 3, indexing="ij"), axis=-1)
    deep = np.all(np.abs(g - box_centre) < box_size / 2 - 0.005, axis=-1)
    assert deep.sum() >= 8 and free.index[deep].max() > 0
    assert boxed.index[deep].max() == 0
    assert boxed.reachable.sum() < free.reachable.sum()


def test_workspace_command_with_a_scene(tmp_path, capsys):
    from handarm.cli import main

    scene = tmp_path / "scene.toml"
    scene.write_text("[[box]]\nsize = [0.06, 0.06, 0.06]\nposition = [0.12, 0.0, 0.06]\n")
    out = tmp_path / "w"
    argv = ["workspace", "--voxel", "0.06", "--directions", "12", "--quiet", "--out", str(out)]
    assert main([*argv, "--scene", str(scene), "--clearance", "2"]) == 0
    assert "in a scene of 1 obstacles, 2 mm kept from them" in capsys.readouterr().out
    report = json.loads((out / "workspace.json").read_text())
    assert report["scene"]["obstacles"] == ["box 1"] and report["scene"]["clearance_m"] == 0.002
    np.testing.assert_allclose(report["scene"]["rows"][0][1:4], [0.12, 0.0, 0.06])
    assert "sensitivity" not in report
    world = tmp_path / "world.toml"
    world.write_text('frame = "world"\n' + scene.read_text())
    for args, message in (
        (["--clearance", "2"], "--clearance: only with --scene"),
        (["--scene", str(world)], "--scene: " + str(world) + ": frame 'world'"),
    ):
        assert main([*argv[:-2], "--out", str(tmp_path / "x"), *args]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "x").exists()


def test_ik_picture_of_a_scene(tmp_path, capsys):
    """--picture draws the obstacles, the target and the arm; bad paths refused first."""
    from matplotlib.image import imread

    from handarm.cli import main

    scene = tmp_path / "scene.toml"
    scene.write_text("[[box]]\nsize = [0.06, 0.06, 0.06]\nposition = [0.12, 0.0, 0.06]\n")
    argv = ["ik", "--pos", "0.2", "0.05", "0.05", "--dir", "1", "0", "0.3"]
    argv += ["--scene", str(scene), "--clearance", "2"]
    picture = tmp_path / "reach.png"
    assert main([*argv, "--picture", str(picture)]) == 0
    assert f"wrote {picture}" in capsys.readouterr().out
    img = imread(picture)[..., :3]
    assert img.shape[0] > 300 and img.shape[1] > 600
    red = (img[..., 0] > 0.8) & (img[..., 1] < 0.2) & (img[..., 2] < 0.2)  # the target
    blue = (img[..., 2] > 0.6) & (img[..., 0] < 0.3)  # the first range's colour
    assert red.sum() > 20 and blue.sum() > 50
    assert {p.name for p in tmp_path.iterdir()} == {"scene.toml", "reach.png"}  # no leftovers
    for bad, message in (
        (tmp_path / "reach.jpg", "--picture: expected a .png file name"),
        (tmp_path / "nope" / "a.png", "--picture: no such folder"),
    ):
        assert main([*argv, "--picture", str(bad)]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
        assert not bad.exists()


def test_meshed_obstacles_bracket_the_true_shapes():
    """The yardstick itself: 'inside' meshes lie within the primitive, 'outside' ones hold it."""
    rng = np.random.default_rng(11)
    for _ in range(4):
        scene = random_scene(rng, 3)
        for (_, inside, inner), (_, _, outer) in zip(
            fcl_obstacles(scene, "inside"), fcl_obstacles(scene, "outside"), strict=True
        ):
            lo, hi = outer.bounds
            pts = rng.uniform(lo - 1, hi + 1, (4000, 3))
            true = inside(pts)
            assert true.sum() > 20
            assert not (inner.contains(pts) & ~true).any()
            assert not (true & ~outer.contains(pts)).any()


def test_over_the_base_in_a_scene_follows_the_nearest_clear_point(design):
    """Above the base's reach the nearest points are a family (joint 4 under p, the tip
    chain vertical, any tip-plane azimuth): with an obstacle on joint 3 of current's own
    member, the answer keeps clear, still meets the bound and moves current no farther
    than the nearest clear member of a dense grid (less its spacing)."""
    from tests.ik.test_degrade import _above_family

    a = design.lengths
    rt = a[4:7].sum()
    p0 = np.array([0.05, 0.02, rt + 0.02])
    e = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])
    current = ik.solve(design, p0, e, current=np.zeros(6)).follow
    checked = 0
    for step in range(6):
        p = p0 + [0.003 * step, -0.002 * step, 0.0]
        psi = current[0] + current[1] + current[2]
        joint3 = [p[0] - a[3] * np.cos(psi), p[1] - a[3] * np.sin(psi), 0.0]
        scene = Scene.empty().with_sphere(joint3, 0.012, name="post")
        r = ik.solve(design, p, e, scene=scene, clearance=0.001, current=current)
        assert r.reached_dof == 2
        assert scene_gaps(design, r.follow, scene, 0.001).min() >= 0
        assert handarm.is_valid(design, r.follow)
        family = _above_family(design, p)
        clear = family[scene_free(design, family, scene, 0.001)]
        assert len(clear) < len(family)  # the post blocks some
        if len(clear):
            checked += 1
            assert r.position_error == pytest.approx(0.02, abs=1e-12)
            nearest = np.linalg.norm(clear - current, axis=1).min()
            assert np.linalg.norm(r.follow - current) <= nearest + np.radians(0.3)
        current = r.follow
    assert checked >= 4
