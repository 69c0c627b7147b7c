"""Hostile input, interrupts and reuse (issue 16): no traceback, no hang, no silent wrong part,
nothing written where it should not be.

In-process cases call ``handarm.cli.main`` and check the exit status, that stderr is one line
and that nothing appeared outside ``--out``; special files and Ctrl-C run the real command in
a subprocess with a timeout.
"""

import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from handarm import ArmDesign
from handarm._io import write_text_atomic
from handarm._outdir import INCOMPLETE, LOCK, MANIFEST, build_folder, check_out_dir
from handarm._resources import check_resources
from handarm.cli import EXIT_CODES, main
from handarm.design import FIELD_BOUNDS, MIN_BORE_WALL, NAME_PATTERN
from handarm.firmware_bridge.calibration import Calibration

ROOT = Path(__file__).resolve().parents[1]
FIELDS = {f for f in ArmDesign().to_dict()}


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(err: str, exit_code: int, expected: int = 2):
    assert exit_code == expected, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err


def listing(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


# -- 1. validation at the door --------------------------------------------------------------

BAD_DESIGNS = [
    ({"clearance": 0.003}, "clearance"),
    ({"axle_diameter": 0.017}, "hub_radius"),  # a 0.1 mm bore wall
    ({"cheek_thickness": 1e-7}, "cheek_thickness"),
    ({"density": 1e308}, "density"),
    ({"joint_pulley_radii": [1e-9] * 6}, r"joint_pulley_radii\[0\]"),
    ({"motor_pulley_radius": 1e-9}, "motor_pulley_radius"),
    ({"link_lengths": [2.0] * 7}, r"link_lengths\[0\]"),
    ({"baud_rate": 1234}, "baud_rate"),
    ({"name": "../x"}, "name"),
    ({"name": "/tmp/abs"}, "name"),
    ({"name": "a/b/c"}, "name"),
    ({"name": "x" * 300}, "name"),
    ({"name": ".hidden"}, "name"),
    ({"servo_ids": [1.9, 2, 3, 4, 5, 6]}, r"servo_ids\[0\]"),
    ({"servo_ids": [True, 2, 3, 4, 5, 6]}, r"servo_ids\[0\]"),
    ({"servo_ids": "123456"}, "servo_ids"),
    ({"servo_ids": [1, 2, 3, 4, 5, 253]}, r"servo_ids\[5\]"),
    ({"hub_radius": 0.03}, "hub_radius"),  # hubs longer than the links
]


@pytest.mark.parametrize(("changes", "field"), BAD_DESIGNS)
def test_bad_design_refused_at_load_naming_the_field(changes, field, tmp_path, capsys):
    with pytest.raises(ValueError, match=f"^{field}"):
        ArmDesign.from_dict(changes)
    path = tmp_path / "arm.toml"
    path.write_text("".join(f"{k} = {json.dumps(v)}\n" for k, v in changes.items()))
    out = tmp_path / "out"
    code, _, err = run(capsys, "build", path, "--out", out, "--quiet")
    one_line_error(err, code)
    assert re.search(field, err)
    assert not out.exists() and listing(tmp_path) == {"arm.toml"}


numeric = st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(10**20), 10**20)


@settings(max_examples=200, deadline=None)
@given(
    changes=st.dictionaries(
        st.sampled_from(sorted(FIELD_BOUNDS)),
        numeric | st.lists(numeric, min_size=6, max_size=7) | st.text(max_size=5) | st.none(),
        max_size=4,
    )
)
def test_any_values_load_inside_the_bounds_or_fail_naming_a_field(changes):
    try:
        d = ArmDesign.from_dict(changes)
    except ValueError as exc:
        assert str(exc).split(":")[0].split("[")[0] in FIELDS, exc
        return
    for name, (lo, hi) in FIELD_BOUNDS.items():
        values = getattr(d, name)
        for v in values if isinstance(values, tuple) else (values,):
            assert lo <= v <= hi and math.isfinite(v)
    # the wall the carving keeps fits between bore and hub
    assert d.hub_radius - d.axle_diameter / 2 - d.clearance >= MIN_BORE_WALL - 1e-15


