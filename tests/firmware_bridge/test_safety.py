"""Every safety behaviour of the bridge, against the emulated MX-64T bus (issue 12)."""

import io
import json
import re
import socket
import sys
import time

import numpy as np
import pytest

import handarm
from handarm import ik
from handarm.cli import main
from handarm.firmware_bridge import bus as B
from handarm.firmware_bridge.emulator import (
    ERR_OVERHEAT,
    ERR_RANGE,
    SYNC_WRITE,
    WRITE,
    EmulatedBus,
)
from handarm.firmware_bridge.mx64 import from_unsigned16
from handarm.transmission import joint_from_motor, motor_from_joint, motor_from_ticks

TIMEOUT = 1000.0  # ms: on a loaded machine the emulator thread can answer late
START = {1: 2000, 2: 100, 3: 3000, 4: 2048, 5: 4000, 6: 10}


@pytest.fixture
def design():
    return handarm.ArmDesign()


def writes(emu, since=0):
    return [e for e in emu.log[since:] if e[1] in (WRITE, SYNC_WRITE)]


def ready(emu, bus, design):
    cal = B.record_calibration(bus, design)
    B.apply_settings(bus, design, cal)
    return cal


def streamed_poses(emu, design, cal, since):
    """Joint angles of every SYNC_WRITE goal the emulator received (decoded independently)."""
    out = []
    for sid, inst, params in emu.log[since:]:
        if sid != 0xFE or inst != SYNC_WRITE:
            continue
        size = params[1]
        raw = {}
        for k in range(2, len(params) - size, size + 1):
            raw[params[k]] = int.from_bytes(params[k + 1 : k + 3], "little")
        ticks = [raw[1]] + [from_unsigned16(raw[i]) for i in range(2, 7)]
        out.append(joint_from_motor(design, motor_from_ticks(design, ticks, cal.offsets)))
    return np.array(out)


def collides_on_the_way(design, rng):
    """Two valid poses whose straight joint-space line is not valid (found by sampling)."""
    while True:
        a, b = rng.uniform(design.lower, design.upper, (2, 6))
        if not handarm.is_valid(design, np.stack([a, b])).all():
            continue
        line = a + np.linspace(0, 1, 4001)[:, None] * (b - a)
        if not handarm.is_valid(design, line).all():
            return a, b


def test_power_cycled_bent_arm_is_refused(design):
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        bent = np.radians([0, 120, 0, 0, 0, 0])
        B.goto(bus, design, cal, bent, rate=200.0)
        emu.power_cycle()
        before = len(emu.log)
        with pytest.raises(B.ArmStateError, match="powered off since the calibration"):
            B.goto(bus, design, cal, np.zeros(6))
        assert writes(emu, before) == []
        # a servo that kept its marker but lost its turn: the pose itself is refused
        for servo in emu.servos.values():
            servo.table[25] = 1
        with pytest.raises(B.ArmStateError, match="present pose: joint \\d at .* outside"):
            B.goto(bus, design, cal, np.zeros(6))
        assert writes(emu, before) == []


def test_unapplied_servos_and_preset_registers_are_refused(design):
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = B.record_calibration(bus, design)  # never applied
        before = len(emu.log)
        with pytest.raises(B.ArmStateError, match="servo 2 cw_angle_limit: reads 0, apply"):
            B.goto(bus, design, cal, np.radians([5, 0, 0, 0, 0, 0]))
        assert writes(emu, before) == []
        B.apply_settings(bus, design, cal)
        bus.write(3, "resolution_divider", 2)
        bus.write(4, "multi_turn_offset", 100)
        before = len(emu.log)
        with pytest.raises(B.ArmStateError) as info:
            B.goto(bus, design, cal, np.radians([5, 0, 0, 0, 0, 0]))
        assert "servo 3 resolution_divider: reads 2" in str(info.value)
        assert "servo 4 multi_turn_offset: reads 100" in str(info.value)
        assert writes(emu, before) == []


def test_mismatched_calibration_is_refused(design):
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        other = cal.__class__(**{**cal.__dict__, "offsets": (1900,) + cal.offsets[1:]})
        before = len(emu.log)
        with pytest.raises(B.ArmStateError, match="servo 1 cw_angle_limit: reads"):
            B.goto(bus, design, other, np.zeros(6))
        assert writes(emu, before) == []


