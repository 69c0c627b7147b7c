"""The motor pulley's driving hexagon: arithmetic that design loading and the handle share.

The drum sits on a hexagon boss round the horn's centre screw, inside the cable's groove.
Whether it fits depends on the design's motor pulley radius, cable diameter and clearance and
on the servo's horn, so a design that cannot have one is refused when it loads
(``handarm.design``), not after carving, and the handle (``handarm.handle.pulley_parts``)
builds the hexagon this gives.
"""

from __future__ import annotations

import math

# the horn screws' socket heads (M2.5: 4.5 mm across, 2.5 mm tall) sink this deep into the
# flange, leaving 1.3 mm under them: an M2.5 x 4 screw then holds 2.7 mm of the 3 mm horn
HORN_HEAD_R, HEAD_SINK = 2.25, 2.7
# the horn's centre screw head needs a pocket this wide and this high above the horn face;
# the hexagon boss around it keeps 1.2 mm of wall, which sets the smallest hexagon
CENTRE_POCKET_R, CENTRE_POCKET_TOP = 3.3, 4.5
MIN_HEX_R = (CENTRE_POCKET_R + 1.2) / math.cos(math.pi / 6)  # corner radius, mm
#: Drum wall (mm) between the hexagon's socket and the bottom of the cable's groove.
DRUM_WALL = 1.2
_MM = 1e3


def drum_hexagon(design) -> tuple[float, float]:
    """(hex_r, slack) in mm: the driving hexagon's corner radius and its socket's clearance.

    The hexagon's corners stay 0.5 mm inside the horn screws' counterbores and leave
    ``DRUM_WALL`` of drum wall under the groove; ``hex_r`` below ``MIN_HEX_R`` does not fit
    (see ``drum_hexagon_problem``).
    """
    bolt_r = design.servo.horn_bolt_circle * _MM / 2
    bottom = design.motor_pulley_radius * _MM - design.cable_diameter * _MM / 2
    slack = design.clearance * _MM / math.cos(math.pi / 6)  # measured at the socket's corners
    return min(bolt_r - HORN_HEAD_R - 0.5, bottom - DRUM_WALL - slack), slack


def drum_hexagon_problem(design) -> str | None:
    """Why the design's motor pulley has no room for its driving hexagon, or None."""
    hex_r, slack = drum_hexagon(design)
    if hex_r >= MIN_HEX_R:
        return None
    rho = design.motor_pulley_radius * _MM
    bottom = rho - design.cable_diameter * _MM / 2
    return (
        f"motor_pulley_radius: {rho:g} mm leaves {bottom - MIN_HEX_R - slack:.2f} mm of "
        f"drum wall around the smallest driving hexagon ({MIN_HEX_R:.1f} mm; needs "
        f"{DRUM_WALL:g} mm) with cable_diameter {design.cable_diameter * _MM:g} mm and "
        f"clearance {design.clearance * _MM:g} mm: a larger motor pulley, or a thinner "
        "cable or smaller clearance"
    )
