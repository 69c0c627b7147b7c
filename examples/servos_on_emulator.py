"""Export, calibrate, apply and move on the software servo bus (no hardware needed).

python examples/servos_on_emulator.py
"""

import tempfile
from pathlib import Path

import numpy as np

import handarm
from handarm.firmware_bridge.bus import (
    ServoBus,
    apply_settings,
    goto,
    read_joint_angles,
    record_calibration,
)
from handarm.firmware_bridge.emulator import EmulatedBus


def main() -> None:
    d = handarm.ArmDesign()
    with tempfile.TemporaryDirectory() as tmp:  # the files are shown, not kept
        files = handarm.pipeline.export_controller(d, Path(tmp) / "controller")
        print("controller files:", ", ".join(p.name for p in files))
    # six emulated MX-64T whose horns sit wherever they were assembled
    with EmulatedBus(positions={1: 2000, 2: 100, 3: 3000, 4: 2048, 5: 4000, 6: 10}) as emu:
        # a software bus answers from a thread: give it the timeout it asks for
        with ServoBus(emu.port, d.baud_rate, emu.timeout_ms) as bus:
            cal = record_calibration(bus, d)  # the arm held straight
            print("calibration offsets (ticks):", cal.offsets)
            apply_settings(bus, d, cal)
            target = np.radians([10, -20, 30, 40, -50, 60])
            samples = goto(bus, d, cal, target)  # the joint samples streamed (rad)
            print(
                f"{len(samples)} joint samples sent, the last (deg):",
                np.round(np.degrees(samples[-1]), 2),
            )
            q = read_joint_angles(bus, d, cal)
            print("joint angles read back (deg):", np.round(np.degrees(q), 2))
            assert np.allclose(q, target, atol=2 * np.pi / 4096)


if __name__ == "__main__":
    main()
