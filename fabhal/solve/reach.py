"""When step 1 cannot bring the target to its requested frame: by how much,
and what limits it (the parts' reach, or the target's requested rotation)
(W505); and when the settled hack hangs beside its request because what hangs
from one hook comes to rest under it (W506).

Out of reach means farther than a builder would place by eye (REACH_MM,
REACH_DEG). To tell the two limits apart, the position alone is fitted from
step 1's result: if it then comes within REACH_MM, the requested rotation is
what cannot be met; otherwise the parts cannot get there at all, and the
distance from the support they hang from says whether they are too short or
cannot fold close enough.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from fabhal.diagnostics import Diagnostic, warning
from fabhal.kinematics.frames import Array
from fabhal.model import Joint, Model, Side
from fabhal.solve import target as target_mod
from fabhal.solve.steps import FRICTION, Problem, end_of, fit_target

# a builder places and aims a hack by eye to about a centimetre and ten degrees;
# a fit this close is reported as reached (the table's error says how close)
REACH_MM = 10.0
REACH_DEG = 10.0
# the position-only fit starts where step 1 ended, near its answer: a short one
# tells the two limits apart (the gallery's take under 30 evaluations)
REACH_EVALUATIONS = 60


def out_of_reach(errors: tuple[float, float]) -> bool:
    position, rotation = errors
    return position > REACH_MM or rotation > REACH_DEG


def unexplained(model: Model, goal: target_mod.TargetGoal, x: Array) -> Diagnostic:
    """W505 for step 1's best `x`, which is out of reach, without the fit that
    tells what limits it (`diagnose`): for a family's members, whose notes
    are kept as codes only."""
    errors = target_mod.errors(goal, target_mod.achieved(goal, model.part_frames(x)))
    return warning(
        "W505",
        f"the target is out of reach: {_at_best(*errors)}",
        model.program.targets[0].span,
        "`fabhal solve` of this program says what limits it",
    )


def _at_best(position: float, rotation: float) -> str:
    """Where step 1's best fit left the target: the best of its starts, not a
    proof that nothing nearer exists (the reading nook, from another closure
    of its loops, came within 2.3 mm; bench/README.md item 60)."""
    return f"step 1 brings the target within {position:.0f} mm and {rotation:.0f} degrees of it"


def loosened(problem: Problem, goal: target_mod.TargetGoal, x: Array) -> tuple[Array, float]:
    """The position alone fitted from step 1's best `x` (its rotation let
    free): where that fit ends, and how far (mm) its position stays."""
    free_turn = replace(goal, rotation_weight=0.0)
    loose = problem.full(fit_target(problem, free_turn, [x[problem.free]], evaluations=REACH_EVALUATIONS).v)
    return loose, target_mod.errors(goal, target_mod.achieved(goal, problem.model.part_frames(loose)))[0]


def position_out_of_reach(position: float, loose_position: float) -> bool:
    """Whether the parts cannot bring the target to its requested position
    even turned freely (step 1's `position` and the loosened fit's, mm): its
    rotation alone is not what limits it."""
    return min(loose_position, position) > REACH_MM


def diagnose(
    problem: Problem, goal: target_mod.TargetGoal, x: Array, loose: Array, loose_position: float
) -> Diagnostic:
    """W505 for step 1's best `x`, which is out of reach, with its loosened
    fit (`loosened`): what limits it."""
    model = problem.model
    position, rotation = target_mod.errors(goal, target_mod.achieved(goal, model.part_frames(x)))
    frames = model.part_frames(loose)
    target = model.program.targets[0]
    at_best = _at_best(position, rotation)
    if not position_out_of_reach(position, loose_position):  # turned freely it gets there: rotation limits
        # the fit may have kept the rotation and given up the position: say the two together
        what = (
            "the requested position is out of reach turned as asked"
            if rotation <= REACH_DEG
            else "the requested rotation is out of reach"
        )
        return warning(
            "W505",
            f"{what}: {at_best}",
            target.span,
            f"the parts can bring the target within {min(loose_position, position):.0f} mm of the requested "
            "position, but not turned as asked: how it is held sets its rotation; ask for the "
            "rotation it takes there (see the result), or connect it differently",
        )
    return warning(
        "W505",
        f"the requested position is out of reach: {at_best}",
        target.span,
        _what_limits(model, goal, loose, frames, loose_position),
    )


def _what_limits(model: Model, goal: target_mod.TargetGoal, x: Array, frames: Array, gap: float) -> str:
    """The support the target hangs from, and how far the parts get from it;
    for a target standing on the world's floor where step 1 does not move it
    (another object there is placed by nothing: `model._stood_where_asked`),
    how to place it."""
    stood = _stood_in_the_middle(model, goal.part)
    if stood is not None:
        return (
            f"even turned freely, it stays {gap:.0f} mm away: it stands in the middle of `{stood}`, where "
            "another object on that floor stands wherever the solver puts it; say where that one stands "
            "(`set (...)` on its line) and this one is stood where asked, or set where this one stands"
        )
    support, anchor = _support(model, goal.part, x, frames)
    requested = goal.requested[:3, 3]
    reached = target_mod.achieved(goal, frames)[:3, 3]
    wanted, got = float(np.linalg.norm(requested - anchor)), float(np.linalg.norm(reached - anchor))
    nearest = f"even turned freely, it stays {gap:.0f} mm away"
    chain = _chain(model, goal.part, x, frames)
    if got < wanted - 0.5 * gap:
        how = f" ({chain.more(wanted - got)})" if chain is not None else ""
        return (
            f"{nearest}: the request is {wanted:.0f} mm from `{support}`, where the hack hangs, and "
            f"the parts reach {got:.0f} mm from it; add parts or use longer ones{how}"
        )
    if got > wanted + 0.5 * gap:
        fewer = chain.fewer(got - wanted) if chain is not None else None
        return (
            f"{nearest}: the request is {wanted:.0f} mm from `{support}`, where the hack hangs, but the "
            f"parts keep the target at least {got:.0f} mm from it; use fewer or shorter parts"
            + (f" ({fewer})" if fewer else "")
        )
    return f"{nearest}, in a direction the connections cannot move it; move the request or the support"


def _stood_in_the_middle(model: Model, part: int) -> str | None:
    """The floor (as `part.primitive`) the target stands on, where that is the
    world's and step 1 keeps it in its middle; else None."""
    for standing in model.standing:
        floor, thing = model.standing_sides(standing)
        slide = set(standing.slide)
        # in the middle: not moved by step 1, nor where the program says
        kept = slide <= model.pinned and not slide & model.written
        if thing.part == part and model.parts[floor.part].environment and kept:
            return str(model.joints[standing.joint].endpoint(floor))
    return None