def test_goto_plans_again_when_the_arm_moved_while_it_planned(design, monkeypatch):
    """The arm is limp while goto plans (seconds with a scene): joint 6 turned by hand
    meanwhile was held at torque-on where it was, then the first sample jumped back to the
    old start, a jump no check had seen. goto now reads the pose again and plans from it;
    an arm that keeps moving is refused with nothing sent."""
    from handarm.firmware_bridge.emulator import SYNC_WRITE, WRITE

    turned = []
    plan = B.plan_move

    def turning_plan(*args, **kwargs):
        out = plan(*args, **kwargs)
        if len(turned) < turns:
            emu.servos[6].real += 300  # a hand turns motor 6 (about 26 deg) meanwhile
            emu.servos[6]._sync_present()
            turned.append(args[2])
        return out

    monkeypatch.setattr(B, "plan_move", turning_plan)
    goal = np.radians([0, 0, 0, 0, 0, 20])
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        turns = 1
        before = len(emu.log)
        samples = B.goto(bus, design, cal, goal, rate=200.0)
        assert len(turned) == 1  # the second plan started from the turned pose
        assert np.abs(samples[0] - turned[0]).max() > np.radians(10)
        poses = streamed_poses(emu, design, cal, before)
        assert np.abs(poses[0] - samples[0]).max() < 2 * B.pose_slack(design).max()
        steps = np.abs(np.diff(poses, axis=0)).max()
        assert steps < np.radians(5)  # no jump back to the old start
        # a hand that never stops: refused after REPLANS + 1 plans, nothing written
        turned.clear()
        turns = B.REPLANS + 1
        before = len(emu.log)
        with pytest.raises(B.ArmStateError, match="the arm moved while each of 3 paths"):
            B.goto(bus, design, cal, np.zeros(6), rate=200.0)
        assert [e for e in emu.log[before:] if e[1] in (WRITE, SYNC_WRITE)] == []


def test_a_goal_at_a_joint_limit_leaves_a_pose_the_next_command_accepts(design):
    """goto to +150 deg on joint 6 rounded its motors to whole ticks, read back as
    150.03 deg, and every later command refused the arm as miscalibrated: a pose within
    pose_slack of a limit is at the limit; one farther out is still refused."""
    from handarm.transmission import joint_from_motor, motor_from_ticks

    lo, hi = design.lower, design.upper
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        over = 0
        for k, side in ((5, hi), (1, lo), (4, hi)):
            goal = np.zeros(6)
            goal[k] = side[k]
            B.goto(bus, design, cal, goal, rate=200.0)
            ticks = np.array([emu.servos[i].get("goal_position") for i in range(1, 7)])
            raw = joint_from_motor(
                design, motor_from_ticks(design, ticks.astype(float), cal.offsets)
            )
            over += not (lo[k] <= raw[k] <= hi[k])  # the rounded goal maps past the limit
            q = B.present_pose(bus, design, cal)
            assert q[k] == pytest.approx(side[k], abs=1e-12)
            B.goto(bus, design, cal, np.zeros(6), rate=200.0)  # refused before the fix
        assert over >= 1  # the case the fix is for did occur
        # twenty ticks on motor 6 (about 1.8 deg on joint 6) is no rounding: refused
        slack = B.pose_slack(design)
        assert 0 < slack.max() < np.radians(0.5)
        goal = np.zeros(6)
        goal[5] = hi[5]
        B.goto(bus, design, cal, goal - np.array([0, 0, 0, 0, 0, 1e-3]), rate=200.0)
        emu.servos[6].real += 20
        emu.servos[6]._sync_present()
        with pytest.raises(B.ArmStateError, match="joint 6 at .* outside its limits"):
            B.present_pose(bus, design, cal)


@pytest.mark.parametrize("reply_level", ["new", "old"])
def test_apply_at_every_status_return_level_and_fixes_presets(design, reply_level):
    """Whichever level decides the answer to writing the level, no stray packet is left."""
    emulator = EmulatedBus(positions=START, reply_level=reply_level)
    with emulator as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        emu.servos[2].table[16] = 1
        emu.servos[5].table[16] = 0
        emu.servos[3].table[22] = 2
        emu.servos[4].table[20:22] = (100).to_bytes(2, "little")
        settings = B.apply_settings(bus, design, None, max_torque_fraction=0.5)
        for sid, regs in settings.items():
            for name, value in regs.items():
                assert emu.servos[sid].get(name) == value
        assert all(emu.servos[s].get("max_torque") == 512 for s in range(1, 7))
        assert all(emu.servos[s].get("torque_limit") == 512 for s in range(1, 7))
        assert all(emu.servos[s].get("torque_enable") == 0 for s in range(1, 7))


def test_apply_reports_what_was_written_before_a_failure(design):
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        servo = emu.servos[3]
        original = servo.write
        servo.write = lambda addr, data: ERR_RANGE if addr == 14 else original(addr, data)
        with pytest.raises(B.BusError) as info:
            B.apply_settings(bus, design)
        msg = str(info.value)
        assert "servo 3: write max_torque" in msg
        assert "written before the failure: servo 1 torque_enable=0" in msg
        assert "servo 3 resolution_divider=1" in msg and "servo 3 max_torque" not in msg


