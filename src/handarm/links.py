"""The shape of every link, from the design's dimensions: one description for every part.

Carving builds its manifold3d blanks from it, the printed-link collision model builds its
envelopes from it, and the URDF/MJCF collision geometry comes from it. It sits below
``kinematics`` and ``ik`` (it imports only the design), so the IK never imports ``carve``.

Parametric link blanks (paper II-A.2), in millimetres.

Every link is a union of named convex *parts*, each a prism along the axis of one of the
link's joints: a polygon in that joint's frame (x, y) and a range of z along its axle.
Prisms along an axle make the sweep of a part about that axle a 2D problem (``sweep``).

Joint j's frame has z along its axle. At joint j the proximal link (j - 1) carries a *fork*:
two cheeks (hubs with the axle bore) and a yoke joining them behind the joint; the distal
link j carries the *tongue*: a hub that is also its driving pulley. Cable k passes the idlers
of joints 1 .. k - 1, so joint j's fork leaves room for 6 - j idlers beside the tongue: forks
widen towards the base. l0 is the handle stub where the cables leave towards the motors; l3
turns the axle by 90 degrees; l6 ends in a tool mount.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from handarm.design import ArmDesign

__all__ = ["Part", "Hole", "LinkBlank", "JointGeometry", "joint_geometry", "link_blank", "MM"]

MM = 1000.0  # metres -> millimetres
_CIRCLE_SEGMENTS = 48


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class Part:
    """A convex prism: ``polygon`` (n, 2) in the plane of ``frame``, from z0 to z1 (mm)."""

    name: str
    frame: str  # "prox": the link frame (axle of its proximal joint); "dist": its distal joint
    polygon: np.ndarray
    z0: float
    z1: float
    axisymmetric: bool = False  # a disk centred on its frame's axle: its sweep is itself


@dataclasses.dataclass(frozen=True)
class Hole:
    """A cylindrical hole: axis from ``start`` to ``end`` (mm, in ``frame``), ``radius``."""

    name: str
    frame: str
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float


@dataclasses.dataclass(frozen=True)
class JointGeometry:
    """Sizes at joint j (mm): tongue, fork gap and width, hub radii, axle bore."""

    joint: int
    idlers: int
    tongue_thickness: float
    tongue_radius: float
    gap: float
    fork_width: float
    hub_radius: float
    bore_radius: float


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class LinkBlank:
    """The uncarved link k: its parts, holes and the transform between its two joint frames.

    ``dist_from_prox`` (4x4, mm) maps distal-joint-frame coordinates into the link frame;
    None for l0 (whose only joint frame is the base frame) and l6.
    """

    index: int
    parts: tuple[Part, ...]
    holes: tuple[Hole, ...]
    length: float
    dist_from_prox: np.ndarray | None

    @property
    def name(self) -> str:
        """Link name: l0 .. l6."""
        return f"l{self.index}"


def _circle(r: float, cx: float = 0.0, cy: float = 0.0, n: int = _CIRCLE_SEGMENTS) -> np.ndarray:
    # circumscribed polygon: it contains the true circle (conservative when swept)
    t = (np.arange(n) + 0.5) * 2 * math.pi / n
    rr = r / math.cos(math.pi / n)
    return np.stack([cx + rr * np.cos(t), cy + rr * np.sin(t)], axis=1)


def _box(x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def joint_geometry(design: ArmDesign, j: int) -> JointGeometry:
    """Sizes at joint j (1..6), in mm."""
    if not 1 <= j <= 6:
        raise ValueError(f"joint: expected 1..6, got {j}")
    c = design.clearance * MM
    idlers = 6 - j
    tongue_t = design.beam_thickness * MM
    gap = tongue_t + idlers * design.idler_width * MM + 2 * c
    pulley = design.joint_pulley_radii[j - 1] * MM
    tongue_r = max(design.hub_radius * MM, pulley + design.cable_diameter * MM)
    return JointGeometry(
        joint=j,
        idlers=idlers,
        tongue_thickness=tongue_t,
        tongue_radius=tongue_r,
        gap=gap,
        fork_width=gap + 2 * design.cheek_thickness * MM,
        hub_radius=design.hub_radius * MM,
        bore_radius=design.axle_diameter * MM / 2 + c / 2,
    )


def _fork(g: JointGeometry, frame: str, length: float, clear: float) -> list[Part]:
    """Cheeks and the bridge joining them, in the joint's frame; the link lies towards -x.

    The gap between the cheeks stays open out to ``clear`` (the tongue's radius plus
    margins): the bridge starts beyond it, so nothing of this link turns through the
    neighbour's tongue.
    """
    half_gap, w = g.gap / 2, g.fork_width / 2
    hub = _circle(g.hub_radius)
    plate = _box(-length, 0.0, -g.hub_radius, g.hub_radius)
    return [
        Part(f"fork cheek + at joint {g.joint}", frame, hub, half_gap, w, axisymmetric=True),
        Part(f"fork cheek - at joint {g.joint}", frame, hub, -w, -half_gap, axisymmetric=True),
        Part(f"fork plate + at joint {g.joint}", frame, plate, half_gap, w),
        Part(f"fork plate - at joint {g.joint}", frame, plate, -w, -half_gap),
        Part(
            f"fork bridge at joint {g.joint}",
            frame,
            _box(-length, -clear, -g.hub_radius, g.hub_radius),
            -w,
            w,
        ),
    ]


#: Forks are sized so that the paper's largest limit (150 degrees) carves cleanly; a larger
#: request moves the bridge further back (less material), up to the fork's end.
NOMINAL_LIMIT = math.radians(150.0)


def _wedge_radius(design: ArmDesign, limit: float) -> float:
    """Where two beams fit side by side in the wedge a +-limit range leaves (mm).

    At a limit of +-lim the two beams meet at an angle of 180 - lim; both (half-width h,
    grown by the clearance) fit in that wedge beyond r = h / tan(wedge / 2).
    """
    h = design.beam_width * MM / 2 + 2 * design.clearance * MM
    wedge = max(math.pi - limit, math.radians(6.0)) - math.radians(2.0)
    return h / math.tan(wedge / 2)


def _fork_sizes(design: ArmDesign, g: JointGeometry, a: float) -> tuple[float, float]:
    """(fork length, bridge start) behind joint j, in mm.

    The fork's length depends on the design's sizes only; the bridge (and the beam of the
    link) stop short of the neighbour's tongue and of the wedge the joint's range leaves
    for the two beams. A larger range only moves the bridge back: it never adds material.
    """
    tongue = g.tongue_radius + 2 * design.clearance * MM + 0.5
    length = max(0.5 * a, max(tongue, _wedge_radius(design, NOMINAL_LIMIT)) + 4.0)
    lo, hi = design.joint_limits[g.joint - 1]
    clear = max(tongue, _wedge_radius(design, max(NOMINAL_LIMIT, abs(lo), abs(hi))))
    return length, min(clear, length - 3.0)


def _tongue(g: JointGeometry) -> Part:
    t = g.tongue_thickness / 2
    return Part(
        f"tongue (pulley) at joint {g.joint}",
        "prox",
        _circle(g.tongue_radius),
        -t,
        t,
        axisymmetric=True,
    )


def _axle(g: JointGeometry, frame: str) -> Hole:
    h = g.fork_width
    return Hole(f"axle bore at joint {g.joint}", frame, (0, 0, -h), (0, 0, h), g.bore_radius)


def link_blank(design: ArmDesign, k: int) -> LinkBlank:
    """The uncarved link k (0..6), in mm."""
    if not 0 <= k <= 6:
        raise ValueError(f"link: expected 0..6, got {k}")
    a = design.link_lengths[k] * MM
    bw = design.beam_width * MM / 2
    parts: list[Part] = []
    holes: list[Hole] = []
    if k == 0:
        # the handle stub: base frame = joint 1's frame; cables leave through the end plate
        g = joint_geometry(design, 1)
        w = g.fork_width / 2
        _, clear = _fork_sizes(design, g, a)
        parts += _fork(g, "dist", length=a, clear=clear)
        parts.append(Part("handle", "dist", _box(-a, -clear, -bw, bw), -w, w))
        plate = 4.0
        parts.append(Part("cable exit plate", "dist", _box(-a - plate, -a, -bw - 4, bw + 4), -w, w))
        cable_r = design.cable_diameter * MM / 2 + design.clearance * MM
        pitch = min(3.0 * cable_r, (2 * w - 4) / 6)
        for c in range(6):
            z = (c - 2.5) * pitch
            holes.append(
                Hole(f"cable {c + 1} exit", "dist", (-a - plate - 1, 0, z), (-a + 1, 0, z), cable_r)
            )
        holes.append(_axle(g, "dist"))
        return LinkBlank(0, tuple(parts), tuple(holes), a, None)
    g_prox = joint_geometry(design, k)
    t = g_prox.tongue_thickness / 2
    parts.append(_tongue(g_prox))
    holes.append(_axle(g_prox, "prox"))
    if k == 6:
        parts.append(Part("beam", "prox", _box(0.0, a, -bw, bw), -t, t))
        # tool mount: a boss at the tip with a bore along x for the tool's shank
        boss = max(bw, 6.0)
        parts.append(Part("tool mount", "prox", _box(a - 10.0, a, -boss, boss), -t, t))
        holes.append(Hole("tool bore", "prox", (a - 8.0, 0, 0), (a + 1.0, 0, 0), 2.0))
        return LinkBlank(6, tuple(parts), tuple(holes), a, None)
    g_dist = joint_geometry(design, k + 1)
    # the fork runs back along half the link; its bridge and the beam stop short of the
    # neighbour's tongue
    length, clear = _fork_sizes(design, g_dist, a)
    dist = np.eye(4)
    dist[0, 3] = a
    if k == 3:
        # joint 4's axle is l3's -y axis: the fork turns by 90 degrees about x
        dist = dist @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
    parts.append(Part("beam", "prox", _box(0.0, a - clear, -bw, bw), -t, t))
    parts += _fork(g_dist, "dist", length=length, clear=clear)
    holes.append(_axle(g_dist, "dist"))
    return LinkBlank(k, tuple(parts), tuple(holes), a, dist)