def _support(model: Model, part: int, x: Array, frames: Array) -> tuple[str, Array]:
    """The environment the part hangs from along the tree, and the point of it
    that carries the hack (the environment side of that connection), in world."""
    found = _support_side(model, part)
    if found is None:
        return model.parts[part].name, frames[part][:3, 3]
    side, _ = found
    return model.parts[side.part].name, model.connector_frame(side, x, frames)[:3, 3]


def _support_side(model: Model, part: int) -> tuple[Side, Joint] | None:
    """The environment's side of the connection the part hangs from along the
    tree (and that connection), or None if no environment places it."""
    for parent, _, joint in _up_the_tree(model, part):
        if model.parts[parent.part].environment:
            return parent, joint
    return None


def _up_the_tree(model: Model, part: int) -> Iterator[tuple[Side, Side, Joint]]:
    """From `part` up the spanning tree to what places it: each connection's
    side above (the one placed first), its side below, and the connection."""
    parent_edges = {model.tree_child[edge.joint]: edge for edge in model.tree}
    while part in parent_edges:
        edge = parent_edges[part]
        parent, child = model.placed_sides(edge)
        yield parent, child, model.joints[edge.joint]
        part = parent.part


# environment primitives a hack hangs from at one point, free to swing every way
POINT_SUPPORTS = ("hook", "hole")
# and along a line (a closet rod): it swings about the line, its place along it chosen
LINE_SUPPORTS = ("rod", "tube")
# a line support steeper than this (its axis' horizontal part shorter) counts as a point
STEEP_AXIS = 0.1