@given(name=st.from_regex(NAME_PATTERN, fullmatch=True))
def test_a_valid_name_is_one_safe_file_name(name):
    assert "/" not in name and not name.startswith(".") and len(name) <= 64
    assert Path(name).name == name and name not in (".", "..")


# -- calibration files: strict types -------------------------------------------------------


def _calibration(**changes):
    data = Calibration.record(ArmDesign(), [2048] * 6).to_dict()
    data.update(changes)
    return data


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"servo_ids": [1.9, 2, 3, 4, 5, 6]}, r"servo_ids\[0\]"),
        ({"servo_ids": [True, 2, 3, 4, 5, 6]}, r"servo_ids\[0\]"),
        ({"servo_ids": "123456"}, "servo_ids"),
        ({"servo_ids": [1, 1, 3, 4, 5, 6]}, "servo_ids"),
        ({"offsets": [1, 2, 3, 4, 5]}, "offsets"),
        ({"offsets": [1, 2, 3, 4, 5, 10**9]}, r"offsets\[5\]"),
        ({"model_number": "310"}, "model_number"),
        ({"design_name": 5}, "design_name"),
    ],
)
def test_calibration_types_are_strict(tmp_path, changes, field):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(_calibration(**changes)))
    with pytest.raises(ValueError, match=f"cal.json: {field}"):
        Calibration.load(path)


def test_calibration_infinity_is_one_clean_error(tmp_path):
    path = tmp_path / "cal.json"
    text = json.dumps(_calibration()).replace('"offsets": [2048', '"offsets": [Infinity')
    path.write_text(text)
    with pytest.raises(ValueError, match="Infinity"):
        Calibration.load(path)


def test_calibration_round_trip_still_loads(tmp_path):
    cal = Calibration.record(ArmDesign(), [2048, 0, -5, 4095, 100, 7])
    assert Calibration.load(cal.save(tmp_path / "c.json"), ArmDesign()) == cal


# -- CLI options ---------------------------------------------------------------------------

OPTION_CASES = [
    ("workspace", "--voxel", "inf"),
    ("workspace", "--voxel", "nan"),
    ("workspace", "--voxel", "-1"),
    ("workspace", "--voxel", "0.001"),  # 1.6 GiB+ of grid: over the limit
    ("workspace", "--directions", "100000"),
    ("workspace", "--directions", "1000000000"),
    ("workspace", "--directions", "2.5"),
    ("workspace", "--threshold", "0"),
    ("carve", "--resolution", "0"),
    ("carve", "--resolution", "inf"),
    ("build", "--max-memory", "-1"),
    ("ik", "--pos", "nan"),
]


@pytest.mark.parametrize(("command", "option", "value"), OPTION_CASES)
def test_bad_options_are_one_line_before_any_work(command, option, value, tmp_path, capsys):
    if command == "ik":
        argv = ["ik", "--pos", value, "0", "0", "--dir", "1", "0", "0"]
    else:
        argv = [command, option, value, "--out", tmp_path / "out", "--quiet"]
    t0 = time.perf_counter()
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse: the option's type refused the value
        code = exc.code
    err = capsys.readouterr().err
    one_line_error(err, code)
    assert option in err or option.lstrip("-") in err
    assert time.perf_counter() - t0 < 20
    assert listing(tmp_path) == set()


