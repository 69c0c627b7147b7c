"""The bridge against emulated MX-64T servos on a pseudo-terminal, through dynamixel_sdk."""

import numpy as np
import pytest

import handarm
from handarm.firmware_bridge import bus as B
from handarm.firmware_bridge.emulator import SYNC_WRITE, WRITE, EmulatedBus
from handarm.firmware_bridge.mx64 import from_unsigned16
from handarm.transmission import motor_from_joint

TIMEOUT = 1000.0  # ms: on a loaded machine the emulator thread can answer late
START = {1: 2000, 2: 100, 3: 3000, 4: 2048, 5: 4000, 6: 10}


@pytest.fixture
def design():
    return handarm.ArmDesign()


def writes(emu):
    return [entry for entry in emu.log if entry[1] in (WRITE, SYNC_WRITE)]


def test_apply_writes_and_verifies(design):
    with (
        EmulatedBus(positions=START) as emu,
        B.ServoBus(emu.port, design.baud_rate, TIMEOUT) as bus,
    ):
        cal = B.record_calibration(bus, design)
        settings = B.apply_settings(bus, design, cal)
        for sid, regs in settings.items():
            servo = emu.servos[sid]
            for name, value in regs.items():
                assert servo.get(name) == value
        assert emu.servos[1].get("cw_angle_limit") == 2000 - 1536
        assert all(emu.servos[s].multi_turn for s in (2, 3, 4, 5, 6))


@pytest.mark.parametrize(
    ("faults", "message"),
    [
        ({"silent": [3]}, "servo 3: ping: .*no status packet"),
        ({"models": {5: 311}}, "servo 5 reports model 311, the MX\\(2.0\\) firmware"),
        ({"models": {2: 29}}, "servo 2 reports model 29, expected 310"),
        ({"bad_checksum": [4]}, "servo 4: ping: .*[Ii]ncorrect status packet"),
        ({"late": {6: 2.0}}, "servo 6: ping: .*no status packet"),
    ],
)
def test_faults_abort_before_anything_is_written(design, faults, message):
    with EmulatedBus(**faults) as emu, B.ServoBus(emu.port, design.baud_rate, TIMEOUT) as bus:
        with pytest.raises(B.BusError, match="nothing was written: .*" + message):
            B.apply_settings(bus, design)
        assert writes(emu) == []


@pytest.mark.slow
def test_calibrate_read_goto(design, rng):
    with (
        EmulatedBus(positions=START) as emu,
        B.ServoBus(emu.port, design.baud_rate, TIMEOUT) as bus,
    ):
        cal = B.record_calibration(bus, design)
        assert cal.offsets == tuple(START[i] for i in range(1, 7))
        B.apply_settings(bus, design, cal)
        B.record_calibration(bus, design)  # the same offsets; sets the power-on marker
        np.testing.assert_allclose(B.read_joint_angles(bus, design, cal), 0.0, atol=1e-12)
        for _ in range(5):
            q = rng.uniform(design.lower, design.upper)
            while not handarm.is_valid(design, q):
                q = rng.uniform(design.lower, design.upper)
            before = len(emu.log)
            samples = B.goto(bus, design, cal, q, rate=200.0)
            ticks = B.goal_ticks(design, cal, q)
            np.testing.assert_array_equal(samples[-1], q)
            assert handarm.is_valid(design, samples).all()
            # a read answers only after the emulator has handled the SYNC_WRITE before it
            q_back = B.read_joint_angles(bus, design, cal)
            sent = [e for e in emu.log[before:] if e[1] == SYNC_WRITE]
            assert len(sent) >= 2  # a timed trajectory, one SYNC_WRITE per period
            present = [
                from_unsigned16(emu.servos[i].get("present_position"))
                if i > 1
                else emu.servos[i].get("present_position")
                for i in range(1, 7)
            ]
            np.testing.assert_array_equal(present, ticks)
            # one tick is 0.088 degrees of motor: the motors come back within half a tick
            np.testing.assert_allclose(
                motor_from_joint(design, q_back),
                motor_from_joint(design, q),
                atol=0.5 * 2 * np.pi / 4096,
            )


@pytest.mark.parametrize(
    ("q_deg", "message"),
    [
        ([170, 0, 0, 0, 0, 0], "q1: 170.00 deg is outside joint 1's limits"),
        ([0, 0, 0, 0, 0, -151], "q6: -151.00 deg is outside"),
        ([0, 150, 120, 0, 0, 0], "links .*l1-l3.* would touch"),
    ],
)
def test_goto_refuses_and_sends_nothing(design, q_deg, message):
    with (
        EmulatedBus(positions=START) as emu,
        B.ServoBus(emu.port, design.baud_rate, TIMEOUT) as bus,
    ):
        cal = B.record_calibration(bus, design)
        before = len(writes(emu))
        with pytest.raises(ValueError, match=message):
            B.goto(bus, design, cal, np.radians(q_deg))
        assert len(writes(emu)) == before


def test_unopenable_port(design, tmp_path):
    with pytest.raises(B.BusError, match="^port: cannot open"):
        B.ServoBus(str(tmp_path / "no-such-tty"), design.baud_rate)
