"""Flat program -> kinematic model in reduced coordinates.

The unknowns are the connections' degrees of freedom (both sides of every
connection). A spanning tree of the connection graph, grown breadth-first
from the environments, gives every other part's world frame as a product
along its tree path:

    part2world(child) = part2world(parent) @ B_p @ C_p(x_p) @ A @ inv(B_c @ C_c(x_c))

(B: the primitive's frame in its part, C: its connector frame, A: the
alignment offset). The tree grows from the environments in program order.
Every connection off the tree closes a loop and becomes a closure
constraint: world(a connector) @ A == world(b connector).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fabhal.elaborate import Connection, FlatProgram, PartInstance
from fabhal.kinematics.frames import Array, frame_matrix, invert
from fabhal.primitives import Dof, Primitive, alignment_offset

# closure residuals put rotation (radians) next to position (mm): 1 rad counts as
# this many millimetres, so 1 degree of misalignment weighs like 1.75 mm
ROTATION_LENGTH_MM = 100.0


@dataclass(frozen=True)
class Side:
    """One end of a joint: a primitive of a part and where its DoFs sit in x."""

    part: int
    primitive: Primitive
    dof_indices: tuple[int, ...]


@dataclass(frozen=True)
class Joint:
    index: int
    a: Side
    b: Side
    offset: Array  # world(a connector) @ offset == world(b connector)
    connection: Connection
    held: bool  # DoFs stay put when the hack settles (`fixed`, or a clip's grip)


@dataclass(frozen=True)
class DofVariable:
    name: str  # e.g. "s1.hook2.theta"
    dof: Dof
    joint: int
    side: str  # "a" or "b"


@dataclass(frozen=True)
class TreeEdge:
    joint: int
    parent_side: str  # the side already placed


@dataclass(frozen=True)
class Model:
    program: FlatProgram
    parts: tuple[PartInstance, ...]
    joints: tuple[Joint, ...]
    tree: tuple[TreeEdge, ...]  # parents before children
    closures: tuple[int, ...]  # joints off the tree
    variables: tuple[DofVariable, ...]
    unplaced: tuple[int, ...]  # parts no environment reaches

    # ---- the DoF vector

    def x_default(self) -> Array:
        return np.array([v.dof.default for v in self.variables], dtype=float)

    def bounds(self) -> tuple[Array, Array]:
        """Lower and upper bounds; -inf/inf for periodic DoFs."""
        low = np.array([-np.inf if v.dof.periodic else v.dof.low for v in self.variables])
        high = np.array([np.inf if v.dof.periodic else v.dof.high for v in self.variables])
        return low, high

    def part_index(self, name: str) -> int:
        return next(i for i, p in enumerate(self.parts) if p.name == name)

    # ---- kinematics

    def connector_frame(self, side: Side, x: Array, part_frames: Array) -> Array:
        values = x[list(side.dof_indices)]
        return part_frames[side.part] @ side.primitive.connector_frames(values)

    def part_frames(self, x: Array) -> Array:
        """(n_parts, 4, 4) part-to-world frames for DoF vector x."""
        frames = np.tile(np.eye(4), (len(self.parts), 1, 1))
        for i, part in enumerate(self.parts):
            if part.environment:
                frames[i] = frame_matrix(part.position, part.rotation)
        for edge in self.tree:
            joint = self.joints[edge.joint]
            parent, child = (joint.a, joint.b) if edge.parent_side == "a" else (joint.b, joint.a)
            offset = joint.offset if edge.parent_side == "a" else joint.offset.T
            parent_connector = self.connector_frame(parent, x, frames)
            child_local = child.primitive.connector_frames(x[list(child.dof_indices)])
            frames[child.part] = parent_connector @ offset @ invert(child_local)
        return frames

    def closure_error(self, joint: Joint, x: Array, frames: Array) -> Array:
        """(4, 4) inv(world(a) @ offset) @ world(b): the identity when the loop closes."""
        a = self.connector_frame(joint.a, x, frames) @ joint.offset
        return invert(a) @ self.connector_frame(joint.b, x, frames)

    def closure_residuals(self, x: Array, frames: Array | None = None) -> Array:
        """(n_closures * 6,): per loop, position error (mm) then rotation error
        (rad x ROTATION_LENGTH_MM), both in the first connector's frame."""
        if frames is None:
            frames = self.part_frames(x)
        out = np.zeros(6 * len(self.closures))
        for k, j in enumerate(self.closures):
            error = self.closure_error(self.joints[j], x, frames)
            out[6 * k : 6 * k + 3] = error[:3, 3]
            out[6 * k + 3 : 6 * k + 6] = _rotation_vector(error[:3, :3]) * ROTATION_LENGTH_MM
        return out


