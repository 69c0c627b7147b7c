"""Tendon paths on the carved links: grooves at the transmission's radius, idler room,
cable lengths, and the clearance check."""

import math

import numpy as np
import pytest
import trimesh
from hypothesis import example, given, settings
from hypothesis import strategies as st
from manifold3d import OpType

import handarm
from handarm.carve import carve
from handarm.carve.carving import _cylinder, _in_joint_frame
from handarm.carve.properties import to_trimesh
from handarm.carve.sweep import _affine, frame_to_link
from handarm.links import cable_runs, corridor_radius, joint_geometry
from handarm.tendons import PULLEY_SLACK, cable_lengths, cut_lengths, swept_overlap, tendon_report
from handarm.transmission import coupling_matrix

OTHER = handarm.ArmDesign(
    name="other",
    link_lengths=(0.06, 0.07, 0.045, 0.055, 0.05, 0.04, 0.05),
    joint_pulley_radii=(0.0085, 0.008, 0.0075, 0.008, 0.007, 0.0075),
)


@pytest.fixture(scope="module", params=["default", "other"])
def carved(request):
    design = handarm.ArmDesign() if request.param == "default" else OTHER
    return carve(design)


def _first_hit(solid, origin, direction) -> float:
    mesh = to_trimesh(solid)
    locs, _, _ = mesh.ray.intersects_location([origin], [direction], multiple_hits=True)
    assert len(locs), (origin, direction)
    return float(np.min(np.linalg.norm(locs - np.asarray(origin), axis=1)))


def test_groove_radius_on_the_mesh_is_the_transmission_radius(carved):
    """Cable centre on the carved groove's bottom = K's pulley radius (from K, not links)."""
    design = carved.design
    k = coupling_matrix(design)
    cable_r = design.cable_diameter * 1e3 / 2
    for j in range(1, 7):
        tongue = carved.links[j].solid  # link j's frame is joint j's frame
        lane = joint_geometry(design, j).slot_z(0, 1)
        for angle in (150.0, 180.0, 210.0):  # behind the tongue, away from the beam
            d = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle)), 0.0])
            origin = 40.0 * d + [0.0, 0.0, lane]
            bottom = 40.0 - _first_hit(tongue, origin, -d)
            radius_from_k = abs(k[j - 1, j - 1]) * design.motor_pulley_radius * 1e3
            assert bottom + cable_r == pytest.approx(radius_from_k, abs=0.01), (j, angle)


def test_every_fork_holds_the_idlers_its_joint_needs(carved):
    """Whole idlers between the tongue's face and the far cheek, measured on the meshes."""
    design = carved.design
    w = design.idler_width * 1e3
    c = design.clearance * 1e3
    for j in range(1, 7):
        prox = _in_joint_frame(carved.links[j - 1], "dist")
        dist = _in_joint_frame(carved.links[j], "prox")
        start = np.array([-1.0, 4.0, 0.0])  # in the gap, off the bore and the anchors
        up = np.array([0.0, 0.0, 1.0])
        cheek = _first_hit(prox, start, up)
        tongue_top = _first_hit(dist, start + [0, 0, 30.0], -up)
        # the idler stack shares the clearance: c / 2 at the tongue, c / 2 at the cheek
        room = cheek - (30.0 - tongue_top) - c
        assert math.floor(room / w + 1e-4) >= 6 - j, (j, room)  # meshes are float32


def test_driving_pulley_length_change_is_the_arc():
    """Cable 1 wraps only joint 1: its change is r1 times the joint's travel."""
    d = handarm.ArmDesign()
    (lo, hi) = d.joint_limits[0]
    r1 = d.joint_pulley_radii[0]
    change = cable_lengths(d)[0].change
    assert change == pytest.approx((-r1 * hi, -r1 * lo))


def test_lengths_grow_with_the_links():
    base = cable_lengths(handarm.ArmDesign())
    longer = cable_lengths(handarm.ArmDesign(link_lengths=(0.05, 0.06) + (0.05,) * 5))
    for c in range(1, 6):  # cables 2..6 run along l1
        assert longer[c].side_plus == pytest.approx(base[c].side_plus + 0.01, abs=2e-4)
    assert longer[0].side_plus == pytest.approx(base[0].side_plus)


