"""The forces in a configured model: what each connection carries, and the
normal and sliding force at each slide (for Coulomb friction and the report).

The model's side of `fabhal.kinematics.statics`: contact points, free motions
and weights from the model's forward kinematics.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from fabhal.kinematics.frames import Array, angular_velocities
from fabhal.kinematics.statics import Wrenches, joint_wrenches
from fabhal.model import Joint, Model, Side
from fabhal.primitives import TILTING, grips

GRAVITY = 9.81  # m/s2
SLIDING_KINDS = ("rod", "tube", "edge")


def weight_newtons(masses: Array) -> Array:
    """Grams -> newtons."""
    return masses / 1000.0 * GRAVITY


@dataclass(frozen=True)
class Slide:
    """A motion that Coulomb friction resists: a part sliding along a rod, tube
    or edge (one DoF: the force across the line presses the contact), or an
    object sliding over the floor it stands on (two DoFs: the force into the
    floor presses it)."""

    dofs: tuple[int, ...]
    joint: int


def friction_slides(model: Model) -> list[Slide]:
    """The slides friction resists: the first DoF (`t`) of a rod, tube or edge
    side, unless pinned or held; and where each standing object is on its floor."""
    slides = [Slide(standing.slide, standing.joint) for standing in model.standing]
    for joint in model.joints:
        if joint.held:
            continue
        for side in (joint.a, joint.b):
            if side.primitive.kind in SLIDING_KINDS and side.dof_indices:
                t = side.dof_indices[0]
                if model.variables[t].dof.name == "t" and t not in model.pinned:
                    slides.append(Slide((t,), joint.index))
    return sorted(slides, key=lambda slide: slide.dofs)


def point_contacts(model: Model) -> Array:
    """(J,) the connections that touch at a point: a hemisphere (a ball, a
    round foot) resting on a surface, unless `fixed` (glued or taped down). A
    point carries a push and friction, no moment: what stands on such feet
    stands only if its weight acts within them (`fabhal.solve` E507)."""
    return np.array(
        [
            {joint.a.primitive.kind, joint.b.primitive.kind} == {"hemisphere", "surface"}
            and not joint.connection.fixed
            for joint in model.joints
        ],
        dtype=bool,
    )


WELDED_RINGS = ("Ring", "RingFlex")  # hole variants whose contact stays on the inner line


@dataclass(frozen=True)
class WeldedRing:
    """A ring held by a hook whose contact the model keeps on the ring's inner
    line (no `spin`): it lacks the real ring's turn about its own wire, so it
    can carry a moment about the wire that no contact of two wires carries."""

    joint: int
    ring: Side
    hook: Side


def welded_sides(joint: Joint) -> list[tuple[Side, Side]]:
    """(ring, hook) where a connection is a ring without `spin` held by a hook."""
    return [
        (ring, hook)
        for ring, hook in ((joint.a, joint.b), (joint.b, joint.a))
        if ring.primitive.variant in WELDED_RINGS and hook.primitive.kind == "hook"
    ]


def welded_rings(model: Model) -> list[WeldedRing]:
    """The rings without `spin` held by a hook, not taped or clipped there
    (`fixed`: the tape carries what the contact does not)."""
    return [
        WeldedRing(joint.index, ring, hook)
        for joint in model.joints
        if not joint.held
        for ring, hook in welded_sides(joint)
    ]


def about_the_wire(model: Model, x: Array, rings: list[WeldedRing]) -> tuple[Array, Array, Array]:
    """Each welded ring's missing turn about its own wire, as a free motion for
    `connection_wrenches`: the rotation about the wire's centre line (the
    connector's y, through the point the wire's radius w behind the contact,
    -w along the connector's z), so at the contact the velocity w x per radian.
    (R,) joints, (R, 3) velocities (mm), (R, 3) rotations (rad)."""
    frames = model.part_frames(x)
    connectors = np.array([model.connector_frame(ring.ring, x, frames) for ring in rings]).reshape(-1, 4, 4)
    wires = np.array([ring.ring.primitive.params["thickness"] for ring in rings])
    joints = np.array([ring.joint for ring in rings], dtype=int)
    return joints, wires[:, None] * connectors[:, :3, 0], connectors[:, :3, 1]


# loops the model keeps square round a rod: no turn about the line of their contact (a
# flexing hook's or ring's `phi` is that turn, with its jam)
SQUARE_LOOPS = ("Hook", "Ring", "RingSpin")


@dataclass(frozen=True)
class SquareLoop:
    """A rod lying in a hook or ring that the model keeps from turning about the
    line of their contact (the common normal through the contact point): the
    reference's rod-in-loop connection has four DoFs where a rod touching a
    wire at a point has five, so the contact can carry a moment about that
    line and, with the rod tilted, a force along the wire, neither of which a
    push at a point carries."""

    joint: int
    rod: Side
    loop: Side


def square_loops(model: Model) -> list[SquareLoop]:
    """The rods in hooks or rings that do not flex (`SQUARE_LOOPS`), not
    `fixed` (tape holds what the contact does not) and not gripped (a hook
    bent open round a rod cannot turn on it: its wire jams at once)."""
    return [
        SquareLoop(joint.index, rod, loop)
        for joint in model.joints
        if not joint.held
        for rod, loop in ((joint.a, joint.b), (joint.b, joint.a))
        if rod.primitive.variant in TILTING
        and loop.primitive.variant in SQUARE_LOOPS
        and not grips(loop.primitive, rod.primitive)
    ]


def contact_lines(model: Model, x: Array, loops: list[SquareLoop]) -> tuple[Array, Array]:
    """(L, 3) each rod's normal at its contact with the loop and (L, 3) the
    rod's axis (the direction its slide `t` moves it): the normal is the
    loop's inward direction there (its connector's z) less its part along
    the axis, as a rod's surface normal is square to its axis."""
    fwd = model.forward(x, with_twists=True)
    assert fwd.own_twists is not None
    normals, axes = np.zeros((len(loops), 3)), np.zeros((len(loops), 3))
    for k, loop in enumerate(loops):
        axis = fwd.own_twists[loop.rod.dof_indices[0], :3, 3]
        axes[k] = axis / np.linalg.norm(axis)
        inward = model.connector_frame(loop.loop, x, fwd.frames)[:3, 2]
        normal = inward - (inward @ axes[k]) * axes[k]
        normals[k] = normal / np.linalg.norm(normal)
    return normals, axes