@dataclass(frozen=True)
class _Hanging:
    """A settled hack hanging free from one support (`_hanging_from`): the
    support's side and connection, the parts' frames, where the hack touches
    the support, the support's horizontal direction (zero for a hook or ring,
    or a rod steeper than STEEP_AXIS), and the target's requested and reached
    places (world, mm)."""

    side: Side
    joint: Joint
    frames: Array
    anchor: Array
    along: Array
    requested: Array
    reached: Array


def _hanging(model: Model, goal: target_mod.TargetGoal, x: Array) -> _Hanging | None:
    found = _hanging_from(model, goal)
    if found is None:
        return None
    side, joint = found
    frames = model.part_frames(x)
    anchor = model.connector_frame(side, x, frames)[:3, 3]
    along = np.zeros(2)
    if side.primitive.kind in LINE_SUPPORTS:
        axis = (frames[side.part] @ side.primitive.base_frame())[:2, 2]  # a rod lies along its z
        length = float(np.linalg.norm(axis))
        along = axis / length if length > STEEP_AXIS else along
    requested, reached = goal.requested[:3, 3], target_mod.achieved(goal, frames)[:3, 3]
    return _Hanging(side, joint, frames, anchor, along, requested, reached)


def hangs_away(model: Model, goal: target_mod.TargetGoal, x: Array) -> tuple[Diagnostic, ...]:
    """Why a settled hack whose target hangs farther than REACH_MM from its
    request hangs there, where it hangs free from one support (no loops,
    nothing standing, the support's connection not held rigid; the caller
    leaves out hacks that lean on the environment, which may hold them
    aside). What hangs free from a hook, ring or rod comes to rest with its
    centre of mass under it (under a rod: in the vertical plane through its
    axis; along it, where the hook is placed), so: the request farther to the
    side than the target, by more than REACH_MM, W506 alone (`_beside_the_support`,
    which says where under the support to ask instead); or along a rod, where
    the hook cannot be placed (beyond the rod's end, `_beyond_its_end`, or up
    a rod too steep for friction to hold it, `_slid_down_it`), W506 and W511
    (`_hangs_below`): each says one fix."""
    hanging = _hanging(model, goal, x)
    if hanging is None or np.linalg.norm(hanging.requested - hanging.reached) <= REACH_MM:
        return ()
    aside = _beside_the_support(model, hanging)
    if aside is not None:
        return (aside,)
    along = _beyond_its_end(model, hanging) or _slid_down_it(model, hanging, x)
    return tuple(d for d in (along, _hangs_below(model, goal, x, hanging)) if d is not None)


def _beside_the_support(model: Model, hanging: _Hanging) -> Diagnostic | None:
    """W506 where the request lies farther across the support than the target."""
    along = hanging.along

    def aside(point: Array) -> Array:
        """Horizontal offset from the support, across it."""
        offset = (point - hanging.anchor)[:2]
        return offset - (offset @ along) * along

    requested, reached = hanging.requested, hanging.reached
    wanted, got = (float(np.linalg.norm(aside(point))) for point in (requested, reached))
    if wanted - got <= REACH_MM:
        return None
    under = requested[:2] - aside(requested) + aside(reached)  # the request, moved across under it
    return warning(
        "W506",
        f"the target hangs beside its request: the request is {wanted:.0f} mm to the side of "
        f"`{hanging.joint.endpoint(hanging.side)}`, which the hack hangs from, and what hangs free from "
        f"it comes to rest with its weight under it (here the target hangs {got:.0f} mm to its side)",
        model.program.targets[0].span,
        f"ask for a place under the support, such as ({_place(under, requested[2])}) at the requested "
        "height, or hang the target from a support above the request",
    )


