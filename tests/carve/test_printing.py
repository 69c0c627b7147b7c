"""Wall thickness and support area, checked on solids whose answer is known by hand."""

import math

import numpy as np
import pytest
from manifold3d import Manifold

import handarm
from handarm.cad_out.meshes import print_orientation, support_area
from handarm.carve.carving import CarvedLink
from handarm.carve.properties import to_trimesh, wall_thickness
from handarm.links import link_blank


def test_wall_of_a_plate_is_its_thickness():
    plate = Manifold.cube([20.0, 10.0, 0.9])
    wall, thin = wall_thickness(plate, 1.2)
    assert wall == pytest.approx(0.9, abs=1e-6)
    assert thin == pytest.approx(2 * (20 * 10 + 20 * 0.9 + 10 * 0.9), rel=0.2)
    block = Manifold.cube([20.0, 10.0, 5.0])
    assert wall_thickness(block, 1.2) == (pytest.approx(5.0, abs=1e-6), 0.0)


def test_rib_on_a_block_is_found():
    """A 0.6 mm rib standing on a 10 mm block: the rib is the thinnest wall."""
    solid = Manifold.cube([10.0, 10.0, 10.0]) + Manifold.cube([0.6, 10.0, 4.0]).translate(
        [4.7, 0.0, 10.0]
    )
    wall, thin = wall_thickness(solid, 1.2)
    assert wall == pytest.approx(0.6, abs=1e-6)
    assert thin > 2 * 10 * 4 * 0.8  # both faces of the rib, give or take the sampling


def _l_shape() -> Manifold:
    # a 10 x 10 x 10 block with a 20 x 10 x 2 shelf on top sticking out 10 mm along +x
    return Manifold.cube([10.0, 10.0, 10.0]) + Manifold.cube([20.0, 10.0, 2.0]).translate(
        [0.0, 0.0, 10.0]
    )


def test_support_area_of_a_shelf():
    mesh = to_trimesh(_l_shape())
    assert support_area(mesh, [0, 0, -1]) == pytest.approx(100.0)  # the shelf's underside
    assert support_area(mesh, [0, 0, 1]) == pytest.approx(0.0)  # shelf on the bed
    # turned so the shelf's end faces down: the block's side overhangs by 10 x 10
    assert support_area(mesh, [1, 0, 0]) == pytest.approx(100.0)


def test_print_orientation_picks_a_pose_without_supports():
    blank = link_blank(handarm.ArmDesign(), 6)
    down, area = print_orientation(CarvedLink(blank, _l_shape()))
    assert area == pytest.approx(0.0)
    mesh = to_trimesh(_l_shape())
    assert support_area(mesh, down) == pytest.approx(0.0)
    assert np.linalg.norm(down) == pytest.approx(1.0)


@pytest.mark.parametrize("tilt", [30.0, 60.0])
def test_faces_within_45_degrees_of_down_need_support(tilt):
    """A 20 x 10 x 4 box turned by `tilt` about y, nothing flat on the bed: its bottom
    (20 x 10, normal `tilt` from down) needs support below 45 degrees, its end (4 x 10,
    normal 90 - `tilt` from down) otherwise."""
    box = Manifold.cube([20.0, 10.0, 4.0]).rotate([0.0, tilt, 0.0])
    expected = 200.0 if tilt < 45.0 else 40.0
    assert support_area(to_trimesh(box), [0, 0, -1]) == pytest.approx(expected)


@pytest.mark.slow
@pytest.mark.parametrize(
    "changes",
    [{}, {"link_lengths": (0.06, 0.07, 0.045, 0.055, 0.05, 0.04, 0.05)}, {"min_wall": 0.0019}],
)
def test_links_report_their_thinnest_wall_against_min_wall(changes):
    """Every link reports a wall measured on its mesh; min_wall_met follows the design's
    limit, and a stricter limit never turns a failing link into a passing one."""
    from handarm.cad_out.carve_files import printing_report
    from handarm.carve import carve

    design = handarm.ArmDesign().replace(**changes)
    result = carve(design, 2.0)
    for link in result.links:
        rep = printing_report(link, design.min_wall)
        wall, _ = wall_thickness(link.solid, design.min_wall * 1e3)
        assert rep["min_wall_m"] == pytest.approx(wall * 1e-3)
        assert rep["min_wall_met"] == (wall * 1e-3 >= design.min_wall - 1e-12)
        assert (rep["thin_area_mm2"] > 0) == (not rep["min_wall_met"])
        strict = printing_report(link, design.min_wall + 0.001)
        assert strict["min_wall_met"] <= rep["min_wall_met"]
        assert strict["support_area_mm2"] == pytest.approx(rep["support_area_mm2"])


