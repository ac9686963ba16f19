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
from functools import cached_property

import numpy as np

from fabhal.elaborate import Connection, FlatProgram, PartInstance
from fabhal.kinematics.frames import Array, frame_matrix, invert
from fabhal.primitives import Dof, Primitive, alignment_offset

# closure residuals put rotation next to position (mm): the rotation error's
# matrix entries (R - I, about the angle in radians for small angles) count as
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
    held: bool  # DoFs stay put when the hack settles (`fixed`, a clip's grip, resting on a surface)


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
    pinned: frozenset[int]  # DoFs that never move: a small surface resting on a larger one sits at its centre

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
        return self.forward(x).frames

    def forward(self, x: Array, with_twists: bool = False) -> Forward:
        """Part frames and, if asked, each DoF's world twist (d frame / d x_i = twist_i @ frame)
        with the set of parts it moves."""
        frames = np.tile(np.eye(4), (len(self.parts), 1, 1))
        for i, part in enumerate(self.parts):
            if part.environment:
                frames[i] = frame_matrix(part.position, part.rotation)
        twists: dict[int, Array] = {}
        for edge in self.tree:
            joint = self.joints[edge.joint]
            parent, child = (joint.a, joint.b) if edge.parent_side == "a" else (joint.b, joint.a)
            offset = joint.offset if edge.parent_side == "a" else joint.offset.T
            parent_local = parent.primitive.connector_frames(x[list(parent.dof_indices)])
            child_local = child.primitive.connector_frames(x[list(child.dof_indices)])
            parent_to_world = frames[parent.part]
            frames[child.part] = parent_to_world @ parent_local @ offset @ invert(child_local)
            if with_twists:
                # moving a parent-side DoF turns the child about the parent connector...
                for i, d_local in _local_derivatives(parent, x):
                    twists[i] = parent_to_world @ d_local @ invert(parent_to_world @ parent_local)
                # ...a child-side DoF moves the child against its own connector
                child_to_world = frames[child.part]
                for i, d_local in _local_derivatives(child, x):
                    twists[i] = -child_to_world @ d_local @ invert(child_to_world @ child_local)
        return Forward(frames, twists)

    def closure_errors(self, x: Array, frames: Array | None = None) -> Array:
        """(n_closures, 4, 4): inv(world(a) @ offset) @ world(b), the identity when a loop closes."""
        if frames is None:
            frames = self.part_frames(x)
        out = np.zeros((len(self.closures), 4, 4))
        for k, j in enumerate(self.closures):
            joint = self.joints[j]
            a = self.connector_frame(joint.a, x, frames) @ joint.offset
            out[k] = invert(a) @ self.connector_frame(joint.b, x, frames)
        return out

    def closure_residuals(self, x: Array, frames: Array | None = None) -> Array:
        """(n_closures * 12,): per loop the position error (mm) and the rotation
        error E_R - I (x ROTATION_LENGTH_MM), in the first connector's frame.
        Zero exactly when every loop closes; linear in the error frame, so its
        Jacobian is exact."""
        errors = self.closure_errors(x, frames)
        return _residual_of(errors).ravel()

    def closure_jacobian(self, x: Array) -> Array:
        """(n_closures * 12, n_dofs) exact derivative of `closure_residuals`."""
        fwd = self.forward(x, with_twists=True)
        moved = self.moved
        jac = np.zeros((len(self.closures), 12, len(self.variables)))
        for k, j in enumerate(self.closures):
            joint = self.joints[j]
            world_a = self.connector_frame(joint.a, x, fwd.frames) @ joint.offset
            world_b = self.connector_frame(joint.b, x, fwd.frames)
            inv_a = invert(world_a)
            for i, twist in fwd.twists.items():
                a_moves, b_moves = joint.a.part in moved[i], joint.b.part in moved[i]
                if a_moves != b_moves:
                    change = twist if b_moves else -twist
                    jac[k, :, i] = _residual_change(inv_a @ change @ world_b)
            for side, sign in ((joint.a, -1.0), (joint.b, 1.0)):
                to_world = fwd.frames[side.part]
                local = side.primitive.connector_frames(x[list(side.dof_indices)])
                for i, d_local in _local_derivatives(side, x):
                    twist = to_world @ d_local @ invert(to_world @ local)
                    jac[k, :, i] += sign * _residual_change(inv_a @ twist @ world_b)
        return jac.reshape(len(self.closures) * 12, len(self.variables))

    def point_derivatives(self, fwd: Forward, part: int, point: Array) -> Array:
        """(n_dofs, 3): d(world position of `point`, given in `part`'s frame) / dx."""
        world = fwd.frames[part][:3, :3] @ point + fwd.frames[part][:3, 3]
        out = np.zeros((len(self.variables), 3))
        for i, twist in fwd.twists.items():
            if part in self.moved[i]:
                out[i] = twist[:3, :3] @ world + twist[:3, 3]
        return out

    def frame_derivatives(self, fwd: Forward, part: int) -> Array:
        """(n_dofs, 4, 4): d(part-to-world frame of `part`) / dx."""
        out = np.zeros((len(self.variables), 4, 4))
        for i, twist in fwd.twists.items():
            if part in self.moved[i]:
                out[i] = twist @ fwd.frames[part]
        return out

    @cached_property
    def moved(self) -> dict[int, set[int]]:
        """For each tree DoF, the parts that move with it (the child's subtree)."""
        return self._moved_parts()

    def _moved_parts(self) -> dict[int, set[int]]:
        """For each tree DoF, the parts that move with it (the child's subtree)."""
        children: dict[int, list[int]] = {}
        child_of_edge: dict[int, int] = {}
        for edge in self.tree:
            joint = self.joints[edge.joint]
            parent, child = (joint.a, joint.b) if edge.parent_side == "a" else (joint.b, joint.a)
            children.setdefault(parent.part, []).append(child.part)
            child_of_edge[edge.joint] = child.part
        moved: dict[int, set[int]] = {}
        for edge in self.tree:
            subtree, stack = set(), [child_of_edge[edge.joint]]
            while stack:
                part = stack.pop()
                subtree.add(part)
                stack.extend(children.get(part, []))
            joint = self.joints[edge.joint]
            for i in joint.a.dof_indices + joint.b.dof_indices:
                moved[i] = subtree
        return moved


