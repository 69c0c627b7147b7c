import json
import struct

import numpy as np
import pytest
import trimesh
import yourdfpy

import handarm
import handarm.carve.properties
from handarm.cad_out.carve_files import write_carve_outputs
from handarm.cad_out.meshes import support_area


@pytest.fixture(scope="module")
def result(carved_default):
    return carved_default


@pytest.fixture(scope="module")
def out(result, tmp_path_factory):
    out = tmp_path_factory.mktemp("carve")
    write_carve_outputs(result, out)
    return out


def test_binary_stl_per_link_in_print_pose(result, out):
    for link in result.links:
        path = out / "meshes" / f"{link.name}.stl"
        data = path.read_bytes()
        (n,) = struct.unpack("<I", data[80:84])
        assert len(data) == 84 + 50 * n  # binary STL
        mesh = trimesh.load(path, file_type="stl")
        assert mesh.volume == pytest.approx(link.solid.volume(), rel=1e-6)
        assert mesh.bounds[0, 2] == pytest.approx(0.0, abs=1e-5)  # on the bed (float32 STL)
        assert mesh.is_watertight


def test_3mf_plate_holds_every_printed_part(result, out):
    scene = trimesh.load(out / "plate.3mf")
    parts = [p for split in result.printed for p in split.parts]
    assert len(parts) == len(scene.geometry) == 14  # the paper's arm: 1 + 3 + 2 + 2 + 3 + 2 + 1
    assert sorted(scene.geometry) == sorted(p.name for p in parts)
    volumes = sorted(g.volume for g in scene.geometry.values())
    expected = sorted(p.solid.volume() for p in parts)
    np.testing.assert_allclose(volumes, expected, rtol=1e-6)
    # laid out without overlaps: the parts' footprints on the bed are disjoint
    boxes = []
    for node in scene.graph.nodes_geometry:
        transform, geom = scene.graph[node]
        mesh = scene.geometry[geom].copy().apply_transform(transform)
        boxes.append(mesh.bounds)
        assert mesh.bounds[0, 2] == pytest.approx(0.0, abs=1e-4)  # on the bed
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            a, b = boxes[i], boxes[j]
            apart = (a[1, :2] <= b[0, :2]) | (b[1, :2] <= a[0, :2])
            assert apart.any(), f"parts {i} and {j} overlap on the plate"


def test_printed_parts_need_under_50_mm2_of_support(result, out):
    """Measured on the written STLs as they lie (z down), with the project's support_area:
    every part of the paper's arm is under the target, on the bed, one closed body; the
    JSON's numbers are the files'."""
    for link in result.links:
        data = json.loads((out / "links" / f"{link.name}.json").read_text())
        worst = 0.0
        for part in data["print"]["parts"]:
            mesh = trimesh.load(out / part["stl"], file_type="stl")
            area = support_area(mesh, [0.0, 0.0, -1.0])
            assert area < 50.0, (part["name"], area)
            assert area == pytest.approx(part["support_area_mm2"], abs=1e-3)
            assert mesh.bounds[0, 2] == pytest.approx(0.0, abs=1e-5)
            assert mesh.is_volume and len(mesh.split(only_watertight=False)) == 1
            assert mesh.volume == pytest.approx(part["volume_m3"] * 1e9, rel=1e-5)
            worst = max(worst, area)
        assert data["support_area_mm2"] == pytest.approx(worst, abs=1e-3)
        assert data["print"]["target_met"] and data["print"]["problems"] == []
        assert data["support_area_unsplit_mm2"] >= data["support_area_mm2"]
    written = sorted(p.name for p in (out / "parts").iterdir())
    named = sorted(p.file_name for s in result.printed for p in s.parts)
    assert written == named