def test_a_links_walls_are_cast_once_for_the_split_and_the_report(monkeypatch):
    """The rays behind a link's wall figures are cast once (``CarvedLink.walls``), however
    many readers ask; the figures are those of a fresh cast."""
    from handarm.cad_out.carve_files import printing_report
    from handarm.carve import carve, properties

    design = handarm.ArmDesign()
    link = carve(design, 5.0).links[2]
    fresh = wall_thickness(link.solid, design.min_wall * 1e3)
    casts = []
    real = properties.wall_samples
    monkeypatch.setattr(
        properties, "wall_samples", lambda *a, **k: casts.append(1) or real(*a, **k)
    )
    first = printing_report(link, design.min_wall)
    again = printing_report(link, design.min_wall)
    assert len(casts) == 1 and link.walls is link.walls
    assert first["min_wall_m"] == again["min_wall_m"] == pytest.approx(fresh[0] * 1e-3)
    assert first["thin_area_mm2"] == pytest.approx(fresh[1])


@pytest.mark.slow
def test_cable_corridors_leave_the_fork_plates_min_wall():
    """A run climbing from one idler stack to the next cuts into the fork plate it passes
    (1.16 mm left of 2.5 on l1, l2, l4 of the paper's arm); the plate grows outwards so that
    min_wall stays. On l3 the twisted corridor, which also opens towards joint 4's plane,
    cut into both plates of joint 4 (a 0.01 mm knife edge and a 0.75 mm floor): the plates
    grow past the corridor's copies as well. Measured on the carved meshes (rays cast
    inwards), on every link of the paper's arm."""
    from handarm.carve import carve

    design = handarm.ArmDesign()
    result = carve(design, 2.0)
    for link in result.links:
        wall, thin = wall_thickness(link.solid, design.min_wall * 1e3)
        assert wall >= design.min_wall * 1e3 - 1e-6, (link.blank.name, wall)
        assert thin == 0.0


@pytest.mark.parametrize(
    "changes", [{}, {"link_lengths": (0.06, 0.07, 0.045, 0.055, 0.05, 0.04, 0.05)}]
)
def test_l3_fork_keeps_min_wall_below_the_slab_l2_sweeps(changes):
    """l3's fork plates stand across joint 3's plane; l2's lower fork plate, turning about
    joint 3, cuts a slab out of them and left a 0.7 mm fin below it on the paper's arm.
    Measured on the carved l3, cut off just inside the slab and near joint 3 (where l2
    reaches): the fin keeps min_wall."""
    from handarm.carve import carve
    from handarm.links import _fork_sizes, joint_geometry

    design = handarm.ArmDesign().replace(**changes)
    l3 = carve(design, 2.0).links[3].solid
    g = joint_geometry(design, 3)
    slab_bottom = g.gap_lo - g.cheek - g.clearance  # l2's plate (not grown here) + clearance
    length, _ = _fork_sizes(design, g, design.link_lengths[2] * 1e3)
    reach = math.hypot(length, g.hub_radius)  # l2's fork plate, from joint 3
    box = Manifold.cube([reach, 100.0, 20.0]).translate([0.0, -50.0, slab_bottom + 0.3 - 20.0])
    fin = l3 ^ box
    assert fin.volume() > 1.0  # the plates do reach below the slab
    wall, thin = wall_thickness(fin, design.min_wall * 1e3)
    assert wall >= design.min_wall * 1e3 - 1e-6 and thin == 0.0, wall


def test_a_step_under_a_micrometre_is_no_wall():
    """A lip 0.1 mm wide and 0.2 um high on a block's edge (what a cut grown by a hair over
    the clearance leaves where it grazes a face) is no 0.1 mm wall; a lip 0.1 mm high is."""
    block = Manifold.cube([10.0, 10.0, 5.0])
    hair = block + Manifold.cube([0.1, 10.0, 5.0002]).translate([9.9, 0.0, 0.0])
    assert wall_thickness(hair, 1.2) == (pytest.approx(5.0, abs=1e-3), 0.0)
    lip = block + Manifold.cube([0.1, 10.0, 5.1]).translate([9.9, 0.0, 0.0])
    assert wall_thickness(lip, 1.2)[0] == pytest.approx(0.1, abs=1e-3)


