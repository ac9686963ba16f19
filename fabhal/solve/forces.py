"""The forces in a configured model: what each connection carries, and the
normal and sliding force at each slide (for Coulomb friction and the report).

The model's side of `fabhal.kinematics.statics`: contact points, free motions
and weights from the model's forward kinematics.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from fabhal.kinematics.frames import Array, angular_velocities
from fabhal.kinematics.statics import Wrenches, joint_wrenches
from fabhal.model import Model

GRAVITY = 9.81  # m/s2
SLIDING_KINDS = ("rod", "tube", "edge")


def weight_newtons(masses: Array) -> Array:
    """Grams -> newtons."""
    return masses / 1000.0 * GRAVITY


def friction_slides(model: Model) -> list[int]:
    """The DoFs that slide a part along a rod, tube or edge and that friction
    resists: the first DoF (`t`) of such a side, unless pinned or held."""
    slides = []
    for joint in model.joints:
        if joint.held:
            continue
        for side in (joint.a, joint.b):
            if side.primitive.kind in SLIDING_KINDS and side.dof_indices:
                t = side.dof_indices[0]
                if model.variables[t].dof.name == "t" and t not in model.pinned:
                    slides.append(t)
    return slides


def connection_wrenches(
    model: Model,
    x: Array,
    masses: Array,
    centres: Array,
    carrying: Iterable[int],
    contact_loads: tuple[Array, Array] | None = None,
) -> Wrenches:
    """What every connection carries at x. `carrying`: the DoFs that can carry a
    load along their motion (held, pinned, resting on an end of their range,
    held by friction); every other DoF's motion is free.

    masses: (P,) grams; centres: (P, 3) mm in part frames; contact_loads: the
    environment's contact forces on each part (P, 3) N and their moments about
    the world origin (P, 3) N mm (fabhal/solve/contacts.py)."""
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
    return joint_wrenches(
        part_a,
        part_b,
        points,
        movable,
        loads,
        world_centres,
        joint,
        sign[:, None] * velocity.reshape(-1, 3),
        sign[:, None] * rotation,
        load_moments,
    )


def normal_forces(model: Model, x: Array, wrenches: Wrenches, slides: list[int]) -> Array:
    """(S,) N: at each slide, the force across it (pressing the contact
    together), from what its connection carries less the part along the slide."""
    if not slides:
        return np.zeros(0)
    fwd = model.forward(x, with_twists=True)
    assert fwd.own_twists is not None
    index = np.array(slides, dtype=int)
    joints = np.array([model.variables[i].joint for i in slides], dtype=int)
    sign = np.array([1.0 if model.variables[i].side == "a" else -1.0 for i in slides])
    direction = sign[:, None] * fwd.own_twists[index, :3, 3]  # a pure translation along the primitive
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    force = wrenches.forces[joints]
    along = np.einsum("ij,ij->i", force, direction)
    return np.linalg.norm(force - along[:, None] * direction, axis=1)


def _placed(model: Model) -> Array:
    placed = np.ones(len(model.parts), dtype=bool)
    placed[list(model.unplaced)] = False
    return placed
