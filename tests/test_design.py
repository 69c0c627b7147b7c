import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import handarm
from handarm import ArmDesign

ROOT = Path(__file__).resolve().parents[1]


def test_defaults_are_the_papers_arm(design):
    np.testing.assert_allclose(design.lengths, 0.05)
    np.testing.assert_allclose(np.degrees(design.upper), [135, 150, 135, 125, 150, 150])
    np.testing.assert_allclose(design.lower, -design.upper)
    assert design.servo_model == "MX-64T"
    assert design.servo_ids == (1, 2, 3, 4, 5, 6)


def test_derived_arrays_are_read_only(design):
    with pytest.raises(ValueError):
        design.lengths[0] = 1.0


def test_example_file_is_the_default():
    """Written out in full, as the docs say: every field, not only those that differ."""
    path = ROOT / "examples" / "paper_arm.toml"
    assert ArmDesign.from_toml(path) == ArmDesign()
    written = tomllib.loads(path.read_text())
    assert set(written) == set(ArmDesign().to_dict())


def test_toml_round_trip_default(tmp_path, design):
    path = design.to_toml(tmp_path / "arm.toml")
    assert ArmDesign.from_toml(path) == design
    # The file is plain TOML another tool can read.
    data = tomllib.loads(path.read_text())
    assert data["link_lengths"] == list(design.link_lengths)


lengths = st.floats(0.02, 0.5, allow_nan=False)  # hubs of 9 mm fit; FIELD_BOUNDS
half_limit = st.floats(0.0, math.pi, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    a=st.lists(lengths, min_size=7, max_size=7),
    lims=st.lists(st.tuples(half_limit, half_limit), min_size=6, max_size=6),
    signs=st.lists(st.sampled_from([-1, 1]), min_size=21, max_size=21),
    clearance=st.floats(5e-5, 1e-3),
    name=st.from_regex(handarm.design.NAME_PATTERN, fullmatch=True),
)
def test_toml_round_trip_is_exact(tmp_path_factory, a, lims, signs, clearance, name):
    it = iter(signs)
    routing = tuple(tuple(next(it) if j <= k else 0 for j in range(6)) for k in range(6))
    d = ArmDesign(
        name=name,
        link_lengths=a,
        joint_limits=[(-lo, hi) for lo, hi in lims],
        routing_signs=routing,
        clearance=clearance,
        motor_pulley_radius=0.009,  # room for its drum's hexagon at every clearance drawn
    )
    path = tmp_path_factory.mktemp("rt") / "d.toml"
    d.to_toml(path)
    back = ArmDesign.from_toml(path)
    assert back == d
    assert back.link_lengths == d.link_lengths  # bit-for-bit, not approximately


def test_replace_validates_and_keeps_the_rest(design):
    d2 = design.replace(link_lengths=[0.04] * 7)
    assert d2.link_lengths == (0.04,) * 7
    assert d2.joint_limits == design.joint_limits
    with pytest.raises(ValueError, match=r"link_lengths\[3\]: must be > 0"):
        design.replace(link_lengths=[0.04, 0.04, 0.04, -0.01, 0.04, 0.04, 0.04])
    with pytest.raises(ValueError, match="unknown field 'bogus'"):
        design.replace(bogus=1)


def test_with_limits_deg(design):
    d2 = design.with_limits_deg([90, 100, 110, 120, 130, 140])
    np.testing.assert_allclose(np.degrees(d2.upper), [90, 100, 110, 120, 130, 140])


pairs = st.tuples(half_limit, half_limit).map(lambda t: (-t[0], t[1]))


@settings(max_examples=100, deadline=None)
@given(
    asked=st.lists(pairs, min_size=6, max_size=6), allowed=st.lists(pairs, min_size=6, max_size=6)
)
def test_limited_to_is_the_intersection(asked, allowed):
    d = ArmDesign(joint_limits=asked)
    cut = d.limited_to(allowed)
    # checked point by point: a joint angle is allowed by the result iff by both inputs
    for k in range(6):
        for q in np.linspace(-math.pi, math.pi, 73):
            inside = cut.lower[k] <= q <= cut.upper[k]
            assert inside == (d.lower[k] <= q <= d.upper[k] and allowed[k][0] <= q <= allowed[k][1])
    assert cut.replace(joint_limits=d.joint_limits) == d  # nothing else changes


def test_limited_to_refuses_an_empty_intersection_naming_the_joint():
    d = ArmDesign(joint_limits=[(-1, 1)] * 5 + [(0.5, 1.0)])
    with pytest.raises(ValueError, match=r"joint_limits\[5\]: .* do not overlap"):
        d.limited_to([(-1, 1)] * 5 + [(-1, 0.2)])
    with pytest.raises(ValueError, match="expected 6"):
        d.limited_to([(-1, 1)] * 5)