def _place(horizontal: Array, height: float) -> str:
    return ", ".join(str(round(float(value))) for value in (*horizontal, height))  # never "-0"


def _along_the_rod(hanging: _Hanging) -> tuple[Array, float, float] | None:
    """For a hack hung from a rod that is not steep: the rod's frame, and the
    request's and the target's horizontal places along it from its middle
    (mm); None where the support is a point, or they lie within REACH_MM of
    each other along it."""
    if not hanging.along.any():
        return None
    rod = hanging.frames[hanging.side.part] @ hanging.side.primitive.base_frame()  # centred on its middle
    wanted, got = (
        float((point - rod[:3, 3])[:2] @ hanging.along) for point in (hanging.requested, hanging.reached)
    )
    return None if abs(wanted - got) <= REACH_MM else (rod, wanted, got)


def _beyond_its_end(model: Model, hanging: _Hanging) -> Diagnostic | None:
    """W506 where the request lies beyond an end of the rod the hack hangs
    from, farther than the target: the hook is placed along the rod, but only
    as far as its ends (a roll on a hanger from a closet rod's end asked for 90
    mm past it was told only that it hung 28 mm low)."""
    found = _along_the_rod(hanging)
    if found is None:
        return None
    rod, wanted, got = found
    half = float(hanging.side.primitive.params["length"]) / 2.0 * float(np.linalg.norm(rod[:2, 2]))
    beyond = abs(wanted) - half
    if beyond <= REACH_MM or np.sign(wanted) * (wanted - got) <= 0.0:
        return None
    within = hanging.requested[:2] - np.sign(wanted) * beyond * hanging.along  # moved back to the end
    return warning(
        "W506",
        f"the target hangs beside its request: the request lies {beyond:.0f} mm beyond the end of "
        f"`{hanging.joint.endpoint(hanging.side)}`, which the hack hangs from; what hangs from it is "
        f"placed along it only as far as its ends (here the target hangs {abs(wanted - got):.0f} mm short "
        "of the request along it)",
        model.program.targets[0].span,
        f"ask for a place within its length, such as ({_place(within, hanging.requested[2])}), or hang the "
        "hack from a support that reaches over the request",
    )


def _slid_down_it(model: Model, hanging: _Hanging, x: Array) -> Diagnostic | None:
    """W506 where the hook slid to the low end of a rod that slopes more than
    friction holds (atan FRICTION, 16.7 degrees) and the request lies up the
    rod from the target: no place the builder chooses along it stays (a mug
    on an S-hook from a closed rod sloping 20 degrees, asked for at its
    middle, hung 154 mm off, told only that it hung 38 mm low)."""
    found = _along_the_rod(hanging)
    if found is None:
        return None
    rod, wanted, got = found
    slope = math.degrees(math.asin(min(1.0, abs(float(rod[2, 2])))))
    holds = math.degrees(math.atan(FRICTION))
    slide = hanging.side.dof_indices[0]  # a rod's place along it, t from 0 to 1
    if slope <= holds or end_of(*model.bounds(), slide, x) is None:
        return None
    return warning(
        "W506",
        f"the target hangs beside its request: the request lies {abs(wanted - got):.0f} mm along "
        f"`{hanging.joint.endpoint(hanging.side)}` from where the target hangs, and the rod slopes "
        f"{slope:.0f} degrees, more than friction holds a hook on it ({holds:.0f}): "
        "what hangs from it slides to its low end",
        model.program.targets[0].span,
        "level the rod (or slope it less), tape the connection where you want it (`fixed`), or ask for a "
        "place under the rod's low end",
    )


