import json
import math
import subprocess

import numpy as np
import pytest

import handarm
from handarm.firmware_bridge.calibration import Calibration
from handarm.firmware_bridge.export import (
    controller_config,
    write_controller_json,
    write_header,
)


@pytest.fixture
def design():
    return handarm.ArmDesign()


def test_controller_json(tmp_path, design):
    cal = Calibration.record(design, [2000, 100, 3000, 2048, 4000, 10])
    achieved = [(-math.radians(136), math.radians(136))] + [(-3.0, 3.0)] * 5
    config = controller_config(design, cal, achieved)
    path = write_controller_json(config, tmp_path / "controller.json")
    data = json.loads(path.read_text())
    assert data["schema"] == "handarm.controller/1"
    assert [s["id"] for s in data["servos"]] == [1, 2, 3, 4, 5, 6]
    assert all(s["model_number"] == 310 and s["protocol"] == 1.0 for s in data["servos"])
    assert [s["mode"] for s in data["servos"]] == ["joint"] + ["multi-turn"] * 5
    k, kinv = np.array(data["coupling"]["K"]), np.array(data["coupling"]["K_inv"])
    np.testing.assert_allclose(k @ kinv, np.eye(6), atol=1e-12)
    # achieved limits are intersected with the design's
    assert data["joint_limits_rad"][0][1] == pytest.approx(design.upper[0])
    assert data["calibration"]["offsets_ticks"] == [2000, 100, 3000, 2048, 4000, 10]
    s1 = data["servos"][0]
    assert s1["cw_angle_limit"] == math.floor(2000 - 1536) and s1["ccw_angle_limit"] == math.ceil(
        2000 + 1536
    )


def test_tighter_achieved_limits_are_exported(design):
    achieved = [(-1.0, 1.0)] * 6
    config = controller_config(design, achieved_limits=achieved)
    assert config["joint_limits_rad"] == [[-1.0, 1.0]] * 6


def test_header_compiles_and_matches(tmp_path, design):
    config = controller_config(design)
    write_header(config, tmp_path / "arm_config.h")
    (tmp_path / "use.c").write_text(
        '#include "arm_config.h"\n'
        "double joint0(const double *phi) {\n"
        "  double s = 0; for (int k = 0; k < 6; ++k) s += HANDARM_K_INV[0][k] * phi[k];\n"
        "  s += HANDARM_K[5][5] + HANDARM_JOINT_LOWER_RAD[0] + HANDARM_JOINT_UPPER_RAD[0];\n"
        "  s += HANDARM_LINK_LENGTH_M[6] + HANDARM_SERVO_ID[0] + HANDARM_MULTI_TURN[1];\n"
        "  s += HANDARM_CW_ANGLE_LIMIT[0] + HANDARM_CCW_ANGLE_LIMIT[0] + HANDARM_MAX_TORQUE[0];\n"
        "  return s + HANDARM_ZERO_TICKS[0] + HANDARM_TICKS_PER_RAD + HANDARM_BAUD_RATE;\n}\n"
    )
    result = subprocess.run(
        ["cc", "-c", "-std=c99", "-Wall", "-Wextra", "-Werror", "use.c", "-o", "use.o"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "HANDARM_SERVO_ID[6] = {1, 2, 3, 4, 5, 6}" in (tmp_path / "arm_config.h").read_text()


def test_design_name_cannot_escape_the_header_comment(tmp_path, design):
    name = "x */ int injected = 1; /* y"
    with pytest.raises(ValueError, match="name: .* not a file-name-safe label"):
        design.replace(name=name)  # refused at the door ...
    config = controller_config(design)
    config["design"] = name  # ... and escaped in the header anyway (defence in depth)
    write_header(config, tmp_path / "arm_config.h")
    (tmp_path / "use.c").write_text(
        '#include "arm_config.h"\nint injected = 2;\nint f(void) { return injected; }\n'
    )
    result = subprocess.run(
        ["cc", "-c", "-std=c99", "-Wall", "-Werror", "use.c", "-o", "use.o"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    # had the name closed the comment, 'injected' would be defined twice
    assert result.returncode == 0, result.stderr
    first = (tmp_path / "arm_config.h").read_text().splitlines()[0]
    assert first.startswith("/*") and first.endswith("*/") and first.count("*/") == 1


def test_no_ros2_control_output(tmp_path, design):
    from handarm.pipeline import export_controller

    paths = export_controller(design, tmp_path / "ctl")
    assert sorted(p.name for p in paths) == ["arm_config.h", "controller.json"]
    assert sorted(p.name for p in (tmp_path / "ctl").iterdir()) == [
        "arm_config.h",
        "controller.json",
    ]


def test_bad_export_arguments(design):
    with pytest.raises(ValueError, match="max_torque_fraction"):
        controller_config(design, max_torque_fraction=0.0)
    with pytest.raises(ValueError, match="achieved_limits"):
        controller_config(design, achieved_limits=[(0, 1)] * 5)


def test_calibration_round_trip_and_refusals(tmp_path, design):
    cal = Calibration.record(design, [1, 2, 3, 4, 5, 6])
    path = cal.save(tmp_path / "cal.json")
    assert Calibration.load(path, design) == cal
    assert not list(tmp_path.glob("*.tmp"))
    other = design.replace(servo_ids=(11, 12, 13, 14, 15, 16))
    with pytest.raises(ValueError, match="servo_ids .* do not match"):
        Calibration.load(path, other)
    data = json.loads(path.read_text())
    data["model_number"] = 311
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"for MX-64T \(model 311\), .*MX-64T \(model 310\)"):
        Calibration.load(path, design)
    path.write_text("{")
    with pytest.raises(ValueError, match="not valid JSON"):
        Calibration.load(path)
    path.write_text('{"schema": "other"}')
    with pytest.raises(ValueError, match="not a handarm calibration"):
        Calibration.load(path)
    with pytest.raises(FileNotFoundError, match="calibration: no such file"):
        Calibration.load(tmp_path / "none.json")
    data = cal.to_dict()
    for bad in (1.5, "7", True, 2.0):
        data["offsets"] = [bad, 2, 3, 4, 5, 6]
        path.write_text(json.dumps(data))
        with pytest.raises(ValueError, match="offsets\\[0\\]: expected an integer"):
            Calibration.load(path)