def about_the_normal(model: Model, x: Array, loops: list[SquareLoop]) -> tuple[Array, Array, Array]:
    """Each square loop's missing turn about the line of its contact, as a free
    motion for `connection_wrenches`: a rotation about the contact normal
    through the contact point (no velocity there). (L,) joints, (L, 3)
    velocities (mm), (L, 3) rotations (rad)."""
    joints = np.array([loop.joint for loop in loops], dtype=int)
    return joints, np.zeros((len(loops), 3)), contact_lines(model, x, loops)[0]


def slide_dofs(slides: Iterable[Slide]) -> list[int]:
    return [i for slide in slides for i in slide.dofs]


def connection_wrenches(
    model: Model,
    x: Array,
    masses: Array,
    centres: Array,
    carrying: Iterable[int],
    contact_loads: tuple[Array, Array] | None = None,
    slack: float = 0.0,
    also_free: tuple[Array, Array, Array] | None = None,
) -> Wrenches:
    """What every connection carries at x. `carrying`: the DoFs that can carry a
    load along their motion (held, pinned, resting on an end of their range,
    held by friction); every other DoF's motion is free.

    masses: (P,) grams; centres: (P, 3) mm in part frames; contact_loads: the
    environment's contact forces on each part (P, 3) N and their moments about
    the world origin (P, 3) N mm (fabhal/solve/contacts.py); slack: the
    imbalance (N) a state at rest may keep (`statics.joint_wrenches`)."""
    fwd = model.forward(x, with_twists=True)
    assert fwd.own_twists is not None
    frames = fwd.frames
    part_a = np.array([j.a.part for j in model.joints], dtype=int)
    part_b = np.array([j.b.part for j in model.joints], dtype=int)
    points = model.connection_points(fwd)
    world_centres = np.einsum("pij,pj->pi", frames[:, :3, :3], centres) + frames[:, :3, 3]
    loads = np.zeros((len(model.parts), 3))
    loads[:, 2] = -weight_newtons(masses)
    load_moments = None
    if contact_loads is not None:
        forces, moments = contact_loads
        loads = loads + forces
        load_moments = moments - np.cross(world_centres, forces)  # about each centre of mass
    movable = np.array([not p.environment for p in model.parts]) & _placed(model)
    held = set(carrying)
    free = [i for i in range(len(model.variables)) if i not in held]
    joint = np.array([model.variables[i].joint for i in free], dtype=int)
    sign = np.array([1.0 if model.variables[i].side == "a" else -1.0 for i in free])
    twists = fwd.own_twists[free]
    rotation = angular_velocities(twists).reshape(-1, 3)
    velocity = twists[:, :3, 3] + np.cross(rotation, points[joint]) if len(free) else np.zeros((0, 3))
    velocity, rotation = sign[:, None] * velocity.reshape(-1, 3), sign[:, None] * rotation
    if also_free is not None:
        joint = np.concatenate([joint, also_free[0]])
        velocity, rotation = np.vstack([velocity, also_free[1]]), np.vstack([rotation, also_free[2]])
    return joint_wrenches(
        part_a,
        part_b,
        points,
        movable,
        loads,
        world_centres,
        joint,
        velocity,
        rotation,
        load_moments,
        point_contacts(model),
        slack,
    )


def normal_forces(model: Model, x: Array, wrenches: Wrenches, slides: list[Slide]) -> Array:
    """(S,) N: at each slide, the force across it (pressing the contact
    together): what its connection carries less the part along the slide's
    directions (a line, or a floor's plane)."""
    if not slides:
        return np.zeros(0)
    fwd = model.forward(x, with_twists=True)
    assert fwd.own_twists is not None
    normal = np.zeros(len(slides))
    for k, slide in enumerate(slides):
        # each DoF of a slide is a pure translation along its primitive
        directions = fwd.own_twists[list(slide.dofs), :3, 3]
        basis = np.linalg.qr(directions.T)[0]  # orthonormal, spanning the slide's directions
        force = wrenches.forces[slide.joint]
        normal[k] = float(np.linalg.norm(force - basis @ (basis.T @ force)))
    return normal


def _placed(model: Model) -> Array:
    placed = np.ones(len(model.parts), dtype=bool)
    placed[list(model.unplaced)] = False
    return placed