def test_argparse_errors_are_one_line(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["workspace", "--voxel", "inf"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--voxel" in err


def test_study_workers_must_be_positive(tmp_path, capsys):
    study = tmp_path / "s.toml"
    study.write_text('name = "s"\nvoxel = 0.04\ndirections = 8\n')
    for bad in ("-1", "0"):
        with pytest.raises(SystemExit):
            main(["study", str(study), "--workers", bad, "--out", str(tmp_path / "o")])
        assert "--workers" in capsys.readouterr().err
    from handarm.workspace.study_file import load_study
    from handarm.workspace.study_run import run_study

    with pytest.raises(ValueError, match="workers"):
        run_study(load_study(study), tmp_path / "o", workers=-1)
    assert not (tmp_path / "o").exists()


def test_resource_estimate_is_in_the_refusal():
    big = ArmDesign(link_lengths=[0.5] * 7, hub_radius=0.009)
    with pytest.raises(ValueError, match=r"voxel: .* about [\d.]+ GiB"):
        check_resources(big, voxel=0.005, directions=100)
    # the option raises the limit
    check_resources(ArmDesign(), voxel=0.005, directions=100, max_memory=1e12, max_seconds=1e9)


def test_time_refusal_quotes_the_limit_given_and_the_whole_job(tmp_path, capsys):
    """A map with its sensitivity screen (3x): the message quotes the whole job and the limit."""
    from handarm._resources import estimate

    minutes = estimate(ArmDesign(), voxel=0.01, directions=100)[1] / 60
    limit = 2.0 * minutes  # the map alone fits, with its screen (3x) it does not
    with pytest.raises(ValueError) as info:
        check_resources(ArmDesign(), voxel=0.01, directions=100, max_seconds=60 * limit,
                        time_factor=3.0)  # fmt: skip
    said = re.search(r"needs about ([\d.]+) min, over the ([\d.e-]+) min limit", str(info.value))
    assert said, info.value
    assert float(said[2]) == pytest.approx(limit, rel=1e-5)
    assert float(said[1]) == pytest.approx(3.0 * minutes, rel=0.05)
    check_resources(ArmDesign(), voxel=0.01, directions=100, max_seconds=60 * limit)
    code, _, err = run(capsys, "build", "--out", tmp_path / "b", "--max-minutes", "0.01")
    one_line_error(err, code)
    assert "over the 0.01 min limit" in err
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize("command", ["build", "workspace"])
def test_a_voxel_in_millimetres_is_refused(command, tmp_path, capsys):
    """--voxel 30 (meant 0.03 m) built a one-voxel map with every score 0, exit 0."""
    code, _, err = run(capsys, command, "--voxel", "30", "--out", tmp_path / "o")
    one_line_error(err, code)
    assert "voxel: 30 m is coarser than the arm's reach (0.300 m) over 4" in err
    assert "in metres" in err
    assert not (tmp_path / "o").exists()
    with pytest.raises(ValueError, match=r"^voxel: 0\.08 m is coarser"):
        check_resources(ArmDesign(), voxel=0.08, directions=36)
    check_resources(ArmDesign(), voxel=0.07, directions=36)  # 0.075 is the bound


@pytest.mark.parametrize(
    ("command", "text", "key"),
    [
        ("optimize", "trials = 2\n[map]\nvoxel = 50\n[variables]\n"
         "pulley_radius_2 = {low = 0.006, high = 0.012}\n", "map.voxel"),
        ("optimize", "trials = 2\n[map]\nfull_voxel = 30\n[variables]\n"
         "pulley_radius_2 = {low = 0.006, high = 0.012}\n", "map.full_voxel"),
        ("study", "voxel = 30\n[grid]\nlimit_deg_2 = [120, 150]\n", "voxel"),
    ],
)  # fmt: skip
def test_a_voxel_in_millimetres_is_refused_in_study_and_optimize_files(
    tmp_path, capsys, command, text, key
):
    """[map] voxel = 50 in an optimize file ran every trial into a numpy broadcast error
    and left trials.csv, front.json and pictures/ behind: refused at load, naming the key."""
    path = tmp_path / "f.toml"
    path.write_text(text)
    code, _, err = run(capsys, command, path, "--out", tmp_path / "o")
    one_line_error(err, code)
    assert f"{path}: {key}: " in err and "in metres" in err, err
    assert not (tmp_path / "o").exists()


def test_no_empty_sensitivity_bar_without_the_screen(tmp_path, capsys):
    """--no-sensitivity drew an empty 'sensitivity screen: 0map' bar on stderr."""
    args = ["--voxel", "0.05", "--directions", "36", "--out"]
    code, _, err = run(capsys, "workspace", *args, tmp_path / "a", "--no-sensitivity")
    assert code == 0, err
    assert "workspace" in err and "sensitivity screen" not in err


def test_inverted_achieved_limits_refused(tmp_path, capsys):
    carve_json = tmp_path / "carve.json"
    joints = [{"achieved_deg": [10.0, -10.0]}] * 6
    carve_json.write_text(json.dumps({"joints": joints}))
    code, _, err = run(
        capsys, "bridge", "export", "--achieved", carve_json, "--out", tmp_path / "c"
    )
    one_line_error(err, code)
    assert not (tmp_path / "c").exists()


# -- files -----------------------------------------------------------------------------------


def test_out_that_is_a_symlink_fifo_or_file_is_refused(tmp_path, capsys):
    target = tmp_path / "real"
    target.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    plain = tmp_path / "plain"
    plain.write_text("keep me")
    for out in (link, fifo, plain):
        with pytest.raises(ValueError, match="out: "):
            check_out_dir(out)
        code, _, err = run(capsys, "workspace", "--out", out, "--quiet", "--no-sensitivity")
        one_line_error(err, code)
    assert link.is_symlink() and fifo.is_fifo() and plain.read_text() == "keep me"
    assert listing(target) == set()


@pytest.mark.parametrize("command", ["carve", "workspace"])
def test_out_holding_a_linked_folder_is_refused(tmp_path, capsys, command):
    """carve --out c1 wrote l0.stl .. l6.stl through c1/meshes, a link to a folder outside."""
    outside = tmp_path / "outside"
    outside.mkdir()
    out = tmp_path / "c1" / "deep"
    out.mkdir(parents=True)
    (out / "meshes").symlink_to(outside)
    extra = ["--no-sensitivity"] if command == "workspace" else []
    code, _, err = run(capsys, command, "--out", tmp_path / "c1", "--quiet", *extra)
    one_line_error(err, code)
    assert "--out: " in err and "deep/meshes is a symbolic link" in err, err
    assert listing(outside) == set()
    assert listing(tmp_path / "c1") == {"deep", "deep/meshes"}
    # a FIFO where an output will go: refused before the work, not after it
    (out / "meshes").unlink()
    os.mkfifo(out / "carve.json")
    code, _, err = run(capsys, command, "--out", tmp_path / "c1", "--quiet", *extra)
    one_line_error(err, code)
    assert "deep/carve.json is not a regular file" in err, err
    assert listing(tmp_path / "c1") == {"deep", "deep/carve.json"}


def test_atomic_write_never_replaces_a_special_file(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "elsewhere")
    for path in (fifo, link, Path("/dev/null")):
        with pytest.raises(ValueError, match="not a regular file"):
            write_text_atomic(path, "x")
    assert fifo.is_fifo() and link.is_symlink() and not (tmp_path / "elsewhere").exists()


def test_urdf_out_symlink_refused(tmp_path, capsys):
    link = tmp_path / "arm.urdf"
    link.symlink_to(tmp_path / "victim")
    code, _, err = run(capsys, "urdf", "--out", link)
    one_line_error(err, code)
    assert link.is_symlink() and not (tmp_path / "victim").exists()


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["urdf", "--out", ""], "^--out: expected a file name"),
        (["urdf", "--out", "{tmp}"], "^--out: expected a file name|exists and is not a regular"),
        (["urdf", "--out", "{tmp}/missing/a.urdf"], "^--out: no such folder"),
        (["urdf", "--out", "{tmp}/link.urdf"], "^--out: .*symbolic link"),
        (["urdf", "--out", "/proc/version"], "^--out: "),
        (["ik", "--pos", "0.2", "0", "0.05", "--dir", "1", "0", "0", "--picture",
          "{tmp}/link.png"], "^--picture: .*symbolic link"),
        (["ik", "--pos", "0.2", "0", "0.05", "--dir", "1", "0", "0", "--picture",
          "{tmp}/dangling.png"], "^--picture: .*symbolic link"),
    ],
)  # fmt: skip
def test_output_file_options_are_named_and_checked_before_any_work(
    tmp_path, capsys, monkeypatch, argv, match
):
    """An output file is a file name in an existing folder, never written through a link;
    the refusal names the option and comes before the solve or the design's export."""
    (tmp_path / "target.png").write_bytes(b"x")
    (tmp_path / "link.png").symlink_to(tmp_path / "target.png")
    (tmp_path / "link.urdf").symlink_to(tmp_path / "target.png")
    (tmp_path / "dangling.png").symlink_to(tmp_path / "nowhere.png")
    import handarm.ik

    def no_work(*args, **kwargs):
        raise AssertionError("the solve ran before the output file was checked")

    monkeypatch.setattr(handarm.ik, "solve", no_work)
    code, out, err = run(capsys, *[a.replace("{tmp}", str(tmp_path)) for a in argv])
    one_line_error(err, code)
    assert re.search(match, err.split("error: ", 1)[-1]), err
    assert out == ""
    assert (tmp_path / "target.png").read_bytes() == b"x"
    assert not (tmp_path / "missing").exists() and not (tmp_path / "nowhere.png").exists()


