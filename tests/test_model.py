"""The kinematic model: forward kinematics against the reference's part frames."""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from fabhal import api
from fabhal.kinematics.frames import frame_matrix
from fabhal.model import POINTER_JUMPING_DEPTH, Model, build_model
from tests.conftest import REPO, spec_json

REFERENCE = spec_json("reference_programs.json")
# the reference composes frames through Euler angles and picks up gimbal-lock noise
# where a chain passes pitch 90 (its own notes: up to 1 mm on these two)
NOISY = {"diaper_caddy", "reading_nook"}


def model_of(path: Path) -> Model:
    result = api.check(path)
    assert result.ok and result.flat is not None, result.diagnostics
    return build_model(result.flat)


def reference_x(model: Model, facts: dict) -> np.ndarray:
    """Our DoF vector holding the reference's values, matched by part, primitive and
    DoF name; several connections on one primitive are matched in program order
    (the model orders its joints canonically, so sort them back by the line)."""
    names = facts["names"]
    written = {id(c): k for k, c in enumerate(model.program.connections)}
    ours: dict[str, list[int]] = defaultdict(list)
    for i, variable in sorted(
        enumerate(model.variables), key=lambda iv: written[id(model.joints[iv[1].joint].connection)]
    ):
        ours[variable.name].append(i)
    seen: dict[str, int] = defaultdict(int)
    x = model.x_default()
    for dof in facts["dofs"]:
        var, _, primitive = dof["primitive"].partition(".")
        name = f"{names[var]}.{primitive}.{dof['dof']}"
        x[ours[name][seen[name]]] = dof["value"]
        seen[name] += 1
    return x


def _reached_through_reference_closures(model: Model) -> set[str]:
    """Parts our tree reaches through a connection that closed a loop in the
    reference. The reference grew its tree in program order, so each loop's last
    written connection was its closure; our tree follows a canonical order and
    may cross it instead. The reference's answers leave their loops open by up to
    some centimetres, so such a part sits elsewhere there by construction."""
    from fabhal.check.cycles import _written_last

    closing = {_written_last(model, loop).index for loop in model.loops}
    parent = {}
    for edge in model.tree:
        up, down = model.placed_sides(edge)
        parent[down.part] = (up.part, edge.joint)

    def crosses(part: int) -> bool:
        while part in parent:
            part, joint = parent[part]
            if joint in closing:
                return True
        return False

    return {p.name for i, p in enumerate(model.parts) if crosses(i)}


@pytest.mark.parametrize("program", sorted(REFERENCE))
def test_part_frames_match_the_reference(program: str) -> None:
    facts = REFERENCE[program]
    model = model_of(REPO / "programs" / f"{program}.fhl")
    frames = model.part_frames(reference_x(model, facts))
    reached_otherwise = _reached_through_reference_closures(model)
    tolerance = 1.5 if program in NOISY else 1e-4  # mm; the reference prints 6 decimals
    for frame in facts["part_frames"]:
        name = facts["names"][frame["var"]]
        if name is None or name in reached_otherwise:  # name None: the reference's target wrapper
            continue
        expected = frame_matrix(frame["pos"], frame["rot"])
        got = frames[model.part_index(name)]
        assert np.abs(got[:3, 3] - expected[:3, 3]).max() < tolerance, (name, got[:3, 3], expected[:3, 3])
        assert np.abs(got[:3, :3] - expected[:3, :3]).max() < max(tolerance / 100, 1e-6), name


def test_tree_reaches_every_part_and_loops_become_closures() -> None:
    model = model_of(REPO / "programs" / "bird_feeder.fhl")
    assert model.unplaced == ()
    assert len(model.tree) == len(model.parts) - 1  # one environment
    (closure,) = model.closures
    assert str(model.joints[closure].connection.a) == "hanger.hook3"


def _numeric_derivative(function, x: np.ndarray, step: float = 1e-5) -> np.ndarray:
    """Central differences of an array-valued function, one column per DoF."""
    columns = []
    for i in range(len(x)):
        up, down = x.copy(), x.copy()
        up[i] += step
        down[i] -= step
        columns.append((function(up) - function(down)).ravel() / (2 * step))
    return np.stack(columns, axis=-1)


# every program with a loop, and the deepest chain
DERIVATIVE_PROGRAMS = [
    "bird_feeder",
    "reading_nook",
    "soap_bottle_holder",
    "toothbrush_holder",
    "clip_light_m",
]