@dataclass(frozen=True)
class Forward:
    frames: Array  # (n_parts, 4, 4)
    twists: dict[int, Array]  # tree DoF index -> (4, 4) world twist


_STEP = 1e-6  # central differences of one connector formula: error ~1e-12 relative


def _local_derivatives(side: Side, x: Array) -> list[tuple[int, Array]]:
    """(DoF index, d(B @ C)/dx) per DoF of a side: the derivative of the side's
    connector frame in its part, to ~1e-10 (central differences of the
    closed-form formula, which is smooth)."""
    values = x[list(side.dof_indices)]
    k = len(values)
    if k == 0:
        return []
    probes = np.repeat(values[None, :], 2 * k, axis=0)
    for d in range(k):
        probes[2 * d, d] += _STEP
        probes[2 * d + 1, d] -= _STEP
    frames = side.primitive.connector_frames(probes)  # (B @ C) at each probe
    return [(side.dof_indices[d], (frames[2 * d] - frames[2 * d + 1]) / (2 * _STEP)) for d in range(k)]


def _residual_change(d_error: Array) -> Array:
    """(4, 4) change of an error frame -> (12,) change of its residual."""
    return np.concatenate([d_error[:3, 3], d_error[:3, :3].ravel() * ROTATION_LENGTH_MM])


def _residual_of(errors: Array) -> Array:
    """(n, 4, 4) error frames -> (n, 12) residuals: position, then (R - I) x length scale."""
    n = errors.shape[0]
    out = np.empty((n, 12))
    out[:, :3] = errors[:, :3, 3]
    out[:, 3:] = (errors[:, :3, :3] - np.eye(3)).reshape(n, 9) * ROTATION_LENGTH_MM
    return out


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
        held = connection.fixed or _holds_by_itself(a.primitive.kind, b.primitive.kind)
        joints.append(Joint(j, a, b, offset, connection, held))
    tree, closures, unplaced = _spanning_tree(program, joints)
    pinned = frozenset(i for joint in joints for i in _resting_surface(joint))
    return Model(program, program.parts, tuple(joints), tree, closures, tuple(variables), unplaced, pinned)


def _holds_by_itself(first: str, second: str) -> bool:
    """A clip's grip, and anything standing on a surface, stay put when the hack
    settles: friction holds them (FabHaL models no friction elsewhere; without it
    a bottle would skate across its basket's floor and tip the basket)."""
    kinds = {first, second}
    return "clip" in kinds or kinds in ({"surface"}, {"surface", "hemisphere"})


def _resting_surface(joint: Joint) -> tuple[int, ...]:
    """Where a surface rests on a larger one, the smaller's DoFs: its centre sits on
    the larger's connector point (the larger's own DoFs place it), so they stay
    at their defaults; moving them too would only say the same thing twice."""
    a, b = joint.a.primitive, joint.b.primitive
    if a.kind != "surface" or b.kind != "surface":
        return ()
    area = [p.params["width"] * p.params["length"] for p in (a, b)]
    return joint.a.dof_indices if area[0] <= area[1] else joint.b.dof_indices


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