@pytest.mark.parametrize("command", ["build", "carve", "workspace", "study", "optimize"])
def test_an_empty_out_is_refused_not_the_working_folder(tmp_path, capsys, monkeypatch, command):
    """--out '' was the working folder: build wrote design.toml, meshes/, ... there."""
    monkeypatch.chdir(tmp_path)
    argv = [command]
    if command == "study":
        (tmp_path / "s.toml").write_text(
            "voxel = 0.05\ndirections = 16\n[grid]\nlimit_deg_2 = [120, 150]\n"
        )
        argv.append("s.toml")
    if command == "optimize":
        argv.append(str(ROOT / "examples" / "optimize.toml"))
    before = listing(tmp_path)
    code, _, err = run(capsys, *argv, "--out", "")
    one_line_error(err, code)
    assert "--out: expected a folder name" in err, err
    assert listing(tmp_path) == before


@pytest.mark.parametrize("command", ["study", "optimize"])
def test_a_scheduler_that_is_no_address_is_named(tmp_path, capsys, command):
    """--scheduler foo said only "missing port number in address 'foo'"."""
    if command == "study":
        path = tmp_path / "s.toml"
        path.write_text("voxel = 0.05\ndirections = 16\n[grid]\nlimit_deg_2 = [120, 150]\n")
    else:
        path = ROOT / "examples" / "optimize.toml"
    for address in ("foo", "tcp://host:port", ""):
        code, _, err = run(
            capsys, command, path, "--out", tmp_path / "o", "--scheduler", address, "--quiet"
        )
        one_line_error(err, code)
        assert f"--scheduler: {address!r} is not a scheduler address" in err, err
        # refused before anything was written (optimize left an empty journal.log)
        assert not (tmp_path / "o").exists()