@pytest.mark.slow
def test_goto_plans_around_a_collision_and_streams_valid_poses(design, rng):
    a, b = collides_on_the_way(design, rng)
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        B.goto(bus, design, cal, a, rate=200.0)
        before = len(emu.log)
        B.goto(bus, design, cal, b, rate=200.0)
        poses = streamed_poses(emu, design, cal, before)
        assert len(poses) > 2
        assert handarm.is_valid(design, poses).all()
        # between streamed poses too (independent dense check, 0.02 degree steps)
        dense = [
            qa
            + np.linspace(0, 1, int(np.abs(qb - qa).max() / np.radians(0.02)) + 2)[:, None]
            * (qb - qa)
            for qa, qb in zip(poses[:-1], poses[1:], strict=True)
        ]
        assert handarm.is_valid(design, np.concatenate(dense)).all()
        tick = 2 * np.pi / 4096
        np.testing.assert_allclose(
            motor_from_joint(design, poses[-1]), motor_from_joint(design, b), atol=tick
        )
        # motor speed between periods stays within the limit (one tick of rounding)
        from handarm.firmware_bridge.motion import MotionLimits

        v = MotionLimits(design).velocity
        steps = np.abs(motor_from_joint(design, np.diff(poses, axis=0))).max(axis=1)
        assert steps.max() <= v / 200.0 + 2 * tick
        # no path in the time given: refused, nothing sent
        before = len(emu.log)
        with pytest.raises(B.PlanningError, match="no collision-free path"):
            B.goto(bus, design, cal, a, rate=200.0, timeout=1e-6)
        assert writes(emu, before) == []


def _dense(poses, step_deg=0.02):
    """Straight joint-space lines between consecutive poses, sampled every ``step_deg``."""
    return np.concatenate(
        [
            qa
            + np.linspace(0, 1, int(np.abs(qb - qa).max() / np.radians(step_deg)) + 2)[:, None]
            * (qb - qa)
            for qa, qb in zip(poses[:-1], poses[1:], strict=True)
        ]
    )


def test_goto_in_a_scene_goes_around_the_obstacle(design):
    """A sphere on the straight path's tool track: the move goes around it, keeping c."""
    from handarm.scene import Scene, scene_gaps

    a = np.radians([0, 40, -30, 20, 10, 0])
    b = np.radians([60, 40, -30, 20, 10, 0])
    mid, _ = handarm.forward(design, (a + b) / 2)
    scene = Scene.empty().with_sphere(mid, 0.015, name="ball")
    c = 0.003
    assert scene_gaps(design, _dense(np.stack([a, b])), scene).min() < 0  # the line hits it
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        B.goto(bus, design, cal, a, rate=200.0)
        before = len(emu.log)
        B.goto(bus, design, cal, b, rate=200.0, scene=scene, clearance=c)
        poses = streamed_poses(emu, design, cal, before)
        # every pose and the lines between them keep the clearance (dense, independent)
        dense = _dense(poses)
        assert handarm.is_valid(design, dense).all()
        assert scene_gaps(design, dense, scene, c).min() >= 0
        tick = 2 * np.pi / 4096
        np.testing.assert_allclose(
            motor_from_joint(design, poses[-1]), motor_from_joint(design, b), atol=tick
        )
        # a goal inside the obstacle's clearance: refused naming it, nothing sent
        before = len(emu.log)
        q_in = np.radians([30, 40, -30, 20, 10, 0])
        with pytest.raises(B.PlanningError, match=r"goal: .* of ball; nothing was sent"):
            B.goto(bus, design, cal, q_in, rate=200.0, scene=scene, clearance=c)
        assert writes(emu, before) == []


def test_follow_in_a_scene_keeps_clear_and_holds_before_a_blocked_target(design):
    from handarm.firmware_bridge.follow import TargetSource, follow
    from handarm.scene import Scene, scene_gaps

    a = np.radians([0, 40, -30, 20, 10, 0])
    goal = np.radians([60, 40, -30, 20, 10, 0])
    mid, e_mid = handarm.forward(design, np.radians([30, 40, -30, 20, 10, 0]))
    scene = Scene.empty().with_sphere(mid, 0.015, name="ball")
    c = 0.003
    p_goal, e_goal = handarm.forward(design, goal)
    lines = [json.dumps({"p": list(p_goal), "e": list(e_goal)})] * 3
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        B.goto(bus, design, cal, a, rate=200.0)
        before = len(emu.log)
        follow(
            bus, design, cal, TargetSource(lines, paced=True), rate=100.0, max_periods=300,
            scene=scene, clearance=c,
        )  # fmt: skip
        poses = streamed_poses(emu, design, cal, before)
        assert len(poses) > 3
        dense = _dense(poses)
        assert handarm.is_valid(design, dense).all()
        assert scene_gaps(design, dense, scene, c).min() >= 0
        # a target whose every exact solution meets the ball: the arm holds where it is
        assert ik.solve(design, mid, e_mid, degrade=False).count > 0  # reachable, but blocked
        inside = [json.dumps({"p": list(mid), "e": list(e_mid)})] * 20
        before = len(emu.log)
        q_before = poses[-1]
        stats = follow(
            bus, design, cal, TargetSource(inside, paced=True), rate=100.0, max_periods=30,
            scene=scene, clearance=c,
        )  # fmt: skip
        held = streamed_poses(emu, design, cal, before)
        assert np.abs(held - q_before).max(initial=0.0) < 2 * 2 * np.pi / 4096
        assert stats["blocked_by"] == ["ball"]
        # the present pose itself within the clearance of an obstacle: refused, nothing sent
        tip, _ = handarm.forward(design, held[-1] if len(held) else q_before)
        near = Scene.empty().with_sphere(tip, 0.01, name="hand")
        goals = [emu.servos[i].get("goal_position") for i in range(1, 7)]
        with pytest.raises(B.PlanningError, match=r"^present pose: .* of hand; nothing was sent"):
            follow(bus, design, cal, TargetSource(lines), max_periods=5, scene=near, clearance=c)
        assert [emu.servos[i].get("goal_position") for i in range(1, 7)] == goals


