import json

import pytest

from handarm.cli import main
from handarm.firmware_bridge.emulator import WRITE, EmulatedBus

TIMEOUT = 1000  # ms: on a loaded machine the emulator thread can answer late
START = {1: 2000, 2: 100, 3: 3000, 4: 2048, 5: 4000, 6: 10}


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_export_and_size(tmp_path, capsys):
    code, out, err = run(capsys, "bridge", "export", "--out", tmp_path / "ctl")
    assert code == 0, err
    assert json.loads((tmp_path / "ctl" / "controller.json").read_text())["servos"][0]["id"] == 1
    code, out, err = run(capsys, "bridge", "size", "--no-carve", "--json")
    assert code == 0, err
    report = json.loads(out)
    assert report["payload_kg"] > 0 and len(report["sized_joint_pulley_radii_mm"]) == 6
    assert report["link_masses_from"].startswith("design estimate")


@pytest.mark.slow
def test_size_with_carved_link_masses(capsys):
    code, out, err = run(capsys, "bridge", "size", "--json")
    assert code == 0, err
    carved = json.loads(out)
    assert carved["link_masses_from"] == "carved meshes"
    estimate = json.loads(run(capsys, "bridge", "size", "--no-carve", "--json")[1])
    # carving removes material: every carved link is lighter than its solid-beam estimate
    # plus hubs, and the payload the motors can lift changes accordingly
    masses = carved["link_masses_kg"]
    assert len(masses) == 6 and all(0.001 < m < 0.05 for m in masses)
    assert carved["payload_kg"] != pytest.approx(estimate["payload_kg"], rel=1e-6)
    assert carved["payload_kg"] > 0


def test_live_bus_commands(tmp_path, capsys):
    with EmulatedBus(positions=START) as emu:
        cal = tmp_path / "cal.json"
        code, out, err = run(
            capsys, "bridge", "calibrate", "--port", emu.port, "--timeout", TIMEOUT, "--out", cal
        )
        assert code == 0, err
        code, out, err = run(
            capsys,
            "bridge",
            "apply",
            "--port",
            emu.port,
            "--timeout",
            TIMEOUT,
            "--calibration",
            cal,
        )
        assert code == 0, err
        assert out.count("(verified)") == 6
        code, out, err = run(
            capsys,
            "bridge",
            "goto",
            "10",
            "-20",
            "30",
            "40",
            "-50",
            "60",
            "--port",
            emu.port,
            "--timeout",
            TIMEOUT,
            "--calibration",
            cal,
        )
        assert code == 0, err
        code, out, err = run(
            capsys, "bridge", "read", "--port", emu.port, "--timeout", TIMEOUT, "--calibration", cal
        )
        assert code == 0, err
        angles = [float(v) for v in out.split()]
        assert angles == pytest.approx([10, -20, 30, 40, -50, 60], abs=0.1)
        before = len(emu.log)
        code, out, err = run(
            capsys,
            "bridge",
            "goto",
            "170",
            "0",
            "0",
            "0",
            "0",
            "0",
            "--port",
            emu.port,
            "--timeout",
            TIMEOUT,
            "--calibration",
            cal,
        )
        assert code == 2 and "outside joint 1's limits" in err
        assert len(emu.log) == before  # refused before touching the bus


def test_bus_faults_are_one_line(tmp_path, capsys):
    with EmulatedBus(silent=[4]) as emu:
        code, out, err = run(capsys, "bridge", "apply", "--port", emu.port, "--timeout", 200)
        assert code == 5  # a bus failure
        assert "handarm bridge apply: error: nothing was written: joint 4" in err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert [e for e in emu.log if e[1] == WRITE] == []
    code, out, err = run(
        capsys,
        "bridge",
        "read",
        "--port",
        tmp_path / "nope",
        "--calibration",
        tmp_path / "none.json",
    )
    assert code == 2 and "calibration file not found" in err