def test_build_folder_lock_marker_manifest_and_cleanup(tmp_path):
    out = tmp_path / "b"
    with build_folder(out, {"name": "one"}) as files:
        for name in ("a.txt", "old.txt"):
            write_text_atomic(out / name, name)
            files.append(out / name)
        with pytest.raises(ValueError, match="another build"):
            with build_folder(out, {"name": "two"}):
                pass
        assert (out / INCOMPLETE).exists()
    assert not (out / INCOMPLETE).exists()
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest == {"design": {"name": "one"}, "files": ["a.txt", "old.txt"]}
    # a killed write left a partial hidden temp file; a foreign file stays
    (out / ".a.txt.x1y2.tmp").write_text("partial")
    (out / "mine.txt").write_text("user's")
    with build_folder(out, {"name": "two"}) as files:
        assert not (out / ".a.txt.x1y2.tmp").exists()
        write_text_atomic(out / "a.txt", "again")
        files.append(out / "a.txt")
    assert listing(out) == {"a.txt", "mine.txt", MANIFEST, LOCK}
    # an interrupted build leaves the folder marked
    with pytest.raises(KeyboardInterrupt):
        with build_folder(out, {"name": "three"}):
            raise KeyboardInterrupt
    assert (out / INCOMPLETE).exists()


def test_calibrate_needs_force_to_overwrite(tmp_path, capsys):
    cal = tmp_path / "calibration.json"
    cal.write_text("precious")
    code, _, err = run(capsys, "bridge", "calibrate", "--port", tmp_path / "no-port", "--out", cal)
    one_line_error(err, code)
    assert "--force" in err and cal.read_text() == "precious"


def test_exit_codes_are_documented_in_the_readme():
    readme = (ROOT / "README.md").read_text()
    for code in EXIT_CODES:
        assert re.search(rf"^\| *{code} *\|", readme, re.M), code


