"""Continuity of `follow` in a control loop: random 2 mm-step paths, and sensor noise.

    python benchmarks/bench_tracking.py [--targets 20] [--seed 0] [--steps 150]

``--targets`` paths of the paper's arm (printed-link model), each ``--steps`` targets 2 mm
apart: the tool poses of a smooth random walk in joint space that stays inside the joint
limits and valid, so that every target has an exact solution and the walk's own
configuration ``q_gen`` is one of them. The loop solves each target with ``current`` = its
last answer and moves to ``follow``. Prints the steps in joint space (largest |dq| of one
step, degrees): median, 99th percentile and largest; how many steps exceed 5 degrees; and,
of those, how many a configuration near the previous answer would have avoided (the walk's
own ``q_gen`` lies closer than half the step: a jump the kinematics did not force). The
rest are forced: the range ``current`` lay on ended (a joint limit or two links meeting)
and no solution of the target is nearer. Also how many steps the result flagged
``family_ended`` (follow moved more than 10x the least joint motion to the new pose).

Then paths that leave the workspace: from the pose of a valid configuration, the tool
point moves straight away from joint 1 in 2 mm steps (direction held) until 60 mm past the
arm's reach, so the answers go from exact through the degraded levels; prints the levels
met, the step in joint space (median, largest) and how many steps were flagged, and per
level how far 1e-6 rad / 1e-6 m of noise on each answer moves ``follow``, also against the
least joint motion between the two answers' poses (|pinv(J) dx|).

Then paths over and under the base: circles about the base axis, higher (or lower) than
a4 + a5 + a6 over the base plane, where every answer is level 2's and the nearest points
form a family (joint 4 under the target, the tip chain vertical, any tip-plane azimuth).
Each circle is run twice: as shipped (the valid member nearest current, narrowed down in
azimuth) and as first shipped (the nearest of 72 sampled azimuths and current's own).
Prints per variant the steps (deg; median, largest), how many exceed 5 degrees and how
many of those a valid member of a 3,600-azimuth grid would have avoided (nearer current
than half the step), and the solve time (median, largest).

Then noise: each answer's pose tilted by 1e-6 rad and moved by 1e-6 m, solved again from
the answer; prints how far ``follow`` moved (rad, largest joint), and its Euclidean motion
against the least joint motion that follows the pose to first order (|pinv(J) dx|,
``handarm.ik.api.least_joint_motion``): near 1x means
the follower adds nothing to what the arm's kinematics amplify.
"""

from __future__ import annotations

import argparse
import contextlib
import time

import numpy as np

import handarm
from handarm import ik
from handarm.ik.api import least_joint_motion

STEP = 0.002  # m between targets
JUMP = np.radians(5.0)


def noisy(p, e, rng) -> tuple[np.ndarray, np.ndarray]:
    """The pose (p, e) tilted by 1e-6 rad about a random axis and moved by 1e-6 m."""
    axis = np.cross(e, rng.normal(size=3))
    axis /= np.linalg.norm(axis)
    e2 = e * np.cos(1e-6) + np.cross(axis, e) * np.sin(1e-6)
    return p + 1e-6 * rng.normal(size=3) / np.sqrt(3), e2