def test_link_json(result, out):
    d = result.design
    for link in result.links:
        data = json.loads((out / "links" / f"{link.name}.json").read_text())
        vol = link.solid.volume() * 1e-9
        assert data["volume_m3"] == pytest.approx(vol, rel=1e-6)
        assert data["mass_kg"] == pytest.approx(vol * d.density, rel=1e-6)
        inertia = np.asarray(data["inertia_kg_m2"])
        np.testing.assert_allclose(inertia, inertia.T, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(inertia) > 0)
        assert data["min_cross_section_m2"] > 0
        assert data["bodies"] == 1 and data["watertight"]
        assert all("achieved_deg" in j for j in data["joints"])
        printed = data["print"]
        mass = sum(p["mass_kg"] for p in printed["parts"])
        assert mass == pytest.approx(data["mass_kg"], rel=0.03)  # less holes and teardrops
        assert mass < data["mass_kg"] or printed["scheme"] == "whole"
        for f in printed["fasteners"]:
            assert set(f["joins"]) <= {p["name"] for p in printed["parts"]}
            assert f["wall_m"] >= d.min_wall - 1e-9
    summary = json.loads((out / "carve.json").read_text())
    assert len(summary["joints"]) == 6 and len(summary["links"]) == 7


def test_pictures(out):
    for name in [f"l{k}" for k in range(7)] + ["arm_straight", "arm_folded"]:
        data = (out / "pictures" / f"{name}.png").read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10000


def test_urdf_meshes_sit_in_their_link_frames(result, out):
    d = result.design
    robot = yourdfpy.URDF.load(str(out / f"{d.name}.urdf"), load_meshes=False)
    names = [f"joint{k}" for k in range(1, 7)]
    rng = np.random.default_rng(0)
    q = rng.uniform(d.lower, d.upper, (20, 6))
    frames = handarm.joint_frames(d, q)
    t_ref = handarm.forward_matrix(d, q)
    for i in range(len(q)):
        robot.update_cfg(dict(zip(names, q[i], strict=True)))
        np.testing.assert_allclose(robot.get_transform("tool", "base_link"), t_ref[i], atol=1e-12)
        for k, link_name in enumerate(["base_link"] + [f"link{n}" for n in range(1, 7)]):
            visual = robot.link_map[link_name].visuals[0]
            mesh = trimesh.load(out / visual.geometry.mesh.filename, file_type="stl")
            mesh.apply_scale(visual.geometry.mesh.scale[0])
            mesh.apply_transform(robot.get_transform(link_name, "base_link") @ visual.origin)
            ours = handarm.carve.properties.to_trimesh(result.links[k].solid)
            ours.apply_scale(1e-3)
            if k > 0:
                ours.apply_transform(frames[i, k - 1])
            np.testing.assert_allclose(mesh.bounds, ours.bounds, atol=1e-7)  # float32 STL
    inertial = robot.link_map["link2"].inertial
    props = json.loads((out / "links" / "l2.json").read_text())
    assert inertial.mass == pytest.approx(props["mass_kg"])


def test_export_with_achieved_limits_from_carve_json(result, out, tmp_path, capsys):
    from handarm.cli import main

    code = main(["bridge", "export", "--achieved", str(out / "carve.json"), "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 0, err
    limits = json.loads((tmp_path / "controller.json").read_text())["joint_limits_rad"]
    for (lo, hi), j, (dlo, dhi) in zip(
        limits, result.joints, result.design.joint_limits, strict=True
    ):
        # the design's limits intersected with what the carved links allow
        assert lo == pytest.approx(max(dlo, j.achieved[0]))
        assert hi == pytest.approx(min(dhi, j.achieved[1]))
    bad = tmp_path / "bad.json"
    bad.write_text('{"joints": [{"achieved_deg": [10, -10]}] }')
    code = main(["bridge", "export", "--achieved", str(bad), "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--achieved" in err
    assert not (tmp_path / "x").exists()


def test_a_missed_target_is_reported_in_the_link_json(result):
    """A split that misses its target still reports: target_met false, the part named."""
    from handarm.cad_out.carve_files import printed_summary, split_report
    from handarm.carve.split import split_link

    split = split_link(result, 5, target=5.0)  # l5's fork stands with 15.8 mm^2
    data = split_report(split, result.design.density)
    assert data["target_met"] is False and data["target_mm2"] == 5.0
    assert any(p.startswith("l5 fork: ") for p in data["problems"])
    assert max(p["support_area_mm2"] for p in data["parts"]) > 5.0
    assert "target missed: l5 fork" in printed_summary([split])