def test_cut_lengths_check_their_arguments():
    d = handarm.ArmDesign()
    cuts = cut_lengths(d)
    assert len(cuts) == 6 and all(a < b for a, b in zip(cuts, cuts[1:], strict=False))
    with pytest.raises(ValueError, match="motor_run"):
        cut_lengths(d, motor_run=-1.0)
    with pytest.raises(ValueError, match="motor_run"):
        cut_lengths(d, motor_run=(0.1, 0.1))
    with pytest.raises(ValueError, match="motor_turns"):
        cut_lengths(d, motor_turns=-1)


def test_every_joint_turns_its_whole_achieved_range_with_its_cables_clear(carved):
    """The independent proof: over each joint's achieved range, the polar sweeps of both
    links' runs (manifold3d solids, ``swept_overlap``) hold no material of the other link.
    Widened by 3 degrees, the ranges do hold some: the proof is not vacuous."""
    achieved = [j.achieved for j in carved.joints]
    for joint in swept_overlap(carved.design, carved, achieved):
        assert joint["proximal_mm3"] <= 1e-6 and joint["distal_mm3"] <= 1e-6, joint
    wider = [(lo - math.radians(3.0), hi + math.radians(3.0)) for lo, hi in achieved]
    met = swept_overlap(carved.design, carved, wider)
    assert max(j["proximal_mm3"] + j["distal_mm3"] for j in met) > 1e-3


def test_a_cable_limit_lies_just_short_of_a_real_contact(carved):
    """Where a cable stops a joint, the traced check (the runs' cylinders and the placed
    meshes intersected) finds that joint's cables meeting a link 10 degrees further on: the
    limit is not arbitrarily cautious."""
    design = carved.design
    poses, which = [], []
    for j, report in enumerate(carved.joints):
        assert report.links_meet[0] <= report.achieved[0] < report.achieved[1]
        assert report.achieved[1] <= report.links_meet[1]
        for side, sign in ((0, -1.0), (1, 1.0)):
            if not report.stopped_by[side].startswith("cable"):
                continue
            q = np.zeros(6)
            q[j] = report.achieved[side] + sign * math.radians(10.0)
            poses.append(q)
            which.append(j + 1)
    assert poses  # the printed links do stop some cables before the links meet
    hits = tendon_report(design, carved, poses=poses)["contacts"]
    for n, j in enumerate(which):
        links = {(h["run_on"], h["meets"]) for h in hits if h["pose"] == n}
        assert links & {(f"l{j - 1}", f"l{j}"), (f"l{j}", f"l{j - 1}")}, (j, poses[n])


def test_a_search_that_starts_with_a_cable_pinched_stops_there_both_ways():
    """From 100 degrees every joint's own cable already meets its neighbour (the traced
    check agrees): the range is that one pose, stopped by the cable on both sides, never
    reported as reaching its end."""
    from handarm.tendons import cable_limits

    design = handarm.ArmDesign()
    carving = carve(design, 2.0)
    start = math.radians(100.0)
    found = cable_limits(design, carving.links, [(start, math.radians(120.0))] * 6)
    for joint in found:
        assert joint["limits"] == (start, start)
        assert all(s and s.startswith("cable") for s in joint["stopped_by"]), joint
    q = np.zeros(6)
    q[1] = start
    assert not tendon_report(design, carving, poses=[q])["clear"]


def test_the_build_uses_the_ranges_the_cables_allow(carved):
    """``as_built`` (what the URDF, controller and map use) lies within the cable limits,
    and a joint narrowed by a cable says which."""
    built = carved.as_built
    for (lo, hi), report in zip(built.joint_limits, carved.joints, strict=True):
        assert report.achieved[0] <= lo <= hi <= report.achieved[1]
    narrowed = [r for r in carved.joints if r.achieved != r.links_meet]
    assert all("cable" in s for r in narrowed for s in r.stopped_by if s)


#: mm: how far the rings that hold a run piece (0.2 mm wide) reach past it, with a margin.
_RING_SPILL = 0.3