@pytest.mark.parametrize("program", DERIVATIVE_PROGRAMS)
def test_batched_jacobians_match_finite_differences(program: str) -> None:
    """The vectorised twists give the exact derivatives of frames and loop errors.
    Tolerance 1e-4 relative to the largest entry: central differences with a 1e-5
    step carry ~1e-8 truncation error at the 1000 mm arm lengths here, and the
    analytic side itself is accurate to ~1e-10 (see model._STEP)."""
    model = model_of(REPO / "programs" / f"{program}.fhl")
    rng = np.random.default_rng(7)
    low, high = model.bounds()
    x = rng.uniform(np.where(np.isfinite(low), low, 0.0), np.where(np.isfinite(high), high, 360.0))
    fwd = model.forward(x, with_twists=True)
    last = len(model.parts) - 1
    numeric_frames = _numeric_derivative(lambda u: model.part_frames(u)[last], x)
    analytic_frames = model.frame_derivatives(fwd, last).reshape(len(x), 16).T
    scale = np.abs(numeric_frames).max()
    np.testing.assert_allclose(analytic_frames, numeric_frames, atol=1e-4 * scale)
    if model.closures:
        numeric = _numeric_derivative(model.closure_residuals, x)
        analytic = model.closure_jacobian(x)
        np.testing.assert_allclose(analytic, numeric, atol=1e-4 * np.abs(numeric).max())


@pytest.mark.parametrize("program", DERIVATIVE_PROGRAMS)
def test_weighted_height_gradient_matches_finite_differences(program: str) -> None:
    """The potential energy's gradient (all parts at once) against central
    differences of the weighted heights; same tolerance argument as above."""
    model = model_of(REPO / "programs" / f"{program}.fhl")
    rng = np.random.default_rng(11)
    low, high = model.bounds()
    x = rng.uniform(np.where(np.isfinite(low), low, 0.0), np.where(np.isfinite(high), high, 360.0))
    weights = rng.uniform(0.5, 2.0, len(model.parts))
    points = rng.uniform(-50.0, 50.0, (len(model.parts), 3))

    def weighted_height(u: np.ndarray) -> np.ndarray:
        frames = model.part_frames(u)
        heights = np.einsum("pj,pj->p", frames[:, 2, :3], points) + frames[:, 2, 3]
        return np.array([weights @ heights])

    numeric = _numeric_derivative(weighted_height, x)[0]
    analytic = model.weighted_height_gradient(model.forward(x, with_twists=True), weights, points)
    np.testing.assert_allclose(analytic, numeric, atol=1e-4 * np.abs(numeric).max())


@pytest.mark.parametrize(
    ("path", "bindings", "rounds"),
    [
        (REPO / "programs" / "reading_nook.fhl", {}, POINTER_JUMPING_DEPTH),
        # a chain: one part a level, composed by plain 4 x 4 products (`Jump.indices`)
        (REPO / "programs" / "clip_light_m.fhl", {}, POINTER_JUMPING_DEPTH),
        # 40 S-hooks deep: pointer jumping, ceil(log2(40)) + 1 = 7 rounds, not 40
        (REPO / "bench" / "programs" / "s_hook_chain.fhl", {"n": "40"}, 7),
    ],
)
def test_batched_frames_match_one_connection_at_a_time(
    path: Path, bindings: dict[str, str], rounds: int
) -> None:
    """The batched composition (a level at a time on the nook, pointer jumping on
    the deep chain) equals composing each tree edge alone (the formula of the
    module docstring), to rounding: 1e-9 mm, and 1e-8 mm on the chain, whose
    last hook is 40 products and 1.6 m from the rod (relative rounding 1e-16
    per product)."""
    result = api.check(path, bindings)
    assert result.ok and result.model is not None, result.diagnostics
    model = result.model
    assert len(model.layout.jumps) <= rounds
    x = model.x_default() + 0.1
    frames = model.part_frames(x)
    for edge in model.tree:
        joint = model.joints[edge.joint]
        parent, child = model.placed_sides(edge)
        offset = joint.offset if edge.parent_side == "a" else joint.offset.T
        parent_connector = model.connector_frame(parent, x, frames)
        child_local = child.primitive.connector_frames(x[list(child.dof_indices)])
        expected = parent_connector @ offset @ np.linalg.inv(child_local)
        np.testing.assert_allclose(frames[child.part], expected, atol=1e-8 if bindings else 1e-9)