def test_overheating_stops_the_move_and_holds(design):
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        emu.servos[4].fault_after = (emu.servos[4].goals + 3, ERR_OVERHEAT)
        with pytest.raises(B.ServoFault, match="servo 4 stopped the move: .*overheating"):
            B.goto(bus, design, cal, np.radians([40, 30, 20, 10, 0, 0]), rate=100.0)
        # held: every goal equals the present position
        for servo in emu.servos.values():
            assert servo.get("goal_position") == servo.get("present_position")


def test_torque_and_stop(design):
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        ready(emu, bus, design)
        B.set_torque(bus, design, True)
        assert all(s.get("torque_enable") == 1 for s in emu.servos.values())
        ticks = B.hold(bus, design)
        assert [emu.servos[i].get("goal_position") for i in range(1, 7)] == [
            t & 0xFFFF for t in ticks
        ]
        B.set_torque(bus, design, False)
        assert all(s.get("torque_enable") == 0 for s in emu.servos.values())


def test_duplicate_ids_wrong_baud_scan_and_setup(design):
    with EmulatedBus(duplicates=[3]) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        with pytest.raises(B.BusError, match="two servos answer as ID 3"):
            B.check_servos(bus, design)
    with EmulatedBus() as emu, B.ServoBus(emu.port, 57_600, 100) as bus:
        with pytest.raises(B.BusError, match="no servo answers at 57600 .*bridge scan"):
            B.check_servos(bus, design)
    with EmulatedBus(ids=[1], bauds={1: 57_600}) as emu:
        found = B.scan(emu.port, [57_600, 1_000_000], range(0, 5), 100)
        assert [(f["id"], f["baud"], f["model_number"]) for f in found] == [(1, 57_600, 310)]
        result = B.setup_servo(emu.port, design, 4, [57_600, 1_000_000], range(0, 5), 100)
        assert result == {"id": 4, "baud": 1_000_000, "was": {"id": 1, "baud": 57_600}}
        servo = emu.servos[4]
        assert servo.get("id") == 4 and servo.get("baud_rate") == 1


def test_shared_bauds_are_the_servo_rates_the_installed_sdk_opens():
    """``BAUD_VALUES`` against the SDK's own list: a scan tried 200,000 bit/s and stopped."""
    from dynamixel_sdk import PortHandler

    from handarm.firmware_bridge.mx64 import BAUD_VALUES, SDK_BAUDS, SERVO_BAUD_REGISTER

    port = PortHandler("/dev/null")  # not opened: getCFlagBaud only looks at the number
    opens = {b for b in (*SDK_BAUDS, *SERVO_BAUD_REGISTER) if port.getCFlagBaud(b) > 0}
    assert opens == set(SDK_BAUDS)
    assert set(BAUD_VALUES) == set(SERVO_BAUD_REGISTER) & opens
    assert {200_000, 250_000, 400_000, 2_250_000}.isdisjoint(BAUD_VALUES)
    assert all(BAUD_VALUES[b] == SERVO_BAUD_REGISTER[b] for b in BAUD_VALUES)


def test_scan_and_setup_at_every_rate_find_a_servo_off_factory_settings(design, capsys):
    """No ``bauds``: every shared rate is tried (a servo at 1 Mbit/s, ID 2, is found)."""
    with EmulatedBus(ids=[2], bauds={2: 1_000_000}) as emu:
        found = B.scan(emu.port, None, range(0, 3), 30)
        assert [(f["id"], f["baud"]) for f in found] == [(2, 1_000_000)]
        assert main(["bridge", "scan", "--port", emu.port, "--ids", "0-2", "--timeout", "30"]) == 0
        out, err = capsys.readouterr()
        assert "1000000" in out and "error" not in err
        result = B.setup_servo(emu.port, design, 5, None, range(0, 3), 30)
        assert result == {"id": 5, "baud": 1_000_000, "was": {"id": 2, "baud": 1_000_000}}
    with EmulatedBus(ids=[1], bauds={1: 200_000}) as emu:  # set so by another tool
        assert B.scan(emu.port, None, range(0, 2), 30) == []