def _nearest_gap(verts: np.ndarray, pts: np.ndarray, turn: float) -> float:
    """Least distance (mm) from the points to the polygon's edges, the polygon turned."""
    c, s = math.cos(turn), math.sin(turn)
    poly = verts @ np.array([[c, s], [-s, c]])
    a, e = poly, np.roll(poly, -1, axis=0) - poly
    t = np.clip(((pts[:, None, :] - a) * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
    return float(np.linalg.norm(pts[:, None, :] - (a + t[..., None] * e), axis=-1).min())


@settings(max_examples=25, deadline=None)
@given(
    st.floats(6.0, 30.0),
    st.floats(-math.pi, math.pi),
    st.floats(0.5, 8.0),
    st.floats(-math.pi, math.pi),
    st.integers(0, 2**31),
)
@example(dist=23.0, heading=-3.0625, length=4.0, start=-2.78125, seed=50890)  # 0.05 mm off
def test_first_contact_against_a_dense_turn(dist, heading, length, start, seed):
    """A straight run piece (its prism: the hull of circles round its ends) turned in
    0.05 degree steps meets a cloud of points no earlier than ``_first_contacts`` says,
    each way. The rings (0.2 mm) over-cover the piece most where a ring grazes its nearest
    point, so the bound the other way is loose: 20 degrees."""
    from handarm.carve.sweep import _run_pieces
    from handarm.tendons import _first_contacts

    rng = np.random.default_rng(seed)
    a = np.array([dist * math.cos(heading), dist * math.sin(heading), 0.0])
    b = a + length * np.array([math.cos(heading + 1.0), math.sin(heading + 1.0), 0.0])
    pieces = [(*piece, "run") for piece in _run_pieces([(a, b)], 0.8)]
    assert len(pieces) == 1  # a flat run is one piece
    verts = pieces[0][0]
    if np.sum(verts[:, 0] * np.roll(verts[:, 1], -1) - np.roll(verts[:, 0], -1) * verts[:, 1]) < 0:
        verts = verts[::-1]  # counter-clockwise
    edges = np.roll(verts, -1, axis=0) - verts
    r = rng.uniform(dist - 3.0, dist + length + 3.0, 150)
    t = rng.uniform(-math.pi, math.pi, 150)
    pts = np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(150)])
    steps = np.radians(np.arange(0.0, 360.0, 0.05))

    def first_met(sign: float) -> float:
        """First step at which a point lies in the piece turned by start + sign * step."""
        ang = t[None, :] - (start + sign * steps)[:, None]  # the points turned back instead
        x, y = r * np.cos(ang), r * np.sin(ang)
        inside = np.ones(x.shape, bool)
        for v, e in zip(verts, edges, strict=True):
            inside &= e[0] * (y - v[1]) - e[1] * (x - v[0]) >= 0.0
        hit = np.flatnonzero(inside.any(axis=1))
        return float(steps[hit[0]]) if len(hit) else math.inf

    if first_met(1.0) == 0.0 or _nearest_gap(verts, pts[:, :2], start) < _RING_SPILL:
        # a point inside at the start, or within the rings' spill round the piece (0.2 mm
        # bands hold the piece's angles over their width): the contact-at-start case
        return
    found = _first_contacts(pts, np.zeros(len(pts)), pieces, start)
    for side, sign in ((0, -1.0), (1, 1.0)):
        angle, tag = found[side]
        first = first_met(sign)
        assert angle <= first + 1e-9, (side, angle, first)
        if math.isfinite(first):
            assert tag == "run" and angle >= first - math.radians(20.0), (side, angle, first)


@pytest.mark.slow
def test_cables_run_clear_across_the_achieved_ranges(carved):
    """q = 0, each joint alone at both ends of its achieved range, and random valid poses:
    the traced check finds no cable meeting a printed part."""
    report = tendon_report(carved.as_built, carved, samples=6)
    assert report["clear"], report["contacts"][:3]
    assert all(s["proximal_mm3"] <= 1e-6 for s in report["swept_in_the_way_mm3"])


