"""handarm's public face: lazy subpackages, sane result values, no backend changes."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import handarm

ROOT = Path(__file__).resolve().parents[1]


def _run(code: str) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_subpackages_work_without_importing_them_first():
    out = _run(
        "import handarm, sys\n"
        "assert 'handarm.ik' not in sys.modules  # lazy: not loaded by import handarm\n"
        "d = handarm.ArmDesign()\n"
        "r = handarm.ik.solve(d, [0.2, 0.05, 0.05], [1, 0, 0.3])\n"
        "print(r.count)\n"
        "print(handarm.carve.link_blank(d, 1).name)\n"
        "print(handarm.workspace.direction_set(16).shape)\n"
        "print(handarm.firmware_bridge.export.controller_config(d)['schema'])\n"
        "print(handarm.cad_out.urdf_string(d)[:5])\n"
        "print(handarm.build.__name__, handarm.transmission.coupling_matrix(d).shape)\n"
    )
    lines = out.split()
    assert int(lines[0]) >= 1
    assert "l1" in out and "(16, 3)" in out and "handarm.controller/1" in out
    assert "<?xml" in out and "build" in out


def test_importing_handarm_modules_leaves_the_matplotlib_backend_alone():
    out = _run(
        "import matplotlib\n"
        "matplotlib.use('svg')\n"
        "import handarm, handarm.cad_out.pictures, handarm.workspace.plots, handarm.pipeline\n"
        "import handarm.workspace.study_results\n"
        "import matplotlib.pyplot as plt\n"
        "print(matplotlib.get_backend(), len(plt.get_fignums()))\n"
    )
    assert out.split() == ["svg", "0"]


def test_result_values_compare_and_hash(design):
    r = handarm.ik.solve(design, [0.2, 0.05, 0.05], [1, 0, 0.3])
    assert r == r and r != handarm.ik.solve(design, [0.2, 0.05, 0.05], [1, 0, 0.3])
    assert isinstance(hash(r), int)
    b = handarm.ik.solve_batch(design, np.array([[0.2, 0.05, 0.05]]), np.array([[1, 0, 0.3]]))
    assert b == b and isinstance(hash(b), int)
    m = handarm.workspace.reachability_map(design, 0.1, 12)
    assert m == m and isinstance(hash(m), int)
    blank = handarm.carve.link_blank(design, 2)
    assert blank == blank and isinstance(hash(blank), int)
    assert blank.parts[0] == blank.parts[0]
    # designs are plain values: equal by content
    assert design == handarm.ArmDesign() and hash(design) == hash(handarm.ArmDesign())


def test_one_servo_specification_everywhere(design):
    from handarm.firmware_bridge import emulator, export, mx64
    from handarm.servo import SERVOS
    from handarm.transmission import joint_effort_limits, joint_velocity_limits, motor_ranges

    spec = SERVOS[design.servo_model]
    assert design.servo is spec
    assert emulator.EmulatedServo(1).get("model_number") == spec.model_number
    assert mx64.MODEL_NUMBER == spec.model_number
    assert mx64.MULTI_TURN_LIMIT == spec.multi_turn_limit
    config = export.controller_config(design)
    assert config["ticks_per_rad"] == pytest.approx(spec.ticks_per_rev / (2 * np.pi))
    assert {s["model_number"] for s in config["servos"]} == {spec.model_number}
    assert {s["max_torque"] for s in config["servos"]} == {spec.max_torque_register}
    k = handarm.transmission.coupling_matrix(design)
    np.testing.assert_allclose(joint_effort_limits(design), np.abs(k).sum(0) * spec.stall_torque)
    np.testing.assert_allclose(joint_velocity_limits(design), spec.no_load_speed / np.abs(k).max(0))
    assert motor_ranges(design)[0].ticks_per_radian == spec.ticks_per_radian


def test_library_errors_never_name_cli_options():
    """Option names (--port, --out, ...) are the CLI's business; the library names arguments."""
    pattern = re.compile(r"""(?:Error|UsageError)\(\s*f?["'][^"']*--[a-z]""")
    for path in (ROOT / "src" / "handarm").rglob("*.py"):
        if "cli" in path.parts:
            continue
        assert not pattern.search(path.read_text()), path


def test_build_is_a_library_function_returning_what_it_wrote(tmp_path):
    # the CLI's build test checks the files; here the library's return value
    d = handarm.ArmDesign(link_lengths=[0.04] * 7, name="small")
    result = handarm.build(d, tmp_path, voxel=0.05, directions=16, resolution_deg=3.0)
    assert result.out == tmp_path and result.design == d
    names = {p.relative_to(tmp_path).as_posix() for p in result.files}
    assert {"design.toml", "summary.txt", "plate.3mf", "small.urdf", "carve.json"} <= names
    assert all(p.exists() and p.stat().st_size > 0 for p in result.files)
    assert len(result.achieved_limits) == 6
