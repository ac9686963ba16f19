"""What keeps a settled result from being at rest, and how each is said: a
part that comes off the end of what holds it (`Fall`, E501) and a lean held
only by the model's limit (`Lean`, E509), both found by the settle's
verification (fabhal/solve/__init__.py), and, found here in the settled
statics' wrenches, a contact that would have to pull (`LiftOff`, E512), a
standing object that falls over (`Topple`, E507) or slides on its round feet
(`Slip`, E510), a ring that would turn about its own wire (`Turn`,
E513) and a rod that would turn on its contact in a hook or ring (`Swivel`,
E514). docs/errors.md explains each error."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fabhal.diagnostics import Diagnostic, error
from fabhal.kinematics.frames import Array
from fabhal.kinematics.statics import MOMENT_ARM_MM, Wrenches, pressing
from fabhal.model import Joint, Model, Side, threaded
from fabhal.primitives import across, grips
from fabhal.solve.forces import (
    SquareLoop,
    WeldedRing,
    contact_lines,
    point_contacts,
    weight_newtons,
    welded_sides,
)
from fabhal.solve.steps import FRICTION, FRICTION_AGREEMENT

# a standing object falls over when its floor would have to push beyond the edge
# of its base by more than this (the base's rim is not a knife edge)
TOPPLE_MARGIN_MM = 0.5


@dataclass(frozen=True)
class Fall:
    joint: int
    dof: int  # index into the model's variables
    end: str  # "min" or "max"
    part: str  # the part that comes off


@dataclass(frozen=True)
class Slip:
    """An object on round feet on a floor steeper than friction holds: its feet
    would slide (where it ends, against a wall or off the floor, is not computed)."""

    joint: int  # the connection of one of its feet and the floor
    part: str
    ratio: float  # the feet's pull along the floor over their push into it (holds up to FRICTION)
    slope_deg: float


@dataclass(frozen=True)
class Lean:
    """A lean (a flex angle: a hook tilting on the rod it hangs from) pushed
    against the end of its range: the range is the model's, a real hook would
    tilt on, so the pose is not one the real objects rest in."""

    joint: int
    dof: int
    end: str  # "min" or "max"
    push: float  # the generalised force on the stop, per mm of motion, over the weight
    part: str  # the part whose lean it is


@dataclass(frozen=True)
class LiftOff:
    """A contact that would have to pull: the parts of a hook, ring or rod
    connection only press on each other (along the contact's normal), so where
    the statics needs the one to pull the other, the real parts separate there
    (a hook hung from the inside of a ring's top, pulled down by what hangs
    from it). Where they go then is not computed."""

    joint: int
    holder: str  # the side that would have to pull (the placed one: nearer the environment)
    held: str  # the side it would have to pull, whose part lifts off
    part: str  # that part
    pull: float  # N: the force along the contact's normal the holder would have to pull with


@dataclass(frozen=True)
class Topple:
    joint: int  # the connection of the object and the floor it stands on
    part: str  # the object that falls over
    beyond_mm: float  # how far beyond its base's edge the floor would have to push (inf: it lifts off)
    slope_deg: float  # the floor's slope
    floor: str  # the connection's side ("a" or "b") that is the floor
    on_feet: bool = False  # it stands on round feet (points), not on a base


@dataclass(frozen=True)
class Turn:
    """A ring held by a hook that would turn about its own wire: the model keeps
    its contact on the ring's inner line (no `spin`), and at rest there the
    contact carries a moment about the wire that two wires touching at a point
    cannot: its force would have to pass outside the ring's wire. The real ring
    turns (where to is not computed)."""

    joint: int
    ring: str  # the ring's endpoint, as written
    hook: str
    part: str  # the ring's part
    moment: float  # N mm about the ring's wire
    lever_mm: float  # how far from the wire's centre line the force would have to pass
    wire_mm: float  # the ring's wire radius
    others: tuple[str, ...] = ()  # the other rings that would turn, by how much over their wires, most first


@dataclass(frozen=True)
class Swivel:
    """A rod in a hook or ring that would turn on its contact: the model keeps
    the loop square round the rod (`forces.SquareLoop`), and at rest there the
    contact carries a moment about the line of the contact, and a force along
    the loop's wire, that a rod touching a wire at a point cannot: the real
    rod turns on the wire or slides along it (where to is not computed)."""

    joint: int
    rod: str  # the rod's endpoint, as written
    loop: str
    part: str  # the rod's part
    moment: float  # N mm about the line of the contact
    along: float  # N along the loop's wire at the contact
    others: tuple[str, ...] = ()  # the other rods that would turn, most first


# what keeps a result from being at rest, each said by an error
Failure = Fall | Topple | Lean | Slip | LiftOff | Turn | Swivel
# held only by the model (a lean's stop, a welded ring, a loop kept square on a rod) or
# sliding feet: not at rest, nothing falls
RESTLESS = Lean | Slip | Turn | Swivel


# a contact "pulls" where the pull along its normal is over this fraction of the assembly's
# weight: the statics' split of a loop's load (least squares) leaves a few thousandths
# of it on contacts that carry nothing (the caddy's lower S-hooks: 0.002 N)
LIFT_CARRIES = 0.01


def lifts_off(model: Model, x: Array, wrenches: Wrenches, masses: Array) -> tuple[LiftOff, ...]:
    """The connections that would have to pull (`LiftOff`): of those that only
    press (`_presses_only`), where the force side a exerts on side b points
    against a's normal (the connector frame's z points from a's material to
    what it holds: the gallery's hooks, rings and rods all press along it).
    In a loop the statics' smallest wrenches are one split of the load among
    many: a contact pulls only where no split (the loop's own force states
    added, and those it nearly has, within the settle's slack: chains hanging
    straight; `statics.pressing`) lets every contact press (a mug hung on a rod
    and on the S-hook beside it: the smallest split has the handle pull the
    S-hook up; another has it carry the S-hook's weight)."""
    joints = [joint for joint in model.joints if _presses_only(joint)]
    if not joints:
        return ()
    frames = model.part_frames(x)
    index = np.array([joint.index for joint in joints])
    normals = np.array([model.connector_frame(joint.a, x, frames)[:3, 2] for joint in joints])
    along = pressing(
        np.einsum("jk,jk->j", wrenches.forces[index], normals),
        np.einsum("sjk,jk->sj", wrenches.indeterminate[:, index], normals),
        wrenches.reach,
        wrenches.taken,
    )
    limit = LIFT_CARRIES * float(weight_newtons(masses).sum())
    lifts = []
    for joint, force in zip(joints, along, strict=True):
        if -force > limit:
            holder, held = _holder_and_held(model, joint)
            name = model.parts[held.part].name
            lifts.append(
                LiftOff(joint.index, str(joint.endpoint(holder)), str(joint.endpoint(held)), name, -force)
            )
    return tuple(lifts)


def turns_about_wires(
    model: Model, x: Array, rings: list[WeldedRing], wrenches: Wrenches, newtons: float
) -> tuple[Turn, ...]:
    """The welded rings (`forces.welded_rings`) that would turn about their
    wires in `wrenches`, the statics as the model has it (the assembly weighing
    `newtons`): in a loop these are one split of the load among many, so the
    caller confirms that no split needs the moments (`solve._held_by_the_model`).
    A ring turns where its moment about its wire's centre line,
    M = (m + w z x f) . y (m about the contact, w the wire's radius, y along
    the wire, z from the wire to what holds it), is more than |f| w: its force
    would pass outside the wire (M / |f| from the centre line), where no
    contact on that wire can act. Within, its contact rocks on the wire's
    section (the paper-towel holder's eye rings: 1.1 mm of 4.5), and a moment
    under 1 % of the weight at w is the rounding of a ring that carries
    nothing."""
    frames = model.part_frames(x)
    turns = []
    for ring in rings:
        connector = model.connector_frame(ring.ring, x, frames)
        wire = float(ring.ring.primitive.params["thickness"])
        force, moment = wrenches.forces[ring.joint], wrenches.moments[ring.joint]
        about = abs(float((moment + np.cross(wire * connector[:3, 2], force)) @ connector[:3, 1]))
        carried = float(np.linalg.norm(force))
        if about > max(carried, LIFT_CARRIES * newtons) * wire:
            joint = model.joints[ring.joint]
            turns.append(
                Turn(
                    ring.joint,
                    str(joint.endpoint(ring.ring)),
                    str(joint.endpoint(ring.hook)),
                    model.parts[ring.ring.part].name,
                    about,
                    about / max(carried, 1e-12),
                    wire,
                )
            )
    if not turns:
        return ()
    worst, *others = sorted(turns, key=lambda turn: -turn.lever_mm / turn.wire_mm)
    return (
        replace(worst, others=tuple(dict.fromkeys(turn.ring for turn in others if turn.ring != worst.ring))),
    )


def swivels(
    model: Model, x: Array, loops: list[SquareLoop], wrenches: Wrenches, newtons: float
) -> tuple[Swivel, ...]:
    """The square loops (`forces.square_loops`) whose contact carries, in
    `wrenches` (the statics as the model has it, the assembly weighing
    `newtons`), what a rod touching a wire at a point cannot: a moment about
    the line of the contact (its normal n through the contact point, where
    the moments are taken), M . n, or a force along the loop's wire there,
    F . (n x a) (a the rod's axis), more than 1 % of the weight at the rod's
    radius or along the wire (less is the rounding of a contact that carries
    nothing). Named for the one that carries most about the line, the others
    listed. In a loop these are one split of the load among many: the caller
    confirms that no split needs them (`solve._held_by_the_model`)."""
    found = []
    for loop, normal, axis in zip(loops, *contact_lines(model, x, loops), strict=True):
        along_wire = np.cross(normal, axis)
        moment = abs(float(wrenches.moments[loop.joint] @ normal))
        along = abs(float(wrenches.forces[loop.joint] @ along_wire))
        if max(along, moment / (across(loop.rod.primitive) / 2.0)) <= LIFT_CARRIES * newtons:
            continue
        joint = model.joints[loop.joint]
        rod = str(joint.endpoint(loop.rod))
        found.append(
            Swivel(
                loop.joint,
                rod,
                str(joint.endpoint(loop.loop)),
                model.parts[loop.rod.part].name,
                moment,
                along,
            )
        )
    if not found:
        return ()
    worst, *others = sorted(found, key=lambda swivel: -swivel.moment)
    return (replace(worst, others=tuple(dict.fromkeys(o.rod for o in others if o.rod != worst.rod))),)


def _holder_and_held(model: Model, joint: Joint) -> tuple[Side, Side]:
    """A connection's sides, the one nearer the environment first: an
    environment's, else the side the spanning tree hangs the other from."""
    if model.parts[joint.b.part].environment or model.tree_child.get(joint.index) == joint.a.part:
        return joint.b, joint.a
    return joint.a, joint.b


def _presses_only(joint: Joint) -> bool:
    """Whether a connection's parts can only press on each other: a hook, ring
    or rod resting on another, not held (a clip's grip, `fixed`, standing on a
    floor: those carry either way, or are judged as standing), not a sleeve
    threaded on a rod nor a hook bent open round it (`primitives.grips`: each
    holds it all round)."""
    kinds = {joint.a.primitive.kind, joint.b.primitive.kind}
    gripped = grips(joint.a.primitive, joint.b.primitive) or grips(joint.b.primitive, joint.a.primitive)
    return (
        not joint.held
        and threaded(joint) is None
        and not gripped
        and kinds <= {"hook", "hole", "rod", "tube", "edge"}
    )


def topples(model: Model, x: Array, wrenches: Wrenches, at_bound: set[int]) -> tuple[Topple, ...]:
    """The standing objects that would fall over: where the floor's push would
    have to act outside the object's base. A floor carries an object by a
    pressure spread over the base; its resultant, N along the floor's normal n,
    acts at the centre of pressure c (from the contact point), and the moment it
    carries about the contact point is M = c x N n, so c = n x M / N. Within the
    base, the object stands; beyond its edge, no pressure can balance it and it
    tips over that edge. An object pushed against its floor's wall (its slide on
    an end of its range) leans on the wall and is not tested."""
    frames = model.part_frames(x)
    topples = []
    for standing in model.standing:
        if at_bound & set(standing.slide):
            continue
        joint = model.joints[standing.joint]
        floor, thing = model.standing_sides(standing)
        sign = 1.0 if standing.floor == "a" else -1.0  # the wrench is what a exerts on b
        force, moment = sign * wrenches.forces[joint.index], sign * wrenches.moments[joint.index]
        normal = model.connector_frame(floor, x, frames)[:3, 2]
        base = model.connector_frame(thing, x, frames)[:3, :2]  # along the base's length (x), width (y)
        pressing = float(force @ normal)
        width, length = standing.base
        if pressing <= 0.0:
            beyond = float("inf")  # the floor would have to pull: it lifts off
        else:
            centre = base.T @ np.cross(normal, moment) / pressing
            beyond = float(np.max(np.abs(centre) - (length / 2.0, width / 2.0)))
        if beyond > TOPPLE_MARGIN_MM:
            slope = _slope(normal)
            topples.append(Topple(joint.index, model.parts[thing.part].name, beyond, slope, standing.floor))
    return tuple(topples)


def tips_off_its_feet(model: Model, x: Array, wrenches: Wrenches, weight: float) -> tuple[Topple | Slip, ...]:
    """Objects on round feet (hemispheres on a surface) that would fall over or
    slide. Each foot touches at a point: it pushes, with friction, and carries
    no moment (the statics gives it none: forces.point_contacts). So the object
    stands only where pushes at its feet balance it: its weight acts within the
    polygon of its feet (a tripod's triangle; on two feet only exactly above
    the line between them). Where they cannot, the statics' best pushes F leave
    a moment M unbalanced: the weight acts M / F beyond the feet (exactly so on
    two feet: F d with d the distance from their line). A foot that would have
    to pull lifts off. An object that stands slides where its feet together
    pull along the floor more than FRICTION times they push into it (one rigid
    object on one floor: only the sums are determined, not each foot's share)."""
    feet = np.flatnonzero(point_contacts(model))
    if not len(feet):
        return ()
    frames = model.part_frames(x)
    newtons = 1000.0 * weight
    found: dict[int, Topple | Slip] = {}
    # per object: the floor's force on all its feet, the floor's normal, one foot
    totals: dict[int, tuple[Array, Array, int]] = {}
    for j in feet.tolist():
        joint = model.joints[j]
        side = "a" if joint.a.primitive.kind == "surface" else "b"
        floor, foot, sign = (joint.a, joint.b, 1.0) if side == "a" else (joint.b, joint.a, -1.0)
        normal = model.connector_frame(floor, x, frames)[:3, 2]
        pressing = float(sign * wrenches.forces[j] @ normal)
        force_left, moment_left = wrenches.unbalanced[foot.part]
        carried = newtons - force_left  # what the feet's pushes balance
        margin = TOPPLE_MARGIN_MM / MOMENT_ARM_MM * newtons
        # M / F is a distance only where the feet carry a share of the weight: carrying none of it
        # (they would have to pull), the weight acts outside them however far
        beyond = moment_left / carried if carried > margin else float("inf")
        if pressing < -margin:
            beyond = float("inf")
        if beyond > TOPPLE_MARGIN_MM and foot.part not in found:
            found[foot.part] = Topple(
                j, model.parts[foot.part].name, beyond, _slope(normal), side, on_feet=True
            )
        total = totals.get(foot.part, (np.zeros(3), normal, j))[0]
        totals[foot.part] = (total + sign * wrenches.forces[j], normal, j)
    for part, (total, normal, j) in totals.items():
        push = float(total @ normal)
        ratio = float(np.linalg.norm(total - push * normal)) / max(push, 1e-12)
        if part not in found and ratio > FRICTION * (1.0 + FRICTION_AGREEMENT):
            found[part] = Slip(j, model.parts[part].name, ratio, _slope(normal))
    return tuple(found.values())


def _slope(normal: Array) -> float:
    """A floor's slope (degrees) from its normal."""
    return float(np.degrees(np.arccos(np.clip(normal[2], -1.0, 1.0))))


def falling_part(model: Model, joint: Joint, side: str) -> str:
    """The part that comes off: the side of the connection farther from the environment."""
    if joint.index in model.tree_child:
        return model.parts[model.tree_child[joint.index]].name
    other = joint.b if side == "a" else joint.a
    return model.parts[other.part].name


def fall_diagnostic(model: Model, fall: Failure) -> Diagnostic:
    if isinstance(fall, Topple):
        return _topple_diagnostic(model, fall)
    if isinstance(fall, Slip):
        return _slip_diagnostic(model, fall)
    if isinstance(fall, Lean):
        return _lean_diagnostic(model, fall)
    if isinstance(fall, LiftOff):
        return _lift_off_diagnostic(model, fall)
    if isinstance(fall, Turn):
        return _turn_diagnostic(model, fall)
    if isinstance(fall, Swivel):
        return _swivel_diagnostic(model, fall)
    variable = model.variables[fall.dof]
    joint = model.joints[fall.joint]
    end = joint.connection.a if variable.side == "a" else joint.connection.b
    primitive = model.side_of(fall.dof).primitive
    value = variable.dof.low if fall.end == "min" else variable.dof.high
    edge = "edge" if primitive.kind == "surface" else "end"
    where = (
        f"the tip of {primitive.kind} `{end}`"
        if primitive.kind == "hook"
        else f"the {edge} of {primitive.kind} `{end}` ({variable.dof.name} = {value:g})"
    )
    return error(
        "E501",
        f"the assembly falls apart here: `{fall.part}` slides off {where}",
        joint.connection.span,
        "gravity keeps pulling it past the end; support it at a second point, turn or tilt the "
        "primitive the other way, or use one closed at that end",
    )


def _lean_diagnostic(model: Model, lean: Lean) -> Diagnostic:
    variable = model.variables[lean.dof]
    joint = model.joints[lean.joint]
    end = joint.connection.a if variable.side == "a" else joint.connection.b
    limit = variable.dof.low if lean.end == "min" else variable.dof.high
    return error(
        "E509",
        f"not at rest: only the model's limit of the lean of `{end}` (phi = {limit:g}) holds the "
        f"hack here ({100 * lean.push:.0f} % of its weight per mm); a real hook or ring would tilt on",
        joint.connection.span,
        "this way of connecting does not hang here: turn a connection the other way (`flip`), or hang "
        "the part from a second point",  # `_with_flip_advice` says which way, where it knows
    )


def _lift_off_diagnostic(model: Model, lift: LiftOff) -> Diagnostic:
    joint = model.joints[lift.joint]
    help_text = (
        "hung this way the weight pulls the parts apart (a hook from the inside of a ring's top): hang it "
        "where what holds it is beneath it, or turn the connection the other way (`flip`)"
    )
    if welded_sides(joint):
        help_text += (
            "; a ring here keeps its contact on its inner line: where a hook should hold its wire from "
            "above (a hoop hung level), use a part whose ring says `spin: true` (the library's "
            "LevelHulaHoop; docs/primitives.md)"
        )
    return error(
        "E512",
        f"the assembly falls apart here: `{lift.holder}` would have to pull `{lift.held}` with "
        f"{lift.pull:.2f} N to hold it, but a contact only presses: `{lift.part}` lifts off",
        joint.connection.span,
        help_text,
    )


OTHERS_NAMED = 3  # E513 and E514 name this many of the others that would turn


def _so_would(others: tuple[str, ...]) -> str:
    named = ", ".join(f"`{name}`" for name in others[:OTHERS_NAMED])
    if len(others) > OTHERS_NAMED:
        named += f" and {len(others) - OTHERS_NAMED} more"
    return f"; so would {named}" if named else ""


def _turn_diagnostic(model: Model, turn: Turn) -> Diagnostic:
    also = _so_would(turn.others)
    return error(
        "E513",
        f"not at rest: `{turn.ring}` would turn about its own wire in `{turn.hook}`: held still it "
        f"carries {turn.moment:.3g} N mm about the wire, as if its force passed {turn.lever_mm:.3g} mm "
        f"from the wire's centre line, outside the wire ({turn.wire_mm:g} mm in radius){also}",
        model.joints[turn.joint].connection.span,
        "the model keeps this ring's contact on its inner line, as the reference does; a real ring turns "
        "in the hook until what hangs from it pulls in line. Use a part whose ring says `spin: true` "
        "(docs/primitives.md), or hang the ring so that what it carries pulls in its plane",
    )


def _swivel_diagnostic(model: Model, swivel: Swivel) -> Diagnostic:
    also = _so_would(swivel.others)
    return error(
        "E514",
        f"not at rest: `{swivel.rod}` would turn on its contact with `{swivel.loop}`: held still it carries "
        f"{swivel.moment:.3g} N mm about the line of the contact and {swivel.along:.2f} N along the wire, "
        f"which a rod touching a wire at a point cannot{also}",
        model.joints[swivel.joint].connection.span,
        "the model keeps the hook or ring square round the rod, as the reference does; the real rod turns "
        "on the wire, or slides along it, until what it carries pulls through the contact. Hang the rod "
        "where the loop's wire is beneath it, use a hook that says `flex: true` (docs/primitives.md), or "
        "tape the connection (`fixed`)",
    )


def _topple_diagnostic(model: Model, topple: Topple) -> Diagnostic:
    joint = model.joints[topple.joint]
    on = joint.connection.a if topple.floor == "a" else joint.connection.b
    base = "its feet" if topple.on_feet else "the edge of its base"
    if np.isfinite(topple.beyond_mm):
        why = f"its weight acts {topple.beyond_mm:.0f} mm beyond {base}"
    elif topple.on_feet:
        why = "its weight acts outside its feet: this foot would have to pull the floor, it lifts off"
    else:
        why = "the floor would have to pull it down: it lifts off"
    return error(
        "E507",
        f"the assembly falls apart here: `{topple.part}` falls over on `{on}` ({why}; "
        f"the floor slopes {topple.slope_deg:.0f} degrees)",
        joint.connection.span,
        "level the floor (hang it from a second point), stand the object against the floor's side, "
        "or stand a lower or wider one there",
    )


# beyond this the feet's pull along the floor over their push into it is no number to read
SLIP_RATIO_SHOWN = 100.0


def _slip_diagnostic(model: Model, slip: Slip) -> Diagnostic:
    pull = (
        f"they pull along the floor {slip.ratio:.2f} times as hard as they push into it"
        if slip.ratio < SLIP_RATIO_SHOWN
        else "they hardly press on the floor at all"
    )
    return error(
        "E510",
        f"not at rest: `{slip.part}` slides on its round feet ({pull}; friction holds up to {FRICTION}: "
        f"the floor slopes {slip.slope_deg:.0f} degrees)",
        model.joints[slip.joint].connection.span,
        f"level the floor below atan {FRICTION} = {np.degrees(np.arctan(FRICTION)):.1f} degrees, "
        "or stand the object against something that stops it",
    )