def walk(design, rng, steps: int) -> np.ndarray:
    """Configurations (steps, 6) whose tool points lie STEP apart, all valid."""
    while True:
        q = rng.uniform(design.lower, design.upper)
        if handarm.is_valid(design, q):
            break
    path = [q]
    heading = rng.normal(size=6)
    tries = 0
    while len(path) < steps and tries < 50 * steps:
        tries += 1
        heading = 0.9 * heading + 0.45 * rng.normal(size=6)  # a smooth random heading
        dq = heading / np.linalg.norm(heading)
        p0 = handarm.forward(design, path[-1])[0]
        moved = np.linalg.norm(handarm.forward(design, path[-1] + 1e-3 * dq)[0] - p0)
        if moved < 1e-9:
            continue
        nxt = path[-1] + dq * (1e-3 * STEP / moved)
        inside = np.all(nxt >= design.lower) and np.all(nxt <= design.upper)
        if inside and handarm.is_valid(design, nxt):
            path.append(nxt)
        else:
            heading = -heading + rng.normal(size=6)  # turn away from the wall
    return np.array(path)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--targets", type=int, default=20, help="paths")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--steps", type=int, default=150, help="targets per path")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    d = handarm.ArmDesign()
    # every kernel a loop meets loads (or, after a change, compiles) before any timing
    ik.warm_up(d, batch=False)
    steps, unforced, forced, times, noise = [], 0, 0, [], []
    flagged, flagged_jumps, noise_flagged = 0, 0, 0
    levels = {}
    for _ in range(args.targets):
        qs = walk(d, rng, args.steps)
        P, E = handarm.forward(d, qs)
        current = qs[0]
        for p, e, q_gen in zip(P[1:], E[1:], qs[1:], strict=True):
            t = time.perf_counter()
            r = ik.solve(d, p, e, current=current)
            times.append(time.perf_counter() - t)
            levels[r.reached_dof] = levels.get(r.reached_dof, 0) + 1
            step = float(np.abs(r.follow - current).max())
            steps.append(step)
            flagged += r.family_ended
            flagged_jumps += r.family_ended and step > JUMP
            if step > JUMP:
                if np.linalg.norm(q_gen - current) < 0.5 * np.linalg.norm(r.follow - current):
                    unforced += 1
                else:
                    forced += 1
            # noise around this pose: 1e-6 rad of tilt, 1e-6 m of shift
            p2, e2 = noisy(p, e, rng)
            r2 = ik.solve(d, p2, e2, current=r.follow)
            noise_flagged += r2.family_ended
            if r2.follow is not None:
                moved = float(np.abs(r2.follow - r.follow).max())
                # the least joint motion that follows the pose to first order, |pinv(J) dx|
                # (tests hold it to pinv of central differences of forward)
                need = least_joint_motion(d, r.follow, p2, e2)
                moved_norm = float(np.linalg.norm(r2.follow - r.follow))
                noise.append((moved, moved_norm / max(need, 1e-12)))
            current = r.follow
    leaving = leaving_paths(d, rng, args.targets)
    circles = {"as shipped": over_the_base(d, np.random.default_rng(args.seed), args.targets)}
    with _first_version():
        circles["nearest of 72 azimuths"] = over_the_base(
            d, np.random.default_rng(args.seed), args.targets
        )
    s = np.degrees(np.array(steps))
    print(
        f"{args.targets} paths x {args.steps} targets, {STEP * 1e3:g} mm apart "
        f"(paper's arm, {d.collision_model} model)"
    )
    print(f"answers by level: {dict(sorted(levels.items(), reverse=True))}")
    print(
        f"step (deg, largest joint): median {np.median(s):.3f}, 99th pct "
        f"{np.percentile(s, 99):.3f}, largest {s.max():.2f}"
    )
    print(
        f"steps > {np.degrees(JUMP):g} deg: {forced + unforced} "
        f"(forced by the kinematics {forced}, avoidable {unforced})"
    )
    print(f"steps flagged family_ended: {flagged} ({flagged_jumps} of them > 5 deg)")
    print(f"solve(current=) median {1e3 * np.median(times):.3f} ms")
    n = np.array(noise)
    print(
        f"noise 1e-6 rad / 1e-6 m over {len(n)} poses: follow moved median "
        f"{np.median(n[:, 0]):.2e} rad, largest {n[:, 0].max():.2e} rad; against the least "
        f"motion that follows the pose (pinv(J) dx): median {np.median(n[:, 1]):.2f}x, "
        f"largest {n[:, 1].max():.2f}x; flagged family_ended: {noise_flagged}"
    )
    lv, ls, lf, ln, lr = leaving
    ls, lf, lr = np.array(ls), np.array(lf, bool), np.array(lr)
    print(
        f"leaving the workspace ({args.targets} straight paths, 2 mm steps): levels met "
        f"{dict(sorted(lv.items(), reverse=True))}; step (deg, largest joint) median "
        f"{np.median(ls):.3f}, largest {np.max(ls):.2f}; flagged family_ended: {lf.sum()}"
    )
    for lim in (20.0, 45.0):
        over = ls > lim
        quiet = over & ~lf
        print(
            f"  steps > {lim:g} deg: {over.sum()}, flagged {np.sum(over & lf)}; "
            f"largest unflagged {np.max(ls[~lf]):.2f} deg"
            + (
                f"; the unflagged ones moved {np.median(lr[quiet]):.2f}x (median), "
                f"{lr[quiet].max():.2f}x (largest) the least joint motion to the answer's pose"
                if quiet.any()
                else ""
            )
        )
    print("  noise 1e-6 rad / 1e-6 m on each answer, follow moved (rad, largest joint):")
    for level in sorted(ln, reverse=True):
        m = np.array([x[0] for x in ln[level]])
        f = np.array([x[1] for x in ln[level]], bool)
        x = np.array([x[2] for x in ln[level]])
        print(
            f"    {level} DoF: {len(m)} answers, median {np.median(m):.1e}, 90th pct "
            f"{np.percentile(m, 90):.1e}, largest {m.max():.1e}; over 1e-3: {np.sum(m > 1e-3)} "
            f"({np.sum((m > 1e-3) & f)} flagged family_ended); against the least motion "
            f"between the answers' poses: median {np.median(x):.2f}x"
            + (f", {np.median(x[m > 1e-3]):.2f}x over 1e-3" if np.any(m > 1e-3) else "")
        )
    print(f"over and under the base ({args.targets} circles, 2 mm steps, level 2 throughout):")
    print(
        f"  {'variant':<24} {'steps':>6} {'median deg':>11} {'largest deg':>12} "
        f"{'> 5 deg':>8} {'avoidable':>10} {'solve p50 ms':>13} {'worst ms':>9}"
    )
    for name, (st, avoid, ts) in circles.items():
        print(
            f"  {name:<24} {len(st):>6} {np.median(st):>11.3f} {st.max():>12.2f} "
            f"{np.sum(st > np.degrees(JUMP)):>8} {avoid:>10} {1e3 * np.median(ts):>13.2f} "
            f"{1e3 * ts.max():>9.2f}"
        )


