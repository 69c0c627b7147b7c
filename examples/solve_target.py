"""Every IK solution of one target, each checked by forward kinematics.

python examples/solve_target.py
"""

import numpy as np

import handarm


def main() -> None:
    d = handarm.ArmDesign()
    p, e = np.array([0.20, 0.05, 0.05]), np.array([1.0, 0.0, 0.3])
    r = handarm.ik.solve(d, p, e)
    print(handarm.ik.format_result(r), end="")
    e = e / np.linalg.norm(e)
    for q in r.solutions:
        p2, e2 = handarm.forward(d, q)
        assert np.allclose(p2, p, atol=1e-9) and np.allclose(e2, e, atol=1e-9)
        assert handarm.is_valid(d, q)
    # any point of a range is a solution too, not only its midpoint
    lo, hi = r.intervals[0]
    q = handarm.ik.configuration_at(d, p, e, r.branches[0], 0.25 * lo + 0.75 * hi)
    print("a quarter of the way along range 1:", np.round(np.degrees(q), 2))
    # in a control loop, pass the present configuration and send `follow`
    r = handarm.ik.solve(d, p, e, current=r.solutions[0] + 0.05)
    print("follow:", np.round(np.degrees(r.follow), 2))


if __name__ == "__main__":
    main()