# -- subprocess: special files, interrupts ----------------------------------------------------

ENV = dict(os.environ, PYTHONPATH=str(ROOT / "src"))


def cli(*argv):
    return [sys.executable, "-m", "handarm_cli", *map(str, argv)]


def test_fifo_as_design_file_does_not_hang(tmp_path):
    fifo = tmp_path / "arm.toml"
    os.mkfifo(fifo)
    r = subprocess.run(
        cli("urdf", fifo, "--out", tmp_path / "a.urdf"),
        capture_output=True,
        text=True,
        timeout=120,
        env=ENV,
    )
    one_line_error(r.stderr, r.returncode)
    assert "not a regular file" in r.stderr


def _as_at_a_terminal() -> None:
    """In the child before exec: SIGINT at its default, as a terminal starts a command.

    A child inherits an ignored SIGINT, and a test run started in the background by a
    non-interactive shell (``bash -c 'bash .ci/run &'``) ignores it: the command would then
    rightly ignore Ctrl-C too (``test_an_inherited_ignored_sigint_is_left_alone``).
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt(argv, delay, cwd):
    p = subprocess.Popen(
        cli(*argv),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        cwd=cwd,
        preexec_fn=_as_at_a_terminal,
    )
    time.sleep(delay)
    sent = time.perf_counter()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    return p.returncode, err, time.perf_counter() - sent


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.02, 0.2])
def test_ctrl_c_at_interpreter_start_ends_promptly(tmp_path, delay):
    # before the first line of handarm_cli runs only Python's own handling exists: killed by
    # the signal (a shell shows 130) or Python's KeyboardInterrupt report; never a hang
    code, err, took = _interrupt(["build", "--out", tmp_path / "b", "--quiet"], delay, tmp_path)
    assert code in (130, -signal.SIGINT, 1) and took < 10, err


def test_an_inherited_ignored_sigint_is_left_alone(tmp_path):
    """Started with SIGINT ignored (nohup, a background job), a command ignores Ctrl-C."""

    def ignore():
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    p = subprocess.Popen(
        cli("urdf", "--out", tmp_path / "a.urdf"),
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        preexec_fn=ignore,
    )
    for _ in range(10):  # during the imports and the command
        time.sleep(0.1)
        p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 0, err
    assert "<robot" in (tmp_path / "a.urdf").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("delay", [2.0, 4.0, 8.0, 15.0])
def test_ctrl_c_during_build_is_exit_130_and_one_line(tmp_path, delay):
    code, err, took = _interrupt(["build", "--out", tmp_path / "b", "--quiet"], delay, tmp_path)
    if code == 0:  # the build finished before the signal (a fast machine)
        return
    assert took < 10
    assert code == 130 and "Traceback" not in err, err
    assert err.strip().endswith("interrupted") and len(err.strip().splitlines()) == 1
    b = tmp_path / "b"
    assert not b.exists() or (b / INCOMPLETE).exists() or (b / MANIFEST).exists()
    assert set(os.listdir(tmp_path)) <= {"b"}


@pytest.mark.slow
def test_ctrl_c_during_a_study_stops_workers_quietly(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(
        'name = "s"\nvoxel = 0.04\ndirections = 12\n[grid]\nlimit_deg_2 = [120, 150]\n'
    )
    code, err, took = _interrupt(["study", study, "--out", tmp_path / "o", "--quiet"], 25, None)
    if code == 0:
        return
    assert code == 130 and "Traceback" not in err, err
    assert len(err.strip().splitlines()) == 1 and took < 10


_CTRL_C_IN_A_CALLBACK = """
import os, signal, sys, time, weakref
from handarm import cli
from handarm.cli import build

class Thing:
    pass

def slow_callback(ref):
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.5)  # the KeyboardInterrupt is raised here, inside the weakref callback

def command(args):
    thing = Thing()
    ref = weakref.ref(thing, slow_callback)
    del thing  # the callback runs now: Python can only ignore what it raises
    time.sleep(4)
    print("finished")
    return 0

build.cmd_build = command
sys.exit(cli.main(["build", "--out", sys.argv[1]]))
"""


_CTRL_C_TURNED_INTO_AN_ERROR = """
import os, signal, sys, time
from handarm import cli
from handarm.cli import build