def test_designs_are_hashable_values(design):
    assert hash(design) == hash(ArmDesign())
    assert {design, ArmDesign()} == {design}


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"link_lengths": [0.05] * 6}, r"link_lengths: expected 7 values, got 6"),
        ({"link_lengths": [0.05] * 6 + [0.0]}, r"link_lengths\[6\]: must be > 0, got 0"),
        ({"link_lengths": [0.05] * 6 + [-1]}, r"link_lengths\[6\]: must be > 0, got -1"),
        ({"link_lengths": [0.05] * 6 + ["a"]}, r"link_lengths\[6\]: expected a number, got str"),
        ({"link_lengths": [0.05] * 6 + [float("nan")]}, r"link_lengths\[6\]: must be finite"),
        ({"link_lengths": 0.05}, r"link_lengths: expected a list of 7 values, got float"),
        (
            {"joint_limits": [[-1, 1]] * 5 + [[0.5, 0.2]]},
            r"joint_limits\[5\]: lower 0.5 exceeds upper 0.2",
        ),
        (
            {"joint_limits": [[-1, 1]] * 5 + [[-1, 3.2]]},
            r"joint_limits\[5\]: upper 3.2 rad .* beyond \+-180 degrees",
        ),
        (
            {"joint_limits": [[-1, 1]] * 5 + [[-3.2, 1]]},
            r"joint_limits\[5\]: lower -3.2 rad .* beyond \+-180",
        ),
        ({"joint_limits": [[-1, 1]] * 5 + [[-1]]}, r"joint_limits\[5\]: expected 2 values, got 1"),
        (
            {"joint_limits": [[-1, True]] * 6},
            r"joint_limits\[0\]\[1\]: expected a number, got bool",
        ),
        ({"hub_radius": 0.0025}, r"hub_radius: .* leaves no wall around the axle bore"),
        ({"clearance": 0.0}, r"clearance: must be > 0, got 0"),
        ({"density": -5}, r"density: must be > 0"),
        ({"motor_pulley_radius": "big"}, r"motor_pulley_radius: expected a number, got str"),
        ({"idler_width": 0.001}, r"idler_width: .* must exceed cable_diameter"),
        ({"servo_ids": [1, 2, 3, 4, 5, 5]}, r"servo_ids: IDs must be distinct"),
        ({"servo_ids": [1, 2, 3, 4, 5, 300]}, r"servo_ids\[5\]: Dynamixel IDs are 0..252, got 300"),
        ({"servo_ids": [1, 2, 3, 4, 5, 6.0]}, r"servo_ids\[5\]: expected an integer, got float"),
        ({"servo_model": "XL-320"}, r"servo_model: unknown model 'XL-320'"),
        ({"baud_rate": 0}, r"baud_rate: 0 is not a rate the servo and the Dynamixel SDK share"),
        # a rate of the servo's table that the SDK's PortHandler cannot open
        (
            {"baud_rate": 200_000},
            r"baud_rate: 200000 is not a rate the servo and the Dynamixel SDK share",
        ),
        ({"name": ""}, r"name: expected a non-empty string"),
        (
            {"routing_signs": [[1, 0, 0, 0, 0, 0]] * 6},
            r"routing_signs\[1\]\[1\]: cable 2 wraps joint 2",
        ),
        (
            {"routing_signs": [[1, 1, 0, 0, 0, 0]] * 6},
            r"routing_signs\[0\]\[1\]: cable 1 does not reach joint 2",
        ),
    ],
)
def test_bad_values_name_the_field(changes, message):
    with pytest.raises(ValueError, match=message):
        ArmDesign(**changes)
    with pytest.raises(ValueError, match=message):
        ArmDesign.from_dict(changes)


def test_unknown_key_in_toml_names_it(tmp_path):
    path = tmp_path / "arm.toml"
    path.write_text("link_lenghts = [0.05, 0.05, 0.05, 0.05, 0.05, 0.05, 0.05]\n")
    with pytest.raises(ValueError, match=r"arm.toml: unknown key 'link_lenghts'"):
        ArmDesign.from_toml(path)


def test_bad_toml_syntax(tmp_path):
    path = tmp_path / "arm.toml"
    path.write_text("link_lengths = [0.05,\n")
    with pytest.raises(ValueError, match=r"arm.toml: not valid TOML"):
        ArmDesign.from_toml(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="design file not found"):
        ArmDesign.from_toml(tmp_path / "nope.toml")


def test_partial_toml_takes_defaults(tmp_path):
    path = tmp_path / "arm.toml"
    path.write_text('name = "short"\nlink_lengths = [0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04]\n')
    d = ArmDesign.from_toml(path)
    assert d.name == "short"
    assert d.joint_limits == ArmDesign().joint_limits


def test_public_api_is_explicit():
    for name in handarm.__all__:
        assert hasattr(handarm, name)


def test_every_numeric_field_has_bounds():
    """A field added without bounds would load unchecked (or fail with a KeyError)."""
    import dataclasses

    from handarm.design import FIELD_BOUNDS

    numeric = {
        f.name
        for f in dataclasses.fields(handarm.ArmDesign)
        if isinstance(getattr(handarm.ArmDesign(), f.name), (float, tuple))
        and f.name not in ("joint_limits", "routing_signs", "servo_ids")
    }
    assert numeric <= set(FIELD_BOUNDS), numeric - set(FIELD_BOUNDS)


def test_unreadable_and_folder_design_files_are_one_line(tmp_path, monkeypatch):
    """A folder said "not a regular file"; an unreadable file raised a raw PermissionError."""
    with pytest.raises(ValueError, match="is a folder, not a file"):
        handarm.ArmDesign.from_toml(tmp_path)
    locked = tmp_path / "locked.toml"
    locked.write_text(handarm.ArmDesign().to_toml_string())

    def denied(self, *args, **kwargs):  # as for a file without read permission (not root)
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "open", denied)
    with pytest.raises(ValueError, match="locked.toml: cannot be read"):
        handarm.ArmDesign.from_toml(locked)
