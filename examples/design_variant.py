"""Derive a design from the paper's arm, check it, and save it as a design file.

python examples/design_variant.py [OUT.toml]
"""

import sys

import numpy as np

import handarm


def main(out: str = "long_reach.toml") -> None:
    paper = handarm.ArmDesign()
    # longer middle links and a wider elbow (joint 5); every field is checked on creation
    variant = paper.replace(
        name="long_reach",
        link_lengths=[0.05, 0.05, 0.06, 0.06, 0.06, 0.05, 0.04],
    ).with_limits_deg([135, 150, 135, 125, 160, 150])
    reach = variant.lengths[1:].sum()
    print(
        f"{variant.name}: reach {reach * 1000:.0f} mm (paper: {paper.lengths[1:].sum() * 1000:.0f})"
    )
    # the straight arm is valid and points along +x
    p, e = handarm.forward(variant, np.zeros(6))
    valid = handarm.is_valid(variant, np.zeros(6))
    print(f"straight arm: tool at {np.round(p * 1000, 1)} mm, valid {valid}")
    try:
        paper.replace(clearance=-0.001)
    except ValueError as exc:
        print(f"a bad value is refused: {exc}")
    print(f"wrote {variant.to_toml(out)}")


if __name__ == "__main__":
    main(*sys.argv[1:])