@pytest.mark.parametrize("lean", [-1e-4, 0.0, 1e-4])
def test_a_face_at_45_degrees_needs_no_support_however_it_rounds(lean):
    """A block turned so that two faces face down at 45 degrees (give or take 1e-4
    degrees, as a mesh's rounding leaves them) needs no support; at 46 degrees one does."""
    import trimesh

    def tilted(deg):
        box = trimesh.creation.box([10.0, 10.0, 10.0])
        box.apply_transform(trimesh.transformations.rotation_matrix(math.radians(deg), [0, 1, 0]))
        return box

    assert support_area(tilted(45.0 + lean), [0.0, 0.0, -1.0]) == 0.0
    assert support_area(tilted(46.0), [0.0, 0.0, -1.0]) == pytest.approx(100.0, rel=1e-6)


#: A legal design with 10.9 mm hubs (others lengths, beam, cable, clearance too): its cable
#: corridors, pushed a fixed 2 radii outwards, stopped 0.1 mm short of the plates' sides.
WIDE_HUBS = handarm.ArmDesign(
    link_lengths=(0.06313, 0.07537, 0.06991, 0.04513, 0.04851, 0.07431, 0.03524),
    hub_radius=0.010927,
    beam_width=0.014377,
    cable_diameter=0.0013615,
    clearance=0.00026061,
)


@pytest.mark.parametrize("design", [handarm.ArmDesign(), WIDE_HUBS], ids=["paper", "wide hubs"])
def test_cable_corridors_open_past_the_links_sides(design):
    """Every corridor's pushed copy lies outside its link's side (the hub radius, l0's exit
    plate, l3's fin), so the corridor cuts through the side and leaves no sheet there."""
    from handarm.links import _dist_transform, _side_reach, link_blank

    for k in range(6):
        blank = link_blank(design, k)
        dist = _dist_transform(design, k)
        for ch in blank.channels:
            if "slot" in ch.name:
                continue  # slots open through a plate's face, not its side
            n = ch.per_cable  # each cable's run, then its copy pushed out (then l3's others)
            for (a, b), (ca, cb) in zip(ch.runs[0::n], ch.runs[1::n], strict=True):
                for p, c in ((a, ca), (b, cb)):
                    p, c = np.asarray(p), np.asarray(c)
                    out = (c - p) / np.linalg.norm(c - p)
                    axes = [np.array([0.0, 1.0, 0.0])] + ([dist[:3, 1]] if dist is not None else [])
                    side = max(abs(float(c @ ax)) for ax in axes if abs(float(out @ ax)) > 0.99)
                    assert side >= _side_reach(design, k), (k, ch.name, side)


def test_l3_corridors_under_joint_4s_plate_edge_open_through_it():
    """With 11 mm hubs, the corridor of one cable per side of l3's lead-out and twist runs
    0.15 mm under the top edge of joint 4's plates (within min_wall, not through it), and
    the twist's ends are pushed out past that edge: the hull rose through the edge at a
    slant and left a 0.006 mm sheet in l3's blank, before any neighbour cuts it. Such an
    end is now pushed through that edge too."""
    from handarm.carve.carving import _blank_solid

    design = handarm.ArmDesign(hub_radius=0.011)
    wall, _ = wall_thickness(_blank_solid(link_blank(design, 3)), design.min_wall * 1e3)
    assert wall >= design.min_wall * 1e3 - 0.01


@pytest.mark.slow
def test_wide_hubs_keep_no_sheet_at_the_plates_sides():
    """WIDE_HUBS carved: no wall under min_wall within 0.5 mm of l0's, l1's and l4's plate
    sides (there were 0.095 mm sheets all along them)."""
    from handarm.carve import carve
    from handarm.links import _dist_transform

    design = WIDE_HUBS
    result = carve(design)
    hub = design.hub_radius * 1e3
    for k in (0, 1, 4):
        pts, walls = result.links[k].walls
        dist = _dist_transform(design, k)
        y = pts[:, 1] if dist is None else (pts - dist[:3, 3]) @ dist[:3, 1]
        near = np.abs(np.abs(y) - hub) < 0.5
        assert near.any()
        assert walls[near].min() >= design.min_wall * 1e3 - 1e-6, (k, walls[near].min())


#: A legal design with 1.59 mm cables on 6.3 mm hubs: the steepest run leaving each idler
#: stack cut into the lip over its own tongue's groove (0.88 mm left on l1).
THICK_CABLES = handarm.ArmDesign(
    link_lengths=(0.046773, 0.048432, 0.07164, 0.039136, 0.062005, 0.067785, 0.043456),
    hub_radius=0.0063309,
    beam_width=0.0101998,
    cable_diameter=0.0015889,
    clearance=0.00031245,
)


