import csv
import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from handarm import ArmDesign
from handarm._outdir import INCOMPLETE, LOCK, MANIFEST
from handarm.cli import main, make_parser
from handarm.pipeline import BUILD_LAYOUT, CARVE_LAYOUT

ROOT = Path(__file__).resolve().parents[1]


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


#: a quick look (coarse map, coarse carving): CI's first step builds at the defaults
QUICK = ("--voxel", "0.05", "--directions", "16", "--resolution", "3", "--quiet")


def test_build_from_a_design_file_writes_everything(tmp_path, capsys):
    """A design file (own name, shorter links) in, every kind of file out (one build).

    Joint 2 asks for +-180 degrees, more than the printed links allow: the build carves the
    largest healthy range, and everything after the carving uses the narrowed limits. A box
    beside the arm: the map is made around it and the report draws it.
    """
    limits = list(ArmDesign().joint_limits)
    limits[1] = (-math.pi, math.pi)
    d = ArmDesign(name="mine", link_lengths=[0.045] * 7, joint_limits=limits)
    d.to_toml(tmp_path / "mine.toml")
    scene = tmp_path / "scene.toml"
    scene.write_text("[[box]]\nname = 'crate'\nsize = [0.1, 0.1, 0.1]\nposition = [0.15, 0, 0]\n")
    code, out, err = run(
        capsys,
        "build",
        str(tmp_path / "mine.toml"),
        "--out",
        str(tmp_path / "b"),
        *QUICK,
        "--scene",
        str(scene),
        "--clearance",
        "1",
    )
    assert code == 0, err
    b = tmp_path / "b"
    assert ArmDesign.from_toml(b / "design.toml") == d
    urdf = (b / "mine.urdf").read_text()
    assert urdf.startswith("<?xml") and "meshes/l3.stl" in urdf and "<inertial>" in urdf
    assert "joint" in (b / "summary.txt").read_text()
    assert (b / "plate.3mf").stat().st_size > 1000
    assert len(list((b / "meshes").glob("l*.stl"))) == 7
    assert (b / "pictures" / "arm_folded.png").exists()
    controller = json.loads((b / "controller" / "controller.json").read_text())
    carving = json.loads((b / "carve.json").read_text())
    # the controller holds the design's limits cut to what the carved parts allow
    achieved = np.radians([j["achieved_deg"] for j in carving["joints"]])
    allowed = np.stack([np.maximum(d.lower, achieved[:, 0]), np.minimum(d.upper, achieved[:, 1])])
    np.testing.assert_allclose(controller["joint_limits_rad"], allowed.T, rtol=0, atol=1e-9)
    narrow = math.pi - math.radians(5)  # joint 2 (column 1) was cut well inside +-180
    assert -narrow < allowed[0, 1] and allowed[1, 1] < narrow
    # the URDF, the MuJoCo model and the map describe the same arm as the controller
    urdf_limits = [
        (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
        for j in ET.fromstring((b / "mine.urdf").read_bytes()).iter("joint")
        if j.get("type") == "revolute"
    ]
    mjcf_limits = [
        tuple(map(float, j.get("range").split()))
        for j in ET.fromstring((b / "mine.mjcf.xml").read_bytes()).iter("joint")
        if j.get("type") == "hinge"
    ]
    workspace = json.loads((b / "workspace" / "workspace.json").read_text())
    assert workspace["scene"]["obstacles"] == ["crate"]
    assert workspace["scene"]["clearance_m"] == 1e-3
    np.testing.assert_allclose(workspace["scene"]["rows"][0][1:4], [0.15, 0, 0])
    assert "sensitivity" not in workspace
    page = (b / "report.html").read_text()
    assert "Mapped around 1 obstacle(s) (crate), keeping 1 mm" in page
    assert '"name":"crate"' in page  # the box drawn in the 3D view
    assert len(urdf_limits) == len(mjcf_limits) == 6
    for limits_used in (urdf_limits, mjcf_limits, workspace["joint_limits_rad"]):
        np.testing.assert_allclose(limits_used, allowed.T, rtol=0, atol=1e-9)
    narrowed = [line for line in (b / "summary.txt").read_text().splitlines() if "narrowed" in line]
    cut = np.any(np.abs(allowed.T - np.array(d.joint_limits)) > 1e-12, axis=1)
    assert [line.split(":")[0].strip() for line in narrowed] == [
        f"joint {k + 1}" for k in np.flatnonzero(cut)
    ]
    assert cut[1]
    assert (b / "controller" / "arm_config.h").exists()
    # one source for the cables' cut lengths: the handle's runs, in the bill of materials,
    # tendons.json and the summary alike (tendons.json once assumed a 100 mm run: 138 mm off)
    with open(b / "bom.csv") as fh:
        bom = {r["item"]: r["size"] for r in csv.DictReader(fh)}
    cables = json.loads((b / "tendons.json").read_text())["cables"]
    summary = (b / "summary.txt").read_text()
    assert len(cables) == 6
    for c in cables:
        cut = f"cut {c['cut_length_m'] * 1e3:.0f} mm"
        assert cut in bom[f"cable {c['cable']}"] and cut in summary
    # nothing half-written is left behind; every file is printed but the folder's own records
    assert not list(b.rglob("*.tmp")) and not (b / INCOMPLETE).exists()
    files = {p for p in b.rglob("*") if p.is_file()} - {b / MANIFEST, b / LOCK}
    assert {Path(line) for line in out.split()} == files
    # what the build checks for in its way before any work is what it writes
    assert _top_level(b, files) == _layout(BUILD_LAYOUT, "mine")
    report = json.loads((b / "workspace" / "workspace.json").read_text())
    assert (report["voxel_m"], report["directions"]) == (0.05, 16)


def _top_level(out, files):
    """(folders, files) at the top of ``out`` among the paths ``files``."""
    rel = [p.relative_to(out).parts for p in files]
    return {r[0] for r in rel if len(r) > 1}, {r[0] for r in rel if len(r) == 1}


def _layout(layout, name):
    return set(layout[0]), {f.format(name=name) for f in layout[1]}


@pytest.mark.parametrize(
    ("command", "in_the_way", "message"),
    [
        ("carve", "meshes", "is in the way of the folder"),
        ("carve", "carve.json/", "is a folder where a file"),
        ("build", "controller", "is in the way of the folder"),
        ("build", "summary.txt/", "is a folder where a file"),
    ],
)
def test_what_is_in_the_way_is_refused_before_any_work(tmp_path, capsys, command, in_the_way,
                                                        message):  # fmt: skip
    """A file named meshes in --out was found after the carving (a raw 'File exists')."""
    out = tmp_path / "o"
    out.mkdir()
    path = out / in_the_way.rstrip("/")
    path.mkdir() if in_the_way.endswith("/") else path.write_text("mine")
    code, _, err = run(capsys, command, "--out", str(out), "--quiet")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert message in err and "--out" in err, err
    assert sorted(p.name for p in out.iterdir()) == [path.name]  # nothing written


def test_build_map_settings_are_checked_before_any_work(tmp_path, capsys):
    args = ("--out", str(tmp_path / "b"), "--directions", "40")
    code, _, err = run(capsys, "build", *args)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "--directions: 40 directions cannot be spread evenly" in err
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize("args", [("--voxel", "0"), ("--resolution", "20"), ("--directions", "x")])
def test_build_options_refuse_bad_values_in_one_line(tmp_path, capsys, args):
    with pytest.raises(SystemExit) as exc:
        run(capsys, "build", "--out", str(tmp_path / "b"), *args)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument {args[0]}:" in err
    assert not (tmp_path / "b").exists()


def test_urdf_command(tmp_path, capsys):
    code, _, err = run(capsys, "urdf", "--out", str(tmp_path / "a.urdf"))
    assert code == 0, err
    assert "<robot" in (tmp_path / "a.urdf").read_text()


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "design file not found"),
        ("link_lengths = [", "not valid TOML"),
        ("link_lengths = [0.05, 0.05]", "link_lengths: expected 7 values"),
        ("colour = 'red'", "unknown key 'colour'"),
    ],
)
@pytest.mark.parametrize("command", ["build", "urdf", "carve"])
def test_user_mistakes_are_one_line(tmp_path, capsys, content, message, command):
    path = tmp_path / "arm.toml"
    if content is not None:
        path.write_text(content)
    code, out, err = run(capsys, command, str(path), "--out", str(tmp_path / "x"))
    assert code == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err
    assert not (tmp_path / "x").exists() or not any((tmp_path / "x").iterdir())