def test_follow_loop_streams_valid_limited_steps(design, tmp_path):
    from handarm.firmware_bridge.follow import TargetSource, follow
    from handarm.firmware_bridge.motion import MotionLimits
    from handarm.kinematics import forward

    q_goal = np.radians([20, 30, -20, 10, 10, 0])
    p, e = forward(design, q_goal)
    lines = [json.dumps({"p": list(p), "e": list(e)})] * 3
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        before = len(emu.log)
        stats = follow(
            bus, design, cal, TargetSource(lines, paced=True), rate=100.0, max_periods=400
        )
        poses = streamed_poses(emu, design, cal, before)
    assert stats["targets"] == 3 and len(poses) > 3
    assert handarm.is_valid(design, poses).all()
    v = MotionLimits(design).velocity
    steps = np.abs(motor_from_joint(design, np.diff(poses, axis=0))).max(axis=1)
    assert steps.max() <= v / 100.0 + 2 * 2 * np.pi / 4096
    p_end, _ = forward(design, poses[-1])
    assert np.linalg.norm(p_end - p) < 2e-3  # the tool reached the target


def test_follow_compiles_its_kernels_before_torque_is_on(design, monkeypatch):
    """No period stalls on a kernel's first use: the warm-up runs while the servos are limp,
    and the loop starts from where the arm is after it, not where it was before."""
    import handarm.ik
    from handarm.firmware_bridge.follow import TargetSource, follow
    from handarm.firmware_bridge.motion import MotionLimits
    from handarm.kinematics import forward

    p, e = forward(design, np.radians([20, 30, -20, 10, 10, 0]))
    calls, moved = [], []
    real = handarm.ik.warm_up
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)

        def spy(*args, **kw):
            calls.append([emu.servos[i].get("torque_enable") for i in design.servo_ids])
            out = real(*args, **kw)
            # the user moves the limp arm meanwhile: motor 2 turns by 100 ticks (8.8 deg)
            emu.servos[2].real += 100
            emu.servos[2]._sync_present()
            moved.append(B.check_state(bus, design, cal, 1.0))
            return out

        monkeypatch.setattr(handarm.ik, "warm_up", spy)
        line = json.dumps({"p": list(p), "e": list(e)})
        before = len(emu.log)
        stats = follow(bus, design, cal, TargetSource([line]), rate=100.0, max_periods=20)
        assert all(emu.servos[i].get("torque_enable") == 1 for i in design.servo_ids)
        poses = streamed_poses(emu, design, cal, before)
    assert calls == [[0] * 6]  # once, before torque on
    assert stats["warm_up_s"] > 0
    # torque on holds the moved pose; every command after it is one period's step from the
    # one before (a loop started from the stale pose would jump back 0.15 rad of motor 2,
    # more than a period allows)
    v = MotionLimits(design).velocity
    tick = 2 * np.pi / 4096
    assert len(poses) > 3
    assert np.abs(motor_from_joint(design, poses[0] - moved[0])).max() <= 2 * tick
    steps = np.abs(motor_from_joint(design, np.diff(poses, axis=0))).max(axis=1)
    assert steps.max() <= v / 100.0 + 2 * tick


def _target_line(design, q_deg) -> str:
    from handarm.kinematics import forward

    p, e = forward(design, np.radians(q_deg))
    return json.dumps({"p": list(p), "e": list(e)})


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


GOAL_DEG = [20, 30, -20, 10, 10, 0]
ELSEWHERE_DEG = [-40, 60, 30, -20, 40, 30]


def test_udp_source_follows_the_newest_target(design):
    """Targets sent to udp:PORT as datagrams (one holding two lines): the newest wins."""
    from handarm.firmware_bridge.follow import follow, open_source, parse_target

    port = _free_udp_port()
    source = open_source(f"udp:{port}")
    elsewhere, goal = _target_line(design, ELSEWHERE_DEG), _target_line(design, GOAL_DEG)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
        tx.sendto(elsewhere.encode(), ("127.0.0.1", port))
        tx.sendto(f"{elsewhere}\n{goal}\n".encode(), ("127.0.0.1", port))
        deadline = time.monotonic() + 10
        while source.queue.qsize() < 3 and time.monotonic() < deadline:
            time.sleep(0.01)
    assert source.queue.qsize() == 3  # all arrived before the loop's first period
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        before = len(emu.log)
        stats = follow(bus, design, cal, source, rate=100.0, max_periods=300)
        poses = streamed_poses(emu, design, cal, before)
    assert stats["targets"] == 1  # the two older lines were dropped unseen
    assert handarm.is_valid(design, poses).all()
    p, _ = parse_target(goal, "goal")
    p_end, _ = handarm.forward(design, poses[-1])
    assert np.linalg.norm(p_end - p) < 2e-3
    with pytest.raises(OSError):
        source.sock.recv(1)  # the loop closed the socket