@contextlib.contextmanager
def _first_version():
    """Level 2 over the base as first shipped: the nearest of 72 azimuths and current's own."""
    from handarm.ik import degrade

    def first(design, p, current):
        psi = np.linspace(-np.pi, np.pi, 72, endpoint=False)
        if current is not None:
            psi = np.append(float(current[0] + current[1] + current[2]), psi)
        q = np.vstack([degrade._above_members(design, p, psi, elbow) for elbow in (1.0, -1.0)])
        return degrade._nearest_valid(design, q, np.zeros(6) if current is None else current)

    kept = degrade._above_the_disk
    degrade._above_the_disk = first
    try:
        yield
    finally:
        degrade._above_the_disk = kept


def family(design, p, n_psi: int = 3600) -> np.ndarray:
    """Valid configurations meeting level 2's bound over the base: joint 4 under p, the tip
    chain vertical, on a grid of tip-plane azimuths (both elbows); numpy on ``is_valid``."""
    a = design.lengths
    psi = np.linspace(-np.pi, np.pi, n_psi, endpoint=False)
    j3x, j3y = p[0] - a[3] * np.cos(psi), p[1] - a[3] * np.sin(psi)
    with np.errstate(invalid="ignore"):
        c2 = np.arccos((j3x**2 + j3y**2 - a[1] ** 2 - a[2] ** 2) / (2 * a[1] * a[2]))
    rows = []
    for q2 in (c2, -c2):
        q = np.zeros((n_psi, 6))
        q[:, 0] = np.arctan2(j3y, j3x) - np.arctan2(a[2] * np.sin(q2), a[1] + a[2] * np.cos(q2))
        q[:, 0] = np.angle(np.exp(1j * q[:, 0]))
        q[:, 1], q[:, 2] = q2, np.angle(np.exp(1j * (psi - q[:, 0] - q2)))
        q[:, 3] = np.copysign(np.pi / 2, p[2])
        rows.append(q[np.isfinite(q2)])
    q = np.concatenate(rows)
    q = q[np.all((q >= design.lower) & (q <= design.upper), axis=1)]
    return q[handarm.is_valid(design, q)]