def test_every_subcommand_has_help(capsys):
    parser = make_parser()
    commands = parser._subparsers._group_actions[0].choices
    assert {"build", "urdf", "ik", "carve", "bridge", "workspace", "study"} <= set(commands)
    bridge = commands["bridge"]._subparsers._group_actions[0].choices
    assert {"export", "size", "apply", "calibrate", "read", "goto", "emulate"} <= set(bridge)
    argvs = [[name, "--help"] for name in commands] + [["bridge", b, "--help"] for b in bridge]
    for argv in argvs:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 0
        assert "usage: handarm" in capsys.readouterr().out


def test_console_script_runs_even_without_docstrings():
    for flags in ([], ["-OO"]):
        result = subprocess.run(
            [sys.executable, *flags, "-m", "handarm.cli", "--help"],
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        assert "build" in result.stdout


def test_ik_command_table_and_json(capsys):
    import json

    code, out, err = run(capsys, "ik", "--pos", "0.2", "0.05", "0.05", "--dir", "1", "0", "0.3")
    assert code == 0, err
    assert "5 DoF" in out and "branch" in out
    code, out, err = run(
        capsys,
        "ik",
        "--pos",
        "0.2",
        "0.05",
        "0.05",
        "--dir",
        "1",
        "0",
        "0.3",
        "--json",
        "--current",
        "0",
        "30",
        "-30",
        "0",
        "20",
        "10",
    )
    data = json.loads(out)
    assert data["reached_dof"] == 5 and len(data["solutions"]) >= 1
    assert len(data["follow_deg"]) == 6


def test_ik_command_user_mistakes(capsys):
    code, _, err = run(capsys, "ik", "--pos", "0.2", "0", "0", "--dir", "0", "0", "0")
    assert code == 2 and "--dir: direction has zero length" in err
    assert "Traceback" not in err
    with pytest.raises(SystemExit) as exc:  # the option's type refuses NaN, in one line
        run(capsys, "ik", "--pos", "0.2", "0", "nan", "--dir", "1", "0", "0")
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "--pos" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, "ik", "--pos", "0.6", "0", "0", "--dir", "1", "0", "0", "--exact")
    assert code == 1