@pytest.mark.parametrize("spec", ["udp:x", "udp:0", "udp:70000", "udp:-5", "udp:"])
def test_udp_source_refuses_a_bad_port_naming_the_source(spec):
    from handarm.firmware_bridge.follow import open_source

    with pytest.raises(ValueError, match=r"^source: expected udp:PORT"):
        open_source(spec)


def test_udp_source_refuses_a_port_in_use_in_one_line(design):
    from handarm.firmware_bridge.follow import open_source

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("127.0.0.1", 0))
        port = held.getsockname()[1]
        with pytest.raises(ValueError, match=rf"^source: cannot listen on UDP port {port}: "):
            open_source(f"udp:{port}")


def test_cli_follow_from_stdin_ends_at_the_last_target(design, tmp_path, capsys, monkeypatch):
    """``bridge follow --source -``: JSON lines on stdin; at their end the arm is on the last."""
    lines = [_target_line(design, ELSEWHERE_DEG), "", _target_line(design, GOAL_DEG)]
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n".join(lines) + "\n"))
    with EmulatedBus(positions=START) as emu:
        port = ["--port", emu.port, "--timeout", TIMEOUT]
        cal = tmp_path / "cal.json"
        assert main(["bridge", "calibrate", *map(str, port), "--out", str(cal)]) == 0
        assert main(["bridge", "apply", *map(str, port), "--calibration", str(cal)]) == 0
        capsys.readouterr()
        before = len(emu.log)
        args = ["bridge", "follow", *map(str, port), "--calibration", str(cal), "--source", "-"]
        code = main(args)
        out, err = capsys.readouterr()
        calibration = B.Calibration.load(cal)
        poses = streamed_poses(emu, design, calibration, before)
        code_bad = main([*args[:-1], "udp:nope"])
        _, err_bad = capsys.readouterr()
    assert code == 0, err
    assert out.startswith("followed ") and "Hz achieved" in out
    # the warm-up (minutes on a fresh install) is announced before it, timed after it
    assert err.startswith("handarm bridge follow: preparing the IK kernels before torque")
    assert re.search(r"kernels prepared in \d+\.\d s before torque on\)", out)
    # the start pose is far from the first target: the approach was slowed, and said so
    assert "periods ran below the speed limit (from 0.25 of it, back up over 0.75 s)" in out
    assert handarm.is_valid(design, poses).all()
    p_goal, _ = handarm.forward(design, np.radians(GOAL_DEG))
    assert np.linalg.norm(handarm.forward(design, poses[-1])[0] - p_goal) < 2e-3
    assert code_bad == 2 and err_bad.strip().splitlines() == [
        "handarm bridge follow: error: --source: expected udp:PORT with PORT in 1..65535, "
        "got 'udp:nope'"
    ]


def test_cli_exit_statuses(design, tmp_path, capsys):
    def run(*argv):
        code = main([str(a) for a in argv])
        return code, capsys.readouterr()

    with EmulatedBus(positions=START) as emu:
        port = ["--port", emu.port, "--timeout", TIMEOUT]
        cal = tmp_path / "cal.json"
        assert run("bridge", "calibrate", *port, "--out", cal)[0] == 0
        code, (out, err) = run(
            "bridge", "goto", "5", "0", "0", "0", "0", "0", *port, "--calibration", cal
        )
        assert code == 4 and "run 'handarm bridge apply'" in err and "\n" not in err.strip()
        assert run("bridge", "apply", *port, "--calibration", cal)[0] == 0
        code, (out, err) = run(
            "bridge", "goto", "5", "0", "0", "0", "0", "0", *port, "--calibration", cal
        )
        assert code == 0, err
        emu.power_cycle()
        code, (out, err) = run("bridge", "read", *port, "--calibration", cal)
        assert code == 4 and "powered off" in err and "'handarm bridge calibrate'" in err
        emu.silent.add(2)
        code, (out, err) = run("bridge", "stop", *port)
        assert code == 5 and "servo 2" in err
    code, (out, err) = run(
        "bridge", "goto", "170", "0", "0", "0", "0", "0", "--port", "x", "--calibration", cal
    )
    assert code == 2 and "q1" in err
    # a goal within a scene obstacle's clearance: refused naming it, before the port opens
    scene = tmp_path / "scene.toml"
    mid, _ = handarm.forward(design, np.radians([30, 40, -30, 20, 10, 0]))
    scene.write_text(
        f"[[sphere]]\nname = 'ball'\nradius = 0.015\nposition = {[float(v) for v in mid]}\n"
    )
    goal = ("30", "40", "-30", "20", "10", "0")
    args = ("--port", "x", "--calibration", cal, "--scene", scene, "--clearance", "3")
    code, (out, err) = run("bridge", "goto", *goal, *args)
    assert code == 3 and "of ball; nothing was sent" in err and len(err.splitlines()) == 1, err
    code, (out, err) = run("bridge", "follow", *args[:4], "--clearance", "3")
    assert code == 2 and "--clearance: only with --scene" in err