def _hangs_below(model: Model, goal: target_mod.TargetGoal, x: Array, hanging: _Hanging) -> Diagnostic | None:
    """W511 for a settled hack whose target hangs more than REACH_MM below its
    request, the request lying under the one hook, ring or rod the hack hangs
    from (`hanging`): what hangs free from one support hangs straight down
    from it, so the parts between reach as far below it as their lengths
    make, and step 1, which folds them up with gravity off, cannot say so
    (W505 is for a request too far, not too near)."""
    side, joint = hanging.side, hanging.joint
    anchor, requested, reached = hanging.anchor[2], hanging.requested[2], hanging.reached[2]
    drop = requested - reached
    if drop <= REACH_MM or requested >= anchor:
        return None
    return warning(
        "W511",
        f"the target hangs {drop:.0f} mm below its request: what hangs from `{joint.endpoint(side)}` "
        f"hangs straight down from it, and the target comes to rest {anchor - reached:.0f} mm below "
        f"it where the request is {anchor - requested:.0f} mm below",
        model.program.targets[0].span,
        f"shorten what hangs between them by about {drop:.0f} mm "
        f"({_fewer_hint(model, goal, x, hanging.frames, drop)}), or ask for the target lower",
    )


@dataclass(frozen=True)
class _Chain:
    """The parts between the support and the target, where they are all of one
    kind and each spans alike (a chain of S-hooks): how many to add or leave out
    for a length."""

    kind: str
    pitch: float  # mm each spans: between its connection above and the one below
    count: int

    def fewer(self, length: float, nearest: bool = False) -> str | None:
        """`length` mm shorter: the count to leave out (at least that much, or the
        nearest), where leaving out fewer than all of them does."""
        fewer = round(length / self.pitch) if nearest else math.ceil(length / self.pitch)
        if not 1 <= fewer < self.count:
            return None
        return f"{fewer} fewer {self.kind}: each spans {self.pitch:.0f} mm here"

    def more(self, length: float) -> str:
        return f"{math.ceil(length / self.pitch)} more {self.kind}: each spans {self.pitch:.0f} mm here"


# parts span alike when their lengths along the chain differ by at most this fraction of their mean
ALIKE = 0.1


def _chain(model: Model, target: int, x: Array, frames: Array) -> _Chain | None:
    """The parts between the target and the environment it hangs from along the
    tree as a `_Chain`, if they are one kind spanning alike."""
    between = _spans_between(model, target, x, frames)
    kinds = {model.parts[part].type_name for part, _ in between}
    if len(kinds) != 1 or len(between) < 2:
        return None
    # the topmost hangs from the environment's primitive, the others from one like
    # themselves: theirs is the length each one added or left out makes
    lengths = np.array([length for _, length in between[:-1]])
    pitch = float(lengths.mean())
    if pitch <= 0.0 or np.ptp(lengths) > ALIKE * pitch:
        return None
    return _Chain(kinds.pop(), pitch, len(between))


def _spans_between(model: Model, target: int, x: Array, frames: Array) -> list[tuple[int, float]]:
    """The parts between the target and the environment it hangs from along the
    tree, target first, each with the distance between its connection toward
    the environment and its connection toward the target (mm)."""
    found: list[tuple[int, float]] = []
    below: Side | None = None  # the part's side toward the target
    for parent, child, _ in _up_the_tree(model, target):
        if below is not None:
            top = model.connector_frame(child, x, frames)[:3, 3]
            found.append(
                (child.part, float(np.linalg.norm(top - model.connector_frame(below, x, frames)[:3, 3])))
            )
        below = parent
    return found


def _fewer_hint(model: Model, goal: target_mod.TargetGoal, x: Array, frames: Array, drop: float) -> str:
    chain = _chain(model, goal.part, x, frames)
    return (chain.fewer(drop, nearest=True) if chain is not None else None) or "fewer or shorter parts"


def _hanging_from(model: Model, goal: target_mod.TargetGoal) -> tuple[Side, Joint] | None:
    """The environment's side and the connection a hack hangs from when it hangs
    free from one support (no loops, nothing standing, a hook, ring or rod whose
    connection is not held rigid); None otherwise."""
    found = _support_side(model, goal.part)
    if model.closures or model.standing or found is None:
        return None
    side, joint = found
    if side.primitive.kind not in POINT_SUPPORTS + LINE_SUPPORTS or joint.held:
        return None
    return side, joint


__all__ = ["REACH_DEG", "REACH_MM", "diagnose", "hangs_away", "out_of_reach"]
