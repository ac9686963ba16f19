"""Primitive kinds: connector frames against the reference's conformance vectors,
DoF tags, and parameter validation."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from fabhal import api
from fabhal.library import Library, PartSpec
from fabhal.primitives import KINDS, Primitive, Tag, check_params, make_primitive
from fabhal.source import Span
from tests.conftest import spec_json

HERE = Span("test", 1, 1, 1, 1)
# connector_frames.json sampled ParamHanger with these dimensions (see the spec's file table)
SAMPLED_ARGUMENTS = {"ParamHanger": {"length": 419.1, "bar_d": 12.7}}


@cache
def library() -> Library:
    result = api.part_library()
    assert result.ok, result.diagnostics
    return result.library


def part(name: str) -> PartSpec:
    args = {k: (v, HERE) for k, v in SAMPLED_ARGUMENTS.get(name, {}).items()}
    return library().instantiate(name, args, HERE)


def conformance_cases() -> list[dict]:
    return spec_json("connector_frames.json")["connector_frames"]


# our parts that the reference does not have: each one of its parts with a flag added
OURS_ONLY = {"LevelHulaHoop": "HulaHoop"}
# primitives whose size or placement the library corrects (stdlib_parts/ says why at
# each): their frames are compared at the reference's, the formula being what is tested
REFERENCE_SIZES = {
    ("Basket", "surface"): {"width": 248.0, "length": 248.0},
    ("BasketBase", "surface"): {"width": 118.0},
    ("HandleBasket", "surface"): {"width": 118.0},
    ("TwoholeBasket", "surface"): {"width": 340.0, "length": 235.0},
}
REFERENCE_ROTATIONS = {("Board", "surface2"): (90.0, 0.0, 0.0)}
# primitives given flags the reference's lack: the toss rings turn about their own wire
# in a hook (`spin`) and twist about their contact (`flex`; stdlib_parts/rings_and_links.fhl
# says why), compared without them
TOSS_RINGS = ("RingXS", "RingS", "RingM", "RingL")
REFERENCE_FLAGS = {
    **{(ring, "ring"): {"spin": False, "flex": False} for ring in TOSS_RINGS},
    ("FlagRod", "rod"): {"centerline": True},  # the reference's stick connects on its axis
}


# primitives the library adds to the reference's parts (stdlib_parts/ says why at each)
ADDED_PRIMITIVES = {
    ("Basket", "bottom"), ("BasketBase", "bottom"), ("HandleBasket", "bottom"), ("TwoholeBasket", "bottom"),
}  # fmt: skip


def test_the_conformance_set_covers_every_library_primitive() -> None:
    cases = {(c["part"], c["primitive"]) for c in conformance_cases()}
    assert len(cases) == 106
    parts = library().parts.items()
    ours = {(OURS_ONLY.get(name, name), p) for name, t in parts for p in t.primitive_names()}
    assert ADDED_PRIMITIVES <= ours and not ADDED_PRIMITIVES & cases
    assert ours - ADDED_PRIMITIVES == cases


def test_a_part_with_a_flag_added_has_the_reference_frames_at_its_new_dofs_defaults() -> None:
    """LevelHulaHoop's ring at spin 0 is HulaHoop's, whose frames the reference gives."""
    for ours, theirs in OURS_ONLY.items():
        cases = [c for c in conformance_cases() if c["part"] == theirs]
        assert cases
        for case in cases:
            primitive = part(ours).primitive(case["primitive"])
            assert primitive is not None
            extra = [d.default for d in primitive.dofs[len(case["dofs"]) :]]
            samples = np.array([s["dofs"] + extra for s in case["samples"]], dtype=float)
            expected = np.array([s["matrix"] for s in case["samples"]], dtype=float)
            np.testing.assert_allclose(primitive.connector_frames(samples), expected, atol=1e-6)


@pytest.mark.parametrize("case", conformance_cases(), ids=lambda c: f"{c['part']}.{c['primitive']}")
def test_connector_frames_match_the_reference(case: dict) -> None:
    # tolerance 1e-6: the reference's matrices are printed to 9 decimals
    primitive = part(case["part"]).primitive(case["primitive"])
    assert primitive is not None
    key = (case["part"], case["primitive"])
    resized, turned = REFERENCE_SIZES.get(key, {}), REFERENCE_ROTATIONS.get(key)
    flagged = REFERENCE_FLAGS.get(key, {})
    if resized or turned or flagged:
        assert not resized or any(primitive.params[k] != v for k, v in resized.items()), "no longer resized"
        assert turned is None or turned != primitive.rotation, "no longer turned"
        assert not flagged or any(primitive.flags.get(k, False) != v for k, v in flagged.items()), "no flag"
        primitive = make_primitive(
            primitive.name,
            primitive.kind,
            {**primitive.params, **resized},
            {**primitive.flags, **flagged},
            primitive.position,
            turned or primitive.rotation,
        )
    assert primitive.variant == case["variant"]
    reference_dofs = [d["name"] for d in case["dofs"]]
    # ours may add DoFs after the reference's (a centre-line rod's spin), which change nothing
    # at their defaults
    assert [d.name for d in primitive.dofs][: len(reference_dofs)] == reference_dofs
    extra = [d.default for d in primitive.dofs[len(reference_dofs) :]]
    samples = np.array([s["dofs"] + extra for s in case["samples"]], dtype=float)
    expected = np.array([s["matrix"] for s in case["samples"]], dtype=float)
    np.testing.assert_allclose(primitive.connector_frames(samples), expected, atol=1e-6)


def test_dof_tags_follow_the_physics() -> None:
    def tags(part_name: str, primitive_name: str) -> dict[str, Tag]:
        primitive = part(part_name).primitive(primitive_name)
        assert primitive is not None
        return {d.name: d.tag for d in primitive.dofs}

    # sliding along an open rod can fall off; the flex angle only rests on its stops;
    # the rod turns in what holds it
    assert tags("ShowerCurtainRod", "rod") == {
        "t": Tag.BOUNDED_AND_OPEN,
        "phi": Tag.BOUNDED_AND_CLAMPED,
        "spin": Tag.UNBOUNDED,
    }
    # a rod closed at its ends (closet rods between walls, a tension rod pressed on them)
    # holds what hangs on it
    assert tags("ClosetRods", "rod1")["t"] is Tag.BOUNDED_AND_CLAMPED
    assert tags("LongTensionRod", "rod")["t"] is Tag.BOUNDED_AND_CLAMPED
    assert tags("DoubleHook", "hook1") == {"theta": Tag.BOUNDED_AND_OPEN, "phi": Tag.BOUNDED_AND_CLAMPED}
    assert tags("Mug", "hook") == {"theta": Tag.BOUNDED_AND_CLAMPED}  # closed handle
    # turns on its wire too, and twists about its contact until a wire jams (in loops)
    assert tags("RingM", "ring") == {
        "theta": Tag.UNBOUNDED,
        "phi": Tag.BOUNDED_AND_CLAMPED,
        "spin": Tag.UNBOUNDED,
    }
    assert tags("ClothesClip", "hook") == {"theta": Tag.UNBOUNDED}  # a 360-degree coil
    assert tags("PlasticClip", "clip") == {"t": Tag.BOUNDED_AND_CLAMPED}
    assert set(tags("PlasticClip", "hemisphere1").values()) == {Tag.BOUNDED_AND_CLAMPED, Tag.UNBOUNDED}
    assert tags("Phone", "edge") == {"t": Tag.BOUNDED_AND_OPEN}
    assert tags("SoapBottle", "surface")["t1"] is Tag.BOUNDED_AND_CLAMPED
    assert tags("BinderClip", "ring1") == {"phi": Tag.UNBOUNDED, "theta": Tag.UNBOUNDED}


def test_what_is_threaded_on_a_centre_line_may_turn_about_it() -> None:
    cable = part("Cable").primitive("rod1")
    assert cable is not None and [d.name for d in cable.dofs] == ["t", "spin", "phi"]
    frames = cable.connector_frames(np.array([[0.3, 0.0, 90.0], [0.3, 70.0, 90.0]]))
    np.testing.assert_allclose(frames[0][:3, 3], frames[1][:3, 3], atol=1e-12)  # same point on the axis
    axis = cable.base_frame()[:3, 2]
    np.testing.assert_allclose(
        frames[1][:3, :3] @ frames[0][:3, :3].T @ axis, axis, atol=1e-12
    )  # turned about it


def test_what_hangs_on_a_centre_line_tilts_along_it_until_its_wire_jams() -> None:
    """A centre-line rod's third DoF tilts what hangs on it along it (about the
    connector's x, square to the axis): square at 90, and tilted by b the
    connector's y (along the axis at 90) turns b away from the axis, the point
    on the axis staying put. Its range is the jam of the loop on the rod, as on
    a rod's surface: a ceiling hook (inside 25 - 2.5 = 22.5 mm, its wire's
    radius off its arc's) on a centre-line rod of 6.35 mm jams at acos(6.35 /
    22.5) = 73.6 degrees (`tilt_jam_deg`); held square, a hook near a flag
    stick's end (the reference's, a centre-line rod) held it out as a
    cantilever."""
    from fabhal.primitives import jam_of

    stick = make_primitive("rod", "rod", {"radius": 6.35, "length": 280.0}, {"centerline": True})
    assert [d.name for d in stick.dofs] == ["t", "spin", "phi"]
    square, tilted = stick.connector_frames(np.array([[0.4, 0.0, 90.0], [0.4, 0.0, 120.0]]))
    np.testing.assert_allclose(square[:3, 3], tilted[:3, 3], atol=1e-12)
    assert float(square[:3, 1] @ tilted[:3, 1]) == pytest.approx(np.cos(np.radians(30.0)))
    hook = part("CeilingHook").primitive("hook")
    assert hook is not None
    inside = hook.params["arc_radius"] - hook.params["thickness"]
    expected = np.degrees(np.arccos(stick.params["radius"] / inside))
    assert jam_of(stick.dofs[2], stick, hook) == pytest.approx(expected, abs=0.05)


def test_a_hook_falls_off_its_tip_only() -> None:
    # the S-hook's upper hook is free at theta = arc angle and joins the part at 0
    theta = part("DoubleHook").primitive("hook1").dofs[0]  # type: ignore[union-attr]
    assert (theta.low_open, theta.high_open) == (False, True)
    lower = part("DoubleHook").primitive("hook2").dofs[0]  # type: ignore[union-attr]
    assert (lower.low_open, lower.high_open) == (True, False)


def test_no_flex_angle_is_ever_open() -> None:
    for name in library().parts:
        for primitive in part(name).primitives:
            for dof in primitive.dofs:
                if dof.name == "phi" and primitive.kind in ("rod", "hook", "hole", "hemisphere"):
                    assert dof.tag is not Tag.BOUNDED_AND_OPEN, (name, primitive.name)


@pytest.mark.parametrize(
    ("kind", "params", "message"),
    [
        ("rod", {"radius": -1, "length": 10}, "radius == -1, but must be positive"),
        (
            "hook",
            {"arc_radius": 10, "arc_angle": 400, "thickness": 1},
            "arc_angle == 400, but must be in (0, 360]",
        ),
        ("hook", {"arc_radius": 2, "arc_angle": 90, "thickness": 3}, "leaves no opening"),
        ("hook", {"arc_radius": 9, "arc_angle": 90, "thickness": 1, "tip": 45}, "must be 0 or the arc angle"),
        (
            "clip",
            {"width": 1, "height": 1, "thickness": 1, "dist": -2, "open_gap": 1},
            "must not be negative",
        ),
        ("tube", {"inner_radius": 1, "thickness": 1}, "missing parameter `length`"),
    ],
)
def test_invalid_shape_parameters_are_explained(kind: str, params: dict, message: str) -> None:
    messages = [m for _, m in check_params(kind, params)]
    assert any(message in m for m in messages), messages


def test_every_kind_has_a_frame_for_its_default_dofs() -> None:
    samples = {
        "rod": {"radius": 2, "length": 10},
        "hook": {"arc_radius": 10, "arc_angle": 180, "thickness": 1},
        "hole": {"arc_radius": 10, "thickness": 1},
        "clip": {"width": 5, "height": 5, "thickness": 1, "dist": 1, "open_gap": 4},
        "tube": {"inner_radius": 5, "thickness": 1, "length": 20},
        "edge": {"width": 5, "length": 50, "height": 5},
        "surface": {"width": 100, "length": 100},
        "hemisphere": {"radius": 5},
    }
    assert set(samples) == set(KINDS)
    for kind, params in samples.items():
        primitive = make_primitive("p", kind, params, {})
        frame = primitive.connector_frames(np.array([d.default for d in primitive.dofs]))
        rotation = frame[:3, :3]
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)  # a rigid frame


def _ring(arc_radius: float, thickness: float) -> Primitive:
    return make_primitive("ring", "hole", {"arc_radius": arc_radius, "thickness": thickness}, {})


def poking_out(across: float, along: float, rho: float) -> float:
    """How far (mm) an ellipse of half-axes `across` and `along` (the second
    along the line of the contact), touching a circle of radius rho from
    inside at the contact, reaches outside it (<= 0: within), over 20,000
    points on the ellipse."""
    t = np.linspace(0.0, 2.0 * np.pi, 20_000)
    x, y = across * np.sin(t), (along - rho) - along * np.cos(t)
    return float((np.hypot(x, y) - rho).max())


def test_a_loop_turns_on_a_round_wire_until_its_wire_jams() -> None:
    """A RingLink's hook (arc radius 18, wire 4: 14 mm inside) on an
    ObstacleRingL's 3 mm wire jams at cos^2 b = 3 / 14: b = 62.42 degrees.
    Checked without the formula: the loop's inner circle (radius p = 14,
    centre (0, 0)) against the rod's section in the turned loop's plane, an
    ellipse of half-axes r / cos b along the wire and r across it, resting
    at the circle's bottom (centre (0, r - p)). 20,000 points on the ellipse:
    just inside the jam (b - 0.05 degrees) none lies outside the circle, just
    past it (b + 0.05) some do, by more than 1e-6 mm (the margin's own
    effect near the contact is of order 1e-4 mm)."""
    from fabhal.primitives import yaw_jam_deg

    link = make_primitive("hook1", "hook", {"arc_radius": 18, "arc_angle": 150, "thickness": 4}, {})
    wire = _ring(195, 3)
    jam = yaw_jam_deg(link, wire)
    assert jam is not None and jam == pytest.approx(62.42, abs=0.01)
    rho, r = 14.0, 3.0
    for turn, inside in ((jam - 0.05, True), (jam + 0.05, False)):
        reach = poking_out(r / np.cos(np.radians(turn)), r, rho)
        assert reach <= 1e-9 if inside else reach > 1e-6


def test_a_ring_tilts_along_its_rod_until_its_wire_jams() -> None:
    """An eye ring (arc radius 14.82, wire 4.5: 10.32 mm inside) hanging on
    an 8 mm rod, tilted along it by b: the rod's section in the ring's plane
    is an ellipse of half-axes r = 8 across the rod and r / cos b along the
    line of the contact, which ends at the contact, inside the ring's inner
    circle. It fits while r / cos b <= 10.32: the jam is acos(8 / 10.32) =
    39.18 degrees. Sampled as for the turn about the contact line: 20,000
    points on the ellipse, none outside the circle 0.05 degrees before the
    jam, some by more than 1e-6 mm 0.05 degrees past it. A snug ring, a
    centre-line ring, or a rod that is not one: None."""
    from fabhal.primitives import tilt_jam_deg

    ring = _ring(14.82, 4.5)
    rod = make_primitive("rod", "rod", {"radius": 8.0, "length": 300.0}, {})
    jam = tilt_jam_deg(ring, rod)
    assert jam is not None and jam == pytest.approx(39.18, abs=0.01)
    rho, r = 10.32, 8.0
    for tilt, inside in ((jam - 0.05, True), (jam + 0.05, False)):
        reach = poking_out(r, r / np.cos(np.radians(tilt)), rho)
        assert reach <= 1e-9 if inside else reach > 1e-6
    thick = make_primitive("rod", "rod", {"radius": 10.5, "length": 300.0}, {})
    centre_line = make_primitive("ring", "hole", ring.params, {"centerline": True})
    assert tilt_jam_deg(ring, thick) is None
    assert tilt_jam_deg(centre_line, rod) is None
    assert tilt_jam_deg(ring, ring) is None


def test_a_snug_loop_cannot_turn_and_only_round_things_jam_it() -> None:
    """A hook whose inside radius is no more than the rod's (a wire hook bent
    open round it, N416) turns 0 degrees; on an edge (square in section) or
    as a centre-line ring the formula does not apply (None)."""
    from fabhal.primitives import yaw_jam_deg

    hook = make_primitive("hook", "hook", {"arc_radius": 9.6, "arc_angle": 220, "thickness": 0.0}, {})
    rod = make_primitive("rod", "rod", {"radius": 10.0, "length": 100.0}, {})
    edge = make_primitive("edge", "edge", {"width": 10.0, "length": 100.0, "height": 10.0}, {})
    centre_line = make_primitive("ring", "hole", {"arc_radius": 10.0, "thickness": 1.0}, {"centerline": True})
    assert yaw_jam_deg(hook, rod) == 0.0
    assert yaw_jam_deg(hook, edge) is None
    assert yaw_jam_deg(centre_line, rod) is None
    assert yaw_jam_deg(rod, hook) is None  # a rod goes round nothing