@pytest.mark.slow
def test_cables_run_clear_at_moderate_poses(carved):
    """q = 0 and every joint at +-60 degrees (one at a time and all together)."""
    poses = [np.zeros(6), np.full(6, math.radians(60)), np.full(6, -math.radians(60))]
    for j in range(6):
        for v in (-60.0, 60.0):
            q = np.zeros(6)
            q[j] = math.radians(v)
            poses.append(q)
    report = tendon_report(carved.design, carved, poses=poses)
    assert report["clear"], report["contacts"][:3]
    assert report["poses"] == len(poses)


@pytest.mark.slow
def test_check_finds_a_cable_pinched_in_a_fold():
    """Joint 2 folded to -150 degrees: l2 closes on l1's side where the cables run; the
    contact the check reports is real (the placed meshes overlap a cylinder round the run)."""
    d = handarm.ArmDesign()
    result = carve(d)
    q = np.zeros(6)
    q[1] = math.radians(-150)
    report = tendon_report(d, result, poses=[q])
    assert not report["clear"]
    hit = report["contacts"][0]
    assert {hit["run_on"], hit["meets"]} <= {"l1", "l2"}
    # independent: the run's points, placed, lie inside the other link's placed mesh
    from handarm.links import strands_in_link

    frames = handarm.joint_frames(d, q)
    k, other = int(hit["run_on"][1]), int(hit["meets"][1])
    mesh = to_trimesh(result.links[other].solid)
    to_other = np.linalg.inv(frames[other - 1]) if other else np.eye(4)
    place = frames[k - 1] if k else np.eye(4)
    st = [s for s in strands_in_link(d, k) if s.cable == hit["cable"] and s.side == hit["side"]]
    pts = np.concatenate([np.linspace(s.start, s.end, 400) for s in st])  # mm in link k
    world = pts @ place[:3, :3].T + place[:3, 3] * 1e3
    local = world @ to_other[:3, :3].T + to_other[:3, 3] * 1e3
    near = trimesh.proximity.signed_distance(mesh, local)
    rc = d.cable_diameter * 1e3 / 2 + d.clearance * 1e3
    assert np.max(near) > -rc  # some point of the run is within the cable's radius


def test_swept_material_holds_what_the_cables_meet_at_every_angle(carved):
    """Joint 2 turned to angles across its range: the part of l2 (its pulley left out) that
    l1's cables, placed independently as turned cylinders, run into never exceeds what the
    sweep says is in their way; in the fold it is not zero, and neither is the sweep's."""
    from manifold3d import Manifold

    design = carved.design
    lo, hi = carved.joints[1].carved
    swept = swept_overlap(design, carved)[1]["distal_mm3"]
    l1, l2 = carved.links[1], carved.links[2]
    rc = corridor_radius(design)
    to_joint = _affine(np.linalg.inv(frame_to_link(l1.blank, "dist")))
    runs = Manifold.batch_boolean(
        [_cylinder(a, b, rc, 32) for a, b in cable_runs(design, 1)], OpType.Add
    ).transform(to_joint)
    pulley = Manifold.cylinder(
        100.0, joint_geometry(design, 2).tongue_radius + PULLEY_SLACK, circular_segments=96
    ).translate([0.0, 0.0, -50.0])
    l2_beyond = l2.solid - pulley
    met = [
        (l2_beyond ^ runs.rotate([0.0, 0.0, -math.degrees(q)])).volume()
        for q in np.linspace(lo, hi, 25)
    ]
    assert max(met) > 1.0  # the fold pinches l1's cables (see the test below)
    assert max(met) <= swept + 1e-6


def test_nothing_is_in_the_cables_way_over_narrow_ranges():
    """With every joint limited to +-60 degrees the sweeps of every joint's cables hold no
    printed material, and the traced check agrees at its poses."""
    design = handarm.ArmDesign().with_limits_deg([60.0] * 6)
    carving = carve(design, 2.0)
    for joint in swept_overlap(design, carving):
        assert joint["proximal_mm3"] < 1e-6 and joint["distal_mm3"] < 1e-6, joint
    assert tendon_report(design, carving, samples=2)["clear"]