def _rotation_vector(rotation: Array) -> Array:
    """Axis-angle vector (radians) of a rotation matrix; exact near 0 and near pi."""
    cos_angle = np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(cos_angle))
    skew = np.array(
        [rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]]
    )
    if angle < 1e-8:
        return skew / 2.0
    if np.pi - angle < 1e-6:  # near a half turn the skew part vanishes; use the symmetric part
        axis = np.sqrt(np.clip((np.diag(rotation) + 1.0) / 2.0, 0.0, None))
        signs = np.sign(skew) if np.any(skew) else np.ones(3)
        axis = axis * np.where(signs == 0, 1.0, signs)
        return axis / np.linalg.norm(axis) * angle
    return skew * angle / (2.0 * np.sin(angle))


def build_model(program: FlatProgram) -> Model:
    """Lay out the DoF vector and grow the spanning tree from the environments."""
    index = {p.name: i for i, p in enumerate(program.parts)}
    variables: list[DofVariable] = []
    joints: list[Joint] = []
    for j, connection in enumerate(program.connections):
        sides = []
        for label, end in (("a", connection.a), ("b", connection.b)):
            part = index[end.part]
            primitive = program.parts[part].spec.primitive(end.primitive)
            assert primitive is not None, end  # elaboration resolved every endpoint
            start = len(variables)
            for dof in primitive.dofs:
                variables.append(DofVariable(f"{end.part}.{end.primitive}.{dof.name}", dof, j, label))
            sides.append(Side(part, primitive, tuple(range(start, len(variables)))))
        a, b = sides
        offset = alignment_offset(a.primitive, b.primitive, connection.flip)
        held = connection.fixed or "clip" in (a.primitive.kind, b.primitive.kind)
        joints.append(Joint(j, a, b, offset, connection, held))
    tree, closures, unplaced = _spanning_tree(program, joints)
    return Model(program, program.parts, tuple(joints), tree, closures, tuple(variables), unplaced)


def _spanning_tree(
    program: FlatProgram, joints: list[Joint]
) -> tuple[tuple[TreeEdge, ...], tuple[int, ...], tuple[int, ...]]:
    """Grow the tree in program order: a connection that reaches a new part is a
    tree edge, one between two placed parts closes a loop; a connection between
    two unplaced parts waits for a later pass. So the order a user writes is the
    order parts are hung, as in the paper's `connect`."""
    placed = {i for i, p in enumerate(program.parts) if p.environment}
    tree: list[TreeEdge] = []
    decided: set[int] = set()
    closures: list[int] = []
    progress = True
    while progress:
        progress = False
        for joint in joints:
            if joint.index in decided:
                continue
            a_in, b_in = joint.a.part in placed, joint.b.part in placed
            if a_in and b_in:
                closures.append(joint.index)
            elif a_in or b_in:
                tree.append(TreeEdge(joint.index, "a" if a_in else "b"))
                placed.add(joint.b.part if a_in else joint.a.part)
            else:
                continue
            decided.add(joint.index)
            progress = True
    unplaced = tuple(i for i in range(len(program.parts)) if i not in placed)
    return tuple(tree), tuple(closures), unplaced
