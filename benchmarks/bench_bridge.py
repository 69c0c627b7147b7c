"""Follow-loop rate and latency on the emulated MX-64T bus (1 Mbit/s, six servos).

    python benchmarks/bench_bridge.py [--periods 300] [--rate 100]

Runs ``handarm.firmware_bridge.follow`` against the software bus with a stream of targets
(a small circle the tool should keep following, fed as JSON lines), and times each stage
of one period on its own in the same run: the IK solve with ``current``, the step's
collision check, the SYNC_WRITE of goal and speed, and the one-servo health read. The
table shows what bounds the loop. On real servos add the wire time: a SYNC_WRITE of six
goals and speeds is 38 bytes (0.38 ms at 1 Mbit/s) and a 4-byte read 14 bytes out and back
plus the servo's Return Delay Time (set to 0 by ``apply``).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import handarm
from handarm.firmware_bridge import bus as B
from handarm.firmware_bridge.emulator import EmulatedBus
from handarm.firmware_bridge.follow import TargetSource, follow, follow_step
from handarm.firmware_bridge.motion import MotionLimits, segment_valid, serial_checks
from handarm.ik import solve
from handarm.kinematics import forward


def circle(design, n):
    q0 = np.radians([20, 30, -20, 10, 10, 0])
    p0, e0 = forward(design, q0)
    t = np.linspace(0, 2 * np.pi, n)
    pts = p0 + 0.01 * np.stack([np.cos(t) - 1, np.sin(t), 0 * t], axis=1)
    return [json.dumps({"p": list(p), "e": list(e0)}) for p in pts], q0


def timed(fn, n):
    out = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return np.median(out) * 1e3, np.percentile(out, 95) * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=300)
    ap.add_argument("--rate", type=float, default=100.0)
    args = ap.parse_args()
    design = handarm.ArmDesign()
    lines, q0 = circle(design, args.periods)
    limits = MotionLimits(design)
    p, e = forward(design, q0)
    solve(design, p, e, current=q0)  # compile
    rows = []
    with (
        serial_checks(),
        EmulatedBus() as emu,
        B.ServoBus(emu.port, design.baud_rate, 1000.0) as bus,
    ):
        cal = B.record_calibration(bus, design)
        B.apply_settings(bus, design, cal)
        B.goto(bus, design, cal, q0, rate=100.0)
        rows.append(("ik.solve(current=...)", *timed(lambda: solve(design, p, e, current=q0), 100)))
        q1 = q0 + np.radians(0.5)
        rows.append(
            ("segment_valid (one step)", *timed(lambda: segment_valid(design, q0, q1), 100))
        )
        rows.append(
            (
                "follow_step (IK+limit+check)",
                *timed(lambda: follow_step(design, q0, (p, e), 0.01, limits), 100),
            )
        )
        rows.append(
            (
                "SYNC_WRITE goal+speed",
                *timed(lambda: B.send_sample(bus, design, cal, q0, q0, 0.01), 200),
            )
        )
        rows.append(
            ("health read (1 servo)", *timed(lambda: B.check_health(bus, design, 0, 1023), 200))
        )
        stats = follow(
            bus,
            design,
            cal,
            TargetSource(lines, paced=True),
            rate=args.rate,
            limits=limits,
            max_periods=args.periods,
        )
    print(f"{'stage':32s} {'median ms':>10s} {'p95 ms':>10s}")
    for name, med, p95 in rows:
        print(f"{name:32s} {med:10.3f} {p95:10.3f}")
    per = stats["period_ms"]
    lat = stats["latency_ms"]
    print(
        f"\nfollow loop at {args.rate:g} Hz requested: {stats['rate']:.1f} Hz achieved over "
        f"{stats['periods']} periods; period median {per['median']:.2f} ms, p95 "
        f"{per['p95']:.2f} ms, max {per['max']:.2f} ms"
    )
    if lat["median"] is not None:
        print(f"target-to-bus latency: median {lat['median']:.2f} ms, p95 {lat['p95']:.2f} ms")


if __name__ == "__main__":
    main()