def test_carve_command(tmp_path, capsys):
    code, out, err = run(
        capsys, "carve", "--out", str(tmp_path / "c"), "--quiet", "--resolution", "2"
    )
    assert code == 0, err
    assert "parts allow" in out and "as built" in out and "total link mass" in out
    # as built: the request within what the parts allow (what the URDF is written with)
    for j in json.loads((tmp_path / "c" / "carve.json").read_text())["joints"]:
        req, ach, built = j["requested_deg"], j["achieved_deg"], j["as_built_deg"]
        assert built == [max(req[0], ach[0]), min(req[1], ach[1])]
    assert (tmp_path / "c" / "handarm-build.json").exists()  # a manifest, as a build has
    manifest = json.loads((tmp_path / "c" / "handarm-build.json").read_text())["files"]
    written = {tmp_path / "c" / f for f in manifest}
    assert _top_level(tmp_path / "c", written) == _layout(CARVE_LAYOUT, "paper_arm")
    assert "warning" not in err and "thin wall" not in out  # the paper's arm keeps min_wall


@pytest.mark.slow
def test_carving_a_too_thin_design_warns(tmp_path, capsys):
    """Links of 20 mm are knife-edged before carving (walls of a few um); carve exited 0
    with only links/*.json saying so."""
    design = tmp_path / "short.toml"
    design.write_text("link_lengths = [0.02, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02]\n")
    code, out, err = run(
        capsys, "carve", str(design), "--out", str(tmp_path / "c"), "--quiet", "--resolution", "2"
    )
    assert code == 0, err
    warning = [line for line in err.splitlines() if "warning" in line]
    assert len(warning) == 1 and "walls under min_wall (1.2 mm)" in warning[0], err
    thin = {link for link in ("l1", "l2", "l3", "l4", "l5") if f"{link} " in warning[0]}
    assert thin == {"l1", "l2", "l3", "l4", "l5"}
    assert out.count("thin wall:") == 5
    for link in thin:  # the same verdict as the link's own report
        report = json.loads((tmp_path / "c" / "links" / f"{link}.json").read_text())
        assert report["min_wall_met"] is False and report["min_wall_m"] < 1.2e-3
    # the default design carved into the same folder: none of the short design's parts stay
    # (its l3 printed whole as parts/l3.stl, the default's as a beam and a fork)
    assert (tmp_path / "c" / "parts" / "l3.stl").exists()
    code, out, err = run(
        capsys, "carve", "--out", str(tmp_path / "c"), "--quiet", "--resolution", "2"
    )
    assert code == 0 and "warning" not in err, err
    manifest = json.loads((tmp_path / "c" / "handarm-build.json").read_text())
    on_disk = {
        str(p.relative_to(tmp_path / "c"))
        for p in (tmp_path / "c").rglob("*")
        if p.is_file() and not p.name.startswith(".") and p.name != "handarm-build.json"
    }
    assert on_disk == set(manifest["files"])
    assert not (tmp_path / "c" / "parts" / "l3.stl").exists()