def command(args):
    try:  # as numba does when Ctrl-C lands mid-compile: the interrupt becomes its own error
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(2)
    except KeyboardInterrupt:
        pass
    raise RuntimeError("no compiled object yet for <Library 'segment_distance'>")

build.cmd_build = command
sys.exit(cli.main(["build", "--out", sys.argv[1]]))
"""


def test_an_error_a_library_makes_of_ctrl_c_is_reported_as_the_interrupt(tmp_path):
    """Seen in CI: Ctrl-C 15 s into a fresh build cut numba's compile; exit was 3, not 130."""
    _assert_one_line_and_130(_run_script(tmp_path, _CTRL_C_TURNED_INTO_AN_ERROR))


def test_ctrl_c_inside_a_callback_python_ignores_still_ends_the_command(tmp_path):
    """Ctrl-C landing in a weakref callback (seen in CI during a build): one line, exit 130."""
    _assert_one_line_and_130(_run_script(tmp_path, _CTRL_C_IN_A_CALLBACK))


def _run_script(tmp_path, source: str) -> subprocess.CompletedProcess:
    script = tmp_path / "command.py"
    script.write_text(source)
    return subprocess.run(
        [sys.executable, script, tmp_path / "b"],
        capture_output=True,
        text=True,
        env=ENV,
        preexec_fn=_as_at_a_terminal,
    )


def _assert_one_line_and_130(done: subprocess.CompletedProcess) -> None:
    assert done.returncode == 130, done.stderr
    assert done.stderr == "handarm build: interrupted\n"
    assert "finished" not in done.stdout  # ended where the interrupt landed, not after it


_CTRL_C_IN_A_CONSTRUCTOR = """
import os, signal, sys, time
import handarm_cli
from handarm.cli import build

class Handle:  # as llvmlite's ObjectRef: __del__ needs what __init__ had not yet set
    def __init__(self):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.5)  # the KeyboardInterrupt is raised here
        self.handle = 1

    def __del__(self):
        del self.handle

kept = []

class Keeper(Handle):
    def __new__(cls):
        self = super().__new__(cls)
        kept.append(self)  # lives until the interpreter's teardown
        return self

def command(args):
    Keeper()
    print("finished")
    return 0

build.cmd_build = command
sys.argv = ["handarm", "build", "--out", sys.argv[1]]
sys.exit(handarm_cli.main())
"""


def test_ctrl_c_inside_a_constructor_leaves_no_teardown_noise(tmp_path):
    """CI: Ctrl-C in llvmlite's ObjectRef.__init__; its __del__ failed at exit, a traceback."""
    _assert_one_line_and_130(_run_script(tmp_path, _CTRL_C_IN_A_CONSTRUCTOR))


# -- 2. carving never writes an unprintable part ---------------------------------------------

EXTREME = [
    # the largest clearance: a 9 mm motor pulley, as 8 mm leaves its drum too thin (refused)
    {"clearance": 0.001, "cheek_thickness": 0.002, "motor_pulley_radius": 0.009},
    {"axle_diameter": 0.0139},  # the thinnest bore wall the bounds allow
    {"cheek_thickness": 0.0008, "clearance": 0.0004},
    {"hub_radius": 0.024},  # fits the 50 mm links, but its sweeps cut them apart
    {"link_lengths": [0.02] * 7},
    {"beam_width": 0.018, "beam_thickness": 0.002},
]


@pytest.mark.slow
@pytest.mark.parametrize("changes", EXTREME)
def test_extreme_loadable_designs_carve_healthy_or_fail_in_one_line(changes):
    from handarm.carve import carve
    from handarm.carve.carving import _healthy

    design = ArmDesign(**changes)
    try:
        result = carve(design, 5.0)
    except ValueError as exc:
        msg = str(exc)
        assert "\n" not in msg and msg.split(":")[0] in FIELDS
        assert re.search(r"joints? \d", msg) and re.search(r"link l\d", msg)
        return
    for link in result.links:
        assert len(link.solid.decompose()) == 1, link.name
        assert _healthy(link.blank, link.solid), link.name
