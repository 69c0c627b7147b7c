import subprocess
import sys
from pathlib import Path

import pytest

from handarm import ArmDesign
from handarm.cli import main, make_parser

ROOT = Path(__file__).resolve().parents[1]


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_build_writes_design_urdf_summary(tmp_path, capsys):
    code, out, err = run(capsys, "build", "--out", str(tmp_path / "b"))
    assert code == 0, err
    assert ArmDesign.from_toml(tmp_path / "b" / "design.toml") == ArmDesign()
    assert (tmp_path / "b" / "paper_arm.urdf").read_text().startswith("<?xml")
    assert "joint" in (tmp_path / "b" / "summary.txt").read_text()


def test_build_from_a_design_file(tmp_path, capsys):
    d = ArmDesign(name="mine", link_lengths=[0.04] * 7)
    d.to_toml(tmp_path / "mine.toml")
    code, _, err = run(capsys, "build", str(tmp_path / "mine.toml"), "--out", str(tmp_path / "o"))
    assert code == 0, err
    assert ArmDesign.from_toml(tmp_path / "o" / "design.toml") == d
    assert (tmp_path / "o" / "mine.urdf").exists()


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
@pytest.mark.parametrize("command", ["build", "urdf"])
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
    assert {"build", "urdf", "ik"} <= set(commands)
    for name in commands:
        with pytest.raises(SystemExit) as exc:
            main([name, "--help"])
        assert exc.value.code == 0
        assert "usage: handarm" in capsys.readouterr().out


def test_console_script_runs():
    result = subprocess.run(
        [sys.executable, "-m", "handarm.cli", "--help"], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0
    assert "build" in result.stdout


def test_readme_and_ci_run_the_same_test_command():
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    test_cmd = 'python -m pip install ".[test]" && python -m pytest'
    assert test_cmd in "\n".join(readme.splitlines()[:15])
    assert test_cmd in ci


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
    code, _, err = run(capsys, "ik", "--pos", "0.2", "0", "nan", "--dir", "1", "0", "0")
    assert code == 2 and "--pos" in err
    code, _, err = run(capsys, "ik", "--pos", "0.6", "0", "0", "--dir", "1", "0", "0", "--exact")
    assert code == 1