def test_a_flex_angle_turns_only_until_its_wire_jams() -> None:
    """The model bounds a flex angle (`phi` of a flexible hook or ring, a
    turn about the line of its contact) where its wire jams, a real stop: a
    clip light's turnbuckle hook (arc radius 5.75, wire 1.5: 4.25 mm inside)
    on RingXS's wire (3.3 mm) jams at acos(sqrt(3.3 / 4.25)) = 28.22 degrees,
    within the reference's [45, 135]; the reading nook's links (14 mm inside)
    on its ObstacleRingL wires (3 mm) jam at acos(sqrt(3 / 14)) = 62.42,
    beyond it, and turn that far (the reference's 45 was an end nothing real
    has, E509). The S-hooks taped to the shelf edge fit it snugly (9.6 mm
    inside, 10 mm rod: N416): they cannot turn (pinned)."""
    import math

    light = build_model(api.check(REPO / "programs" / "clip_light_xs.fhl").model.program)  # type: ignore[union-attr]
    names = {v.name: (i, v.dof) for i, v in enumerate(light.variables)}
    _, turnbuckle = names["chain.tb[1].hook2.phi"]
    jam = math.degrees(math.acos(math.sqrt(3.3 / 4.25)))
    assert jam == pytest.approx(28.22, abs=0.01)
    assert (turnbuckle.low, turnbuckle.high) == pytest.approx((90 - jam, 90 + jam), abs=1e-9)
    assert turnbuckle.jammed and turnbuckle.ends_hold
    nook = api.check(REPO / "programs" / "reading_nook.fhl").model
    assert nook is not None
    names = {v.name: (i, v.dof) for i, v in enumerate(nook.variables)}
    _, link = names["link1.hook1.phi"]
    jam = math.degrees(math.acos(math.sqrt(3.0 / 14.0)))
    assert jam == pytest.approx(62.42, abs=0.01)
    assert (link.low, link.high) == pytest.approx((90 - jam, 90 + jam), abs=1e-9) and link.ends_hold
    snug, _ = names["s1.hook2.phi"]
    assert snug in nook.pinned


EYE_RING_ON_A_ROD = """\
environment rod = Rod(length: 300, radius: {radius}) at (0, 0, 300) rot (90, 0, 90)
e = HookEyeLeftS()
connect e.ring -- rod{setting}
target e at (0, 0, 250)
"""


def test_a_rods_tilt_of_a_ring_ends_where_the_wire_jams(tmp_path: Path) -> None:
    """The rod's `phi` tilts the eye ring hanging on it along the rod. On an
    8 mm rod the ring (10.32 mm inside) jams at acos(8 / 10.32) = 39.18
    degrees (primitives.tilt_jam_deg): the range narrows to 90 +- 39.18, a
    real stop (its ends hold, no E509), and a `set` past it is E315. On the
    closet's 6.35 mm rods the jam, acos(6.35 / 10.32) = 52.0, lies beyond
    the reference's 45, and the range reaches it (90 +- 52.0): its ends hold too."""
    import math

    program = tmp_path / "ring.fhl"
    program.write_text(EYE_RING_ON_A_ROD.format(radius=8, setting=""))
    model = api.check(program).model
    assert model is not None
    (tilt,) = [v.dof for v in model.variables if v.name == "rod.rod.phi"]
    jam = math.degrees(math.acos(8.0 / 10.32))
    assert jam == pytest.approx(39.18, abs=0.01)
    assert (tilt.low, tilt.high) == pytest.approx((90.0 - jam, 90.0 + jam), abs=1e-9)
    assert tilt.jammed and tilt.ends_hold
    program.write_text(EYE_RING_ON_A_ROD.format(radius=8, setting=" set (rod.phi: 40)"))
    assert [d.code for d in api.check(program).diagnostics if d.is_error] == ["E315"]
    closet = model_of(REPO / "programs" / "closet_basket.fhl")
    (rod,) = [v.dof for v in closet.variables if v.name == "rods.rod1.phi"]
    wide = math.degrees(math.acos(6.35 / 10.32))
    assert wide == pytest.approx(52.0, abs=0.05)
    assert (rod.low, rod.high) == pytest.approx((90.0 - wide, 90.0 + wide), abs=1e-9) and rod.ends_hold


def test_a_loop_that_grips_its_rod_does_not_tilt_along_it_unless_taped(tmp_path: Path) -> None:
    """An S-hook (arc radius 11.6, wire 2: 9.6 mm inside) on a 10 mm rod (20 mm
    across) is bent open round it (N416): the rod's section in any tilted
    plane of the hook reaches r / cos b >= 10 > 9.6 from the contact, so
    the hook's plane cannot turn along the rod at all: the rod's tilt is
    square, [90, 90], and pinned (before: the model's [45, 135]). Written
    `fixed` (taped on, as the reading nook's shelf hooks) the builder sets
    the tilt: the model's range stays."""
    program = tmp_path / "grip.fhl"
    text = (
        "environment rod = Rod(length: 300, radius: 10, slide_off: false) at (0, 0, 300) rot (120, 0, 90)\n"
        "s = DoubleHook()\n"
        "connect s.hook2 -- rod{fixed}\n"
        "target s.hook1 at (0, 0, 260)\n"
    )
    for fixed, expected in (("", (90.0, 90.0)), (" fixed", (45.0, 135.0))):
        program.write_text(text.format(fixed=fixed))
        model = model_of(program)
        (tilt,) = [i for i, v in enumerate(model.variables) if v.name == "rod.rod.phi"]
        dof = model.variables[tilt].dof
        assert (dof.low, dof.high) == expected
        assert (tilt in model.pinned) == (not fixed)