def test_ctrl_c_during_follow_holds_the_pose(design):
    from handarm.firmware_bridge.follow import TargetSource, follow
    from handarm.kinematics import forward

    p, e = forward(design, np.radians([30, 40, -30, 20, 10, 0]))
    lines = [json.dumps({"p": list(p), "e": list(e)})] * 50
    calls = []

    def interrupt(q):
        calls.append(q)
        if len(calls) == 5:
            raise KeyboardInterrupt

    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        with pytest.raises(KeyboardInterrupt):
            follow(bus, design, cal, TargetSource(lines, paced=True), on_period=interrupt)
        for servo in emu.servos.values():
            assert servo.get("goal_position") == servo.get("present_position")
            assert servo.get("torque_enable") == 1


def test_follow_steps_slowly_where_the_answer_jumps_to_another_family(design):
    """A new swing (an answer flagged ``family_ended`` whose goal jumped since the previous
    period's; here a target far from the present pose, with no previous goal) steps at
    JUMP_SPEED of the velocity limit. The same answer with its goal unchanged since the last
    period (a command lagging behind a goal) is no new swing: it steps at the speed given.
    A target the present family reaches with a small motion is not flagged at all."""
    from handarm.firmware_bridge.follow import JUMP_SPEED, follow_step
    from handarm.firmware_bridge.motion import MotionLimits

    limits, dt = MotionLimits(design), 0.01
    allowed = limits.velocity * dt  # motor rad in one period
    q = np.radians(GOAL_DEG)
    far = handarm.forward(design, np.radians(ELSEWHERE_DEG))
    assert ik.solve(design, *far, current=q).family_ended
    step = follow_step(design, q, far, dt, limits)
    assert step.swing and step.slowed and step.reached_dof == 5 and step.blocked_by == ()
    motor = np.abs(motor_from_joint(design, step.q - q)).max()
    assert motor == pytest.approx(JUMP_SPEED * allowed, rel=1e-9)
    again = follow_step(design, q, far, dt, limits, previous_goal=step.goal)
    assert not again.swing and not again.slowed  # still flagged, but no new swing
    motor = np.abs(motor_from_joint(design, again.q - q)).max()
    assert motor == pytest.approx(allowed, rel=1e-9)
    half = follow_step(design, q, far, dt, limits, speed=0.5, previous_goal=step.goal)
    motor = np.abs(motor_from_joint(design, half.q - q)).max()
    assert half.slowed and motor == pytest.approx(0.5 * allowed, rel=1e-9)
    near = handarm.forward(design, q + np.radians([8.0, 0, 0, 0, 0, 0]))
    assert not ik.solve(design, *near, current=q).family_ended
    step = follow_step(design, q, near, dt, limits)
    assert not step.swing and not step.slowed and step.reached_dof == 5
    assert np.abs(motor_from_joint(design, step.q - q)).max() == pytest.approx(allowed, rel=1e-9)


def test_a_clearance_without_a_scene_is_refused_before_the_bus_is_touched(design):
    """follow_step, Follower and follow took clearance=0.003 without a scene and kept
    nothing from nothing: a clearance meant for something else, silently ignored."""
    from handarm.firmware_bridge.follow import Follower, TargetSource, follow, follow_step
    from handarm.firmware_bridge.motion import MotionLimits
    from handarm.scene import Scene

    limits, dt = MotionLimits(design), 0.01
    q = np.radians(GOAL_DEG)
    target = handarm.forward(design, q)
    for bad, why in ((0.003, "without a scene"), (float("nan"), r"\[0, 1\] m"), (-1e-3, "")):
        with pytest.raises(ValueError, match=rf"^clearance: .*{why}"):
            follow_step(design, q, target, dt, limits, clearance=bad)
        with pytest.raises(ValueError, match=rf"^clearance: .*{why}"):
            Follower(design, dt, limits, clearance=bad)
    # with a scene the same clearance is kept, not refused
    ball = Scene.empty().with_sphere([0.0, 0.0, 0.5], 0.01, name="far")
    assert follow_step(design, q, target, dt, limits, ball, 0.003).reached_dof == 5
    line = json.dumps({"p": list(target[0]), "e": list(target[1])})
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        before = len(emu.log)
        with pytest.raises(ValueError, match="^clearance: .*without a scene"):
            follow(bus, design, cal, TargetSource([line]), max_periods=5, clearance=0.003)
        assert len(emu.log) == before  # not even a read