def over_the_base(design, rng, n: int):
    """Circles over and under the base: (steps (deg), avoidable jumps, solve times (s))."""
    a = design.lengths
    rt, r2 = float(a[4:].sum()), float(a[2] + a[3])
    steps, avoidable, times = [], 0, []
    for k in range(n):
        rho = rng.uniform(0.2, 0.9) * (a[1] + r2)
        z = (1 if k % 2 == 0 else -1) * (rt + rng.uniform(0.005, 0.04))
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        current = np.zeros(6)
        for t in np.linspace(0.0, 2.0 * np.pi, int(2.0 * np.pi * rho / STEP)):
            p = np.array([rho * np.cos(t), rho * np.sin(t), z])
            start = time.perf_counter()
            r = ik.solve(design, p, e, current=current)
            times.append(time.perf_counter() - start)
            step = float(np.abs(r.follow - current).max())
            steps.append(np.degrees(step))
            if step > JUMP:
                members = family(design, p)
                if len(members) and (
                    np.linalg.norm(members - current, axis=1).min()
                    < 0.5 * np.linalg.norm(r.follow - current)
                ):
                    avoidable += 1
            current = r.follow
    return np.array(steps), avoidable, np.array(times)


def leaving_paths(design, rng, n: int):
    """Straight paths from a held pose out past the reach: levels, steps (deg), flags."""
    reach = float(np.sum(design.lengths))
    levels, steps, flagged, noise, ratios = {}, [], [], {}, []
    for _ in range(n):
        while True:
            q = rng.uniform(design.lower, design.upper)
            if handarm.is_valid(design, q):
                break
        p0, e = handarm.forward(design, q)
        out = p0 / np.linalg.norm(p0)
        current = q
        for k in range(1, int((reach + 0.06 - np.linalg.norm(p0)) / STEP) + 1):
            r = ik.solve(design, p0 + k * STEP * out, e, current=current)
            levels[r.reached_dof] = levels.get(r.reached_dof, 0) + 1
            if r.follow is None:  # nothing to follow: the loop keeps its pose
                continue
            steps.append(float(np.degrees(np.abs(r.follow - current).max())))
            flagged.append(r.family_ended)
            # follow's move against the least joint motion to the answer's pose
            least = least_joint_motion(design, current, r.achieved_position,
                                       r.achieved_direction)  # fmt: skip
            ratios.append(float(np.linalg.norm(r.follow - current)) / max(least, 1e-12))
            current = r.follow
            # the same 1e-6 rad / 1e-6 m of noise as on the walks, from this answer
            p2, e2 = noisy(p0 + k * STEP * out, e, rng)
            r2 = ik.solve(design, p2, e2, current=current)
            if r2.follow is not None:
                # against the least joint motion between the two answers' poses
                need = least_joint_motion(design, current, r2.achieved_position,
                                          r2.achieved_direction)  # fmt: skip
                moved = float(np.linalg.norm(r2.follow - current))
                noise.setdefault(r.reached_dof, []).append(
                    (float(np.abs(r2.follow - current).max()), r2.family_ended,
                     moved / max(need, 1e-12))
                )  # fmt: skip
    return levels, steps, flagged, noise, ratios


if __name__ == "__main__":
    main()