def test_idler_stacks_lift_only_where_a_run_would_thin_a_tongue_lip():
    """The paper's arm and the other test design keep their stacks on the tongue (their
    geometry is unchanged); thick cables lift some, never joint 3 (l3 leaves it level) nor
    joint 6 (no idlers); a lifted stack widens its fork's gap by the spacer and moves every
    idler slot by it."""
    from handarm.links import _joint_geometry, joint_geometry

    other = handarm.ArmDesign(link_lengths=(0.045, 0.055, 0.05, 0.06, 0.045, 0.05, 0.055))
    for design in (handarm.ArmDesign(), other):
        assert all(joint_geometry(design, j).lift == 0.0 for j in range(1, 7))
    lifts = [joint_geometry(THICK_CABLES, j).lift for j in range(1, 7)]
    assert lifts[0] > 0.3 and lifts[2] == 0.0 and lifts[5] == 0.0
    for j in range(1, 6):
        g, flat = joint_geometry(THICK_CABLES, j), _joint_geometry(THICK_CABLES, j, 0.0)
        assert g.gap - flat.gap == pytest.approx(g.lift)
        assert g.slot_z(1) - flat.slot_z(1) == pytest.approx(g.lift)
        assert g.slot_z(0, -1) == flat.slot_z(0, -1)  # the tongue's lanes stay


@pytest.mark.slow
def test_thick_cables_leave_every_tongue_lip_min_wall():
    """THICK_CABLES carved: over each tongue (within its radius of the link's proximal joint,
    above the middle) no wall is under min_wall; before the lift l1 kept 0.88 mm there."""
    from handarm.carve import carve
    from handarm.links import joint_geometry

    design = THICK_CABLES
    result = carve(design)
    for k in range(1, 7):
        g = joint_geometry(design, k)
        pts, walls = result.links[k].walls
        over = (np.hypot(pts[:, 0], pts[:, 1]) < g.tongue_radius + 0.5) & (pts[:, 2] > 0.0)
        assert over.any()
        assert walls[over].min() >= design.min_wall * 1e3 - 1e-6, (k, walls[over].min())


def test_a_tongue_keeps_min_wall_round_its_anchor_holes():
    """A tongue's rim keeps min_wall (and a margin) outside its anchor holes: with 0.83 mm
    cables the rim, the pulley radius plus the cable's diameter out, kept 1.02 mm there on
    every tongue. Measured on the blanks: the holes' outer edges against the tongues."""
    from handarm.links import _anchor_place, joint_geometry

    thin = handarm.ArmDesign(cable_diameter=0.00083, clearance=0.00035, hub_radius=0.0085)
    for design in (handarm.ArmDesign(), thin):
        for j in range(1, 7):
            g = joint_geometry(design, j)
            at, hole = _anchor_place(design, g.groove_radius)
            blank = link_blank(design, j)
            anchors = [h for h in blank.holes if h.name.startswith("cable anchor")]
            assert len(anchors) == 2
            for h in anchors:
                assert math.hypot(*h.start[:2]) == pytest.approx(at)
                assert g.tongue_radius - (at + hole) >= design.min_wall * 1e3
    assert joint_geometry(thin, 1).tongue_radius > 8.0 + 0.83  # grown past the old rim


@pytest.mark.slow
def test_thin_cables_keep_min_wall_round_the_anchors():
    """0.83 mm cables, carved: no wall under min_wall within 1.5 mm of an anchor hole's axis
    (every tongue kept 1.02 mm between its anchors and its rim)."""
    from handarm.carve import carve
    from handarm.links import _anchor_place, anchor_angles, joint_geometry

    design = handarm.ArmDesign(cable_diameter=0.00083, clearance=0.00035, hub_radius=0.0085)
    result = carve(design)
    for k in range(1, 7):
        at, hole = _anchor_place(design, joint_geometry(design, k).groove_radius)
        pts, walls = result.links[k].walls
        near = np.zeros(len(pts), bool)
        for angle in anchor_angles(design, k):
            axis = at * np.array([math.cos(angle), math.sin(angle)])
            near |= np.hypot(*(pts[:, :2] - axis).T) < hole + 1.5
        assert near.any()
        assert walls[near].min() >= design.min_wall * 1e3 - 1e-6, (k, walls[near].min())