def test_a_lagging_follower_catches_up_after_a_dropout(design):
    """A target moving along a reachable path at 0.6 of the speed limit, its stream frozen
    for 30 periods (a dropout) then resuming at its newest position: the resumed goal is a
    swing, the speed drops to JUMP_SPEED and ramps back up (never faster than JUMP_RAMP
    allows), and the arm catches up. (When every period re-decided the slowdown from the
    lagging command's flag, it stayed slowed: 232 mm behind when the target stopped and
    248 periods late, where the full speed arrives 0 late.)"""
    from handarm.firmware_bridge.follow import JUMP_RAMP, JUMP_SPEED, Follower
    from handarm.firmware_bridge.motion import MotionLimits

    limits, dt = MotionLimits(design), 0.01
    qa = np.radians([94.743, -99.304, 125.377, 30.923, 32.065, 141.168])
    qb = np.radians([-77.256, 107.593, -100.776, -50.811, -2.146, 104.838])
    per = np.abs(motor_from_joint(design, qb - qa)).max() / (0.6 * limits.velocity * dt)
    n, drop = int(np.ceil(per)), 30
    follower, q, speeds, swings = Follower(design, dt, limits), qa.copy(), [1.0], 0
    for i in range(n + 200):
        k = n // 3 if n // 3 <= i < n // 3 + drop else i
        p, e = handarm.forward(design, qa + (qb - qa) * min(1.0, k / per))
        step = follower.step(q, (p, e))
        q, swings = step.q, swings + step.swing
        speeds.append(follower.speed)
        if k >= per and np.linalg.norm(handarm.forward(design, q)[0] - p) < 2e-3:
            break
    assert swings >= 1 and min(speeds) <= JUMP_SPEED + 0.01
    assert i <= n + 30  # arrived within 30 periods of the target's stop
    rises = np.diff(speeds)
    assert rises.max() <= (1.0 - JUMP_SPEED) * dt / JUMP_RAMP + 1e-12
    assert speeds[-1] == 1.0


def test_follow_loop_counts_its_slowed_periods(design):
    """The loop's summary counts the periods the swing speed shortened, and its commands
    (the streamed goals, decoded independently) start at JUMP_SPEED of a period's motion and
    speed up by at most JUMP_RAMP's rate a period."""
    from handarm.firmware_bridge.follow import JUMP_RAMP, JUMP_SPEED, TargetSource, follow
    from handarm.firmware_bridge.motion import MotionLimits

    lines = [_target_line(design, ELSEWHERE_DEG)]
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        before = len(emu.log)
        stats = follow(bus, design, cal, TargetSource(lines), rate=100.0, max_periods=40)
        poses = streamed_poses(emu, design, cal, before)
    # 40 periods from the start pose: the target stays far, every step shortened
    assert stats["slowed_periods"] == stats["periods"] == 40
    steps = np.abs(motor_from_joint(design, np.diff(poses, axis=0))).max(axis=1)
    tick, period = 2 * np.pi / 4096, MotionLimits(design).velocity / 100.0
    fraction = JUMP_SPEED + (1.0 - JUMP_SPEED) * 0.01 / JUMP_RAMP * np.arange(len(steps))
    assert np.all(steps <= fraction * period + 2 * tick)
    assert steps[0] <= JUMP_SPEED * period + 2 * tick
    assert steps[-1] > 1.5 * JUMP_SPEED * period  # it speeds up


def test_follow_from_a_file_ends_when_the_steps_only_round(design, monkeypatch):
    """A file source ends once its last target is reached, even where the answers from
    commands a rounding apart alternate between two configurations (1.3e-14 rad apart, as
    a hostile check found on a near-vertical target): the loop ends on SETTLED, not on an
    exact match, which would never come."""
    from handarm.firmware_bridge import follow as F

    real = F.Follower.step
    calls = []

    def wobbling(self, q_cmd, target):
        out = real(self, q_cmd, target)
        calls.append(1)
        if np.abs(out.q - q_cmd).max() < 1e-6:  # arrived: step back and forth by a rounding
            out = out._replace(q=q_cmd + (1.3e-14 if len(calls) % 2 else -1.3e-14))
        return out

    monkeypatch.setattr(F.Follower, "step", wobbling)
    with EmulatedBus(positions=START) as emu, B.ServoBus(emu.port, 1_000_000, TIMEOUT) as bus:
        cal = ready(emu, bus, design)
        start = B.check_state(bus, design, cal, 1.0)
        line = json.dumps({"p": list(handarm.forward(design, start)[0]),
                           "e": list(handarm.forward(design, start)[1])})  # fmt: skip
        stats = F.follow(bus, design, cal, F.TargetSource([line], paced=True), max_periods=500)
    assert stats["periods"] < 50  # not the 500 of an endless loop