def _rod_contact_normal(model: Model) -> np.ndarray:
    """The world direction of the environment rod's contact normal at the model's start."""
    x = model.x_default()
    (joint,) = [j for j in model.joints if model.parts[j.b.part].environment]
    return model.connector_frame(joint.b, x, model.part_frames(x))[:3, 2]


@pytest.mark.parametrize(
    ("placed", "connection", "up"),
    [
        # the tension rod's frame puts its contact line (+y) on its side, level with its axis
        ("", "", (0.0, 0.0, 1.0)),
        # turned 20 degrees about y its axis runs along (cos 20, 0, -sin 20); of the
        # directions square to it the highest is (sin 20, 0, cos 20)
        (" rot (0, 20, 0)", "", (math.sin(math.radians(20)), 0.0, math.cos(math.radians(20)))),
        # taped on, the hook stays where the builder put it: the frame's own line (+y)
        ("", " fixed", (0.0, 1.0, 0.0)),
    ],
)
def test_what_rests_on_an_environments_rod_touches_its_top_line(
    tmp_path: Path, placed: str, connection: str, up: tuple[float, float, float]
) -> None:
    """An S-hook on a tension rod: the contact's outward normal points straight
    up (the rod's top line), or, on a sloping rod, as nearly up as a direction
    square to the axis can; before, it was the rod frame's +y, the rod's side,
    and a mug on that S-hook was `solved` hanging from a horizontal contact.
    Exact geometry: 1e-12."""
    program = tmp_path / "rod.fhl"
    program.write_text(
        f"environment rod = LongTensionRod() at (0, 0, 0){placed}\n"
        "s = DoubleHookMedium()\n"
        f"connect s.hook1 -- rod.rod{connection}\n"
        "target s at (1400, 127, 2100)\n"
    )
    model = model_of(program)
    assert _rod_contact_normal(model) == pytest.approx(up, abs=1e-12)
    (spin,) = [i for i, v in enumerate(model.variables) if v.name == "rod.rod.spin"]
    assert spin in model.pinned  # it stays there: the rod cannot turn


def test_plain_hooks_turn_on_hooks_only_on_a_loop(tmp_path: Path) -> None:
    """A flag stick laid in two ceiling hooks (a loop through the ceiling), an
    S-hook on the stick and a mug on the S-hook below it. The loop's
    connections are the stick's two; the ones below hang from it. Given the
    turn about the line of their contact (`turning_on_contact`), the ceiling
    hooks turn on the stick (a rod), and the mug's plain handle stays square
    on the S-hook: below the loop that turn carries nothing."""
    program = tmp_path / "flag.fhl"
    program.write_text(
        "environment c1 = CeilingHook() at (-120, 0, 1600) rot (0, 0, 90)\n"
        "environment c2 = CeilingHook() at (120, 0, 1600) rot (0, 0, 90)\n"
        "flag = FlagRod()\n"
        "s = DoubleHook()\n"
        "mug = Mug()\n"
        "connect flag.rod -- c1.hook\n"
        "connect flag.rod -- c2.hook\n"
        "connect s.hook2 -- flag.rod\n"
        "connect mug.hook -- s.hook1\n"
        "target mug at (0, 0, 1400)\n"
    )
    result = api.check(program)
    assert result.ok and result.flat is not None
    square = build_model(result.flat)
    looped = {f"{c.a} -- {c.b}" for c in square.on_loops()}
    assert looped == {"flag.rod -- c1.hook", "flag.rod -- c2.hook"}
    turning = build_model(result.flat, turning_on_contact=True)
    variants = {
        str(j.connection.a) + "|" + str(j.connection.b): (j.a.primitive.variant, j.b.primitive.variant)
        for j in turning.joints
    }
    assert variants["flag.rod|c1.hook"] == ("Rod", "HookFlex")
    assert variants["mug.hook|s.hook1"] == ("Hook", "HookFlex")  # the S-hook's own flex; the handle square


def test_a_program_is_named_by_text_as_well_as_by_a_path() -> None:
    """`api.check("programs/demo.fhl")`, as a newcomer writes it in Python,
    reads the same program as a Path does (it raised AttributeError)."""
    by_text = api.check(str(REPO / "programs" / "demo.fhl"))
    by_path = api.check(REPO / "programs" / "demo.fhl")
    assert by_text.ok and by_text.flat is not None and by_path.flat is not None
    assert [p.name for p in by_text.flat.parts] == [p.name for p in by_path.flat.parts]
