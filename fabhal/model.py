"""Flat program -> kinematic model in reduced coordinates.

The unknowns are the connections' degrees of freedom (both sides of every
connection). A spanning tree of the connection graph, grown breadth-first
from the environments, gives every other part's world frame as a product
along its tree path:

    part2world(child) = part2world(parent) @ B_p @ C_p(x_p) @ A @ inv(B_c @ C_c(x_c))

(B: the primitive's frame in its part, C: its connector frame, A: the
alignment offset). The tree grows from the environments in a canonical order of the
connections (what they join, not where they are written).
Every connection off the tree closes a loop and becomes a closure
constraint: world(a connector) @ A == world(b connector).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from fabhal.elaborate import Connection, Endpoint, FlatProgram, PartInstance
from fabhal.kinematics.frames import Array, angular_velocities, frame_matrix, invert
from fabhal.primitives import (
    FRAME_FORMULAS,
    LOOPS,
    SPINNING,
    TILTING,
    Dof,
    FrameFormula,
    Primitive,
    alignment_offset,
    grips,
    is_flex_angle,
    is_ring_twist,
    jam_of,
    make_primitive,
    turning_to_the_jam,
    yaw_jam_between,
)

Index = NDArray[np.intp]

# closure residuals put rotation next to position (mm): the rotation error's
# matrix entries (R - I, about the angle in radians for small angles) count as
# this many millimetres, so 1 degree of misalignment weighs like 1.75 mm
ROTATION_LENGTH_MM = 100.0
# trees deeper than this compose their frames by pointer jumping (`_tree_jumps`)
POINTER_JUMPING_DEPTH = 16


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

    def endpoint(self, side: Side) -> Endpoint:
        """The program's `part.primitive` for one side of this joint."""
        return self.connection.a if side is self.a else self.connection.b

    @property
    def stands(self) -> bool:
        """One part stands on the other's surface (by a surface or round feet),
        not `fixed` to it (glued, taped or pinned)."""
        return "surface" in (self.a.primitive.kind, self.b.primitive.kind) and not self.connection.fixed


@dataclass(frozen=True)
class Standing:
    """An object standing on a surface (a connection of two surfaces: an
    environment's, else the larger, is the floor). Step 1 stands it in the
    floor's middle (`pinned`; the target on the world's floor where it is asked
    for, `_stood_where_asked`); when the hack settles it may slide on the floor,
    which friction resists, and it topples when its weight acts beyond where
    they touch (fabhal/solve/__init__.py)."""

    joint: int
    floor: str  # the side ("a" or "b") of the floor (`_floor_and_object`)
    slide: tuple[int, int]  # the floor's t1, t2: where on it the object stands
    base: tuple[float, float]  # where they touch (width, length), mm: the object's base, or a narrower floor


@dataclass(frozen=True)
class TurnLimit:
    """The flex angles of both sides of one connection (two loops, each turned
    about the line of their contact) turn the parts about that one line: only
    their sum u = (x[first] - 90) + sign (x[second] - 90) moves anything, and
    the two together turn until a wire jams (|u| <= `jam`, degrees), not each
    alone (two S-hooks once turned 23 and 22 degrees where they jam at 44 in
    all). Without loops the pair is `folded`: `first` carries the whole turn
    over the range the jam leaves it, a bound, and `second` stays put (square,
    or where the program sets it): one unknown and no row less per pair (a
    chain of 100 S-hooks: 10 s with rows, 1.8 s folded). With loops both turn
    and two linear rows keep the sum (fabhal/solve/spacing.py): folded, the
    settles that balance on knife edges (the caddy, the reading nook) took
    other paths and one of them ended not at rest (bench/README.md item 52)."""

    first: int  # DoF index of one side's flex angle (folded: the one that turns)
    second: int  # the other side's (folded: it stays put)
    sign: float  # +1 where both turn the parts the same way relative to each other
    jam: float
    folded: bool = False


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


ENVIRONMENT = -1  # in a loop's parts: every environment part, one rigid link


@dataclass(frozen=True)
class Loop:
    """A loop of the connection graph: the one a closing connection makes."""

    closing_joint: int
    parts: tuple[int, ...]  # in order around the loop, ENVIRONMENT for the ground
    joints: tuple[int, ...]  # joints around the loop, the closing one last


@dataclass(frozen=True)
class Model:
    program: FlatProgram
    parts: tuple[PartInstance, ...]
    joints: tuple[Joint, ...]
    tree: tuple[TreeEdge, ...]  # parents before children
    closures: tuple[int, ...]  # joints off the tree
    variables: tuple[DofVariable, ...]
    unplaced: tuple[int, ...]  # parts no environment reaches
    pinned: frozenset[int]  # DoFs step 1 never moves: an object on a surface stands at its centre
    standing: tuple[Standing, ...]  # objects standing on a surface (their slide is free in step 2)
    # the closure residuals each loop's closing connection takes up as play (see
    # `with_play`); empty when every loop closes exactly
    closure_play: tuple[float, ...] = ()
    written: frozenset[int] = frozenset()  # DoFs the program sets (`set (...)`): in `pinned`, never moved
    turn_limits: tuple[TurnLimit, ...] = ()  # flex angles on both sides of a connection, jammed together
    # plain hooks and rings round rods, hooks and rings turn about the line of their contact
    # (`_turning_on_its_contact`)
    turning_on_contact: bool = False

    # ---- the DoF vector

    def x_default(self) -> Array:
        return np.array([v.dof.default for v in self.variables], dtype=float)

    def bounds(self) -> tuple[Array, Array]:
        """Lower and upper bounds; -inf/inf for periodic DoFs."""
        low = np.array([-np.inf if v.dof.periodic else v.dof.low for v in self.variables])
        high = np.array([np.inf if v.dof.periodic else v.dof.high for v in self.variables])
        return low, high

    def standing_sides(self, standing: Standing) -> tuple[Side, Side]:
        """A standing object's connection as (the floor's side, the object's)."""
        joint = self.joints[standing.joint]
        return (joint.a, joint.b) if standing.floor == "a" else (joint.b, joint.a)

    def part_index(self, name: str) -> int:
        return next(i for i, p in enumerate(self.parts) if p.name == name)

    def floor_slides(self) -> frozenset[int]:
        """The DoFs of objects standing on a floor that gravity may slide: pinned
        (centred) in step 1, free in step 2, unless the program set where."""
        return frozenset(i for standing in self.standing for i in standing.slide) - self.written

    def as_written(self) -> list[int]:
        """The parts' indices in the order the program declares them (the
        model's own order is the tree's: `build_model`), for what people read."""
        return [self.part_index(part.name) for part in self.program.parts]

    # ---- kinematics (vectorised over all connections; see `layout`)

    def side_of(self, i: int) -> Side:
        """The side of its connection whose primitive DoF i belongs to."""
        variable = self.variables[i]
        joint = self.joints[variable.joint]
        return joint.a if variable.side == "a" else joint.b

    def connector_frame(self, side: Side, x: Array, part_frames: Array) -> Array:
        """(4, 4) world frame of one side's connector."""
        values = x[list(side.dof_indices)]
        return part_frames[side.part] @ side.primitive.connector_frames(values)

    def part_frames(self, x: Array) -> Array:
        """(n_parts, 4, 4) part-to-world frames for DoF vector x."""
        return self.forward(x).frames

    def forward(self, x: Array, with_twists: bool = False) -> Forward:
        """Part frames and, if asked, each DoF's world twist: d(frame)/dx_i =
        twists[i] @ frame for the parts DoF i moves (`moves[i]`).

        The last result is kept: optimisers ask for the value, the gradient and
        the constraints at one point in separate calls."""
        key = x.tobytes()
        last = self._last_forward.get(key)
        if last is not None and (last.twists is not None or not with_twists):
            return last
        result = self._forward(x, with_twists)
        for array in (
            result.frames,
            result.local,
            result.twists,
            result.own_twists,
            result.closure_a_inverse,
            result.closure_b,
        ):
            if array is not None:
                array.setflags(write=False)  # shared with later callers at the same x
        self._last_forward.clear()
        self._last_forward[key] = result
        return result

    @cached_property
    def _last_forward(self) -> dict[bytes, Forward]:
        return {}

    def _forward(self, x: Array, with_twists: bool) -> Forward:
        layout = self.layout
        if with_twists:
            local, d_local = layout.local_frames_and_derivatives(x)
        else:
            local, d_local = layout.local_frames(x), None
        frames = layout.environment_frames.copy()
        edges = layout.edges
        # child in parent for every edge in one product; then one product per round,
        # a level of the tree or a round of pointer jumping (`_tree_jumps`)
        frames[edges.child] = local[edges.parent_side] @ edges.offset @ invert(local[edges.child_side])
        for jump in layout.jumps:  # numpy gathers the ancestors before writing: all at once
            pending, ancestor = jump.indices
            frames[pending] = frames[ancestor] @ frames[pending]
        if d_local is None:
            return Forward(frames, local, None, None)
        # the twist of a DoF turns its side's part about that side's connector:
        # W dL inv(W L); a parent-side DoF moves the child with it, a child-side
        # DoF moves the child against its own connector (the minus sign)
        on_part = frames[layout.dof_part]
        own = on_part @ d_local @ invert(on_part @ local[layout.dof_side])
        world_a, world_b = layout.closure_worlds(local, frames)
        return Forward(frames, local, layout.tree_sign[:, None, None] * own, own, invert(world_a), world_b)

    def closure_errors(self, x: Array) -> Array:
        """(n_closures, 4, 4): inv(world(a) @ offset) @ world(b), the identity when a loop closes."""
        # with the twists: solvers ask for the Jacobian at the same point next, and reuse them
        fwd = self.forward(x, with_twists=True)
        assert fwd.closure_a_inverse is not None and fwd.closure_b is not None
        return fwd.closure_a_inverse @ fwd.closure_b

    def closure_residuals(self, x: Array) -> Array:
        """(n_closures * 12,): per loop the position error (mm) and the rotation
        error E_R - I (x ROTATION_LENGTH_MM), in the first connector's frame.
        Zero exactly when every loop closes; linear in the error frame, so its
        Jacobian is exact. Less the play a loop closes with (`with_play`)."""
        residuals = _residual_of(self.closure_errors(x)).ravel()
        return residuals - np.array(self.closure_play) if self.closure_play else residuals

    def with_play(self, x: Array) -> Model:
        """This model with the loops' residuals at x taken up by their closing
        connections: a loop of rigid parts that closes only to a fraction of a
        millimetre (coordinates written to three decimals) closes in the real
        objects by the play of a hook on its rod or a clip's jaws. Its closure
        constraint becomes `residuals(x') == residuals(x)`: x closes it, and
        every motion that kept the loop closed keeps it so."""
        residuals = _residual_of(self.closure_errors(x)).ravel()
        return replace(self, closure_play=tuple(float(r) for r in residuals))

    def closure_jacobian(self, x: Array) -> Array:
        """(n_closures * 12, n_dofs) exact derivative of `closure_residuals`."""
        layout = self.layout
        fwd = self.forward(x, with_twists=True)
        assert fwd.own_twists is not None and fwd.closure_a_inverse is not None and fwd.closure_b is not None
        # d error = c * inv(world a) @ twist @ world b, c = how the DoF moves b relative to a
        # as broadcast matrix products: a four-operand einsum loops naively (18x slower on the nook)
        d_errors = layout.closure_coefficients[:, :, None, None] * (
            fwd.closure_a_inverse[:, None] @ fwd.own_twists[None] @ fwd.closure_b[:, None]
        )
        n_closures, n_dofs = d_errors.shape[:2]
        rows = np.concatenate(
            [d_errors[..., :3, 3], d_errors[..., :3, :3].reshape(n_closures, n_dofs, 9) * ROTATION_LENGTH_MM],
            axis=2,
        )  # (k, i, 12)
        return rows.transpose(0, 2, 1).reshape(n_closures * 12, n_dofs)

    def weighted_height_gradient(self, fwd: Forward, weights: Array, points: Array) -> Array:
        """(n_dofs,): d(sum_p weights[p] * world z of points[p], given in part p's frame) / dx,
        for all parts at once (the potential energy's gradient)."""
        assert fwd.twists is not None
        world = np.einsum("pij,pj->pi", fwd.frames[:, :3, :3], points) + fwd.frames[:, :3, 3]
        weighted = self.layout.moves * weights  # (n_dofs, n_parts)
        along = np.einsum("ij,ij->i", fwd.twists[:, 2, :3], weighted @ world)
        return along + fwd.twists[:, 2, 3] * weighted.sum(axis=1)

    def wrench_gradient(self, fwd: Forward, forces: Array, moments: Array) -> Array:
        """(n_dofs,): the generalised force of a force forces[p] (world) and a moment
        moments[p] (about the world origin) on each part p: each DoF's twist
        (angular velocity w, velocity v of the point at the origin) dotted with
        them, w . M + v . F, over the parts it moves."""
        assert fwd.twists is not None
        moves = self.layout.moves.astype(float)
        return np.einsum("ij,ij->i", angular_velocities(fwd.twists), moves @ moments) + np.einsum(
            "ij,ij->i", fwd.twists[:, :3, 3], moves @ forces
        )

    def load_hessian(self, x: Array, fwd: Forward, loads: Array) -> Array:
        """(n_dofs, n_dofs): the exact second derivative by x of the work
        potential of forces held constant in the world, sum f . X over forces f
        at points X that move with their parts. loads: (n_parts, 3, 4), per part
        the sum of f (x) (X, 1) over its forces (gravity: the weight times e_z
        (x) the centre of mass). The gradient is <T_i[:3], M_i> with M_i the loads
        DoF i moves and T_i its twist (`weighted_height_gradient`, `wrench_gradient`).

        For a DoF j that moves i's part (j above i), the twist T_i turns with the
        part, dT_i/dx_j = T_j T_i - T_i T_j, and the points of M_i move by T_j:
        H_ij = <(T_j T_i)[:3], M_i> = <T_j[:3], M_i T_i^T>, one (n, 12) x (12, n)
        product. DoFs of one connection side move one part through one connector
        frame L (W: that part's frame): on a parent side H_ik = <W L_ik inv(W L),
        M_i> (L_ik: the second derivative of L); a child side hangs its part from
        inv(L), whose second derivative gives <U_k U_i + U_i U_k - W L_ik inv(W L),
        M_i> (U: the side's own twists, `Forward.own_twists`). DoFs off the tree
        and DoFs on separate branches: 0."""
        assert fwd.twists is not None and fwd.own_twists is not None
        layout = self.layout
        n = layout.n_dofs
        twists = fwd.twists
        carried = (layout.moves.astype(float) @ loads.reshape(len(loads), 12)).reshape(n, 3, 4)
        turned = (carried @ twists.transpose(0, 2, 1)).reshape(n, 12)  # M_i T_i^T
        mixed = twists[:, :3, :].reshape(n, 12) @ turned.T  # [j, i] = <T_j[:3], M_i T_i^T>
        above = layout.moves[:, layout.dof_part] & (layout.dof_side[:, None] != layout.dof_side[None, :])
        hessian = np.where(above, mixed, 0.0)
        hessian = hessian + hessian.T
        first, second, bent = self._connector_curvature(x, fwd)
        sign = layout.tree_sign[first]
        change = sign[:, None, None] * bent
        own_i, own_k = fwd.own_twists[first], fwd.own_twists[second]
        change += (sign < 0)[:, None, None] * (own_k @ own_i + own_i @ own_k)
        same_side = np.einsum("pab,pab->p", change[:, :3, :], carried[first])
        hessian[first, second] += same_side
        off_diagonal = first != second
        hessian[second[off_diagonal], first[off_diagonal]] += same_side[off_diagonal]
        return hessian

    def closure_hessian(self, x: Array, fwd: Forward, weights: Array) -> Array:
        """(n_dofs, n_dofs): the exact second derivative by x of sum_k <weights[k],
        E_k[:3, :]>, E_k the loop's error frame (`closure_errors`) and weights
        (n_closures, 3, 4): any linear function of the closure residuals, such as
        the loops' multipliers times their constraints.

        With E = inv(A) B (A, B: the world frames of the loop's a connector with
        its offset and of its b connector), <W, E> = trace(G), G = B W^T inv(A)
        (W padded to 4 x 4). DoF i turns B by its twist Tb_i and A by Ta_i, so the
        first derivative is trace(D_i G), D_i = Tb_i - Ta_i = c_i U_i (U: the DoF's
        own twist, c: `closure_coefficients`), and the second
        H_ij = c_i trace(dU_i/dx_j G) + trace(D_i (Tb_j G - G Ta_j)), where
        dU_i/dx_j = [T_j, U_i] when j moves i's part, and on one connection side
        the connector's second derivative as well (as in `load_hessian`)."""
        assert fwd.twists is not None and fwd.own_twists is not None
        assert fwd.closure_a_inverse is not None and fwd.closure_b is not None
        layout = self.layout
        n = layout.n_dofs
        twists, own = fwd.twists, fwd.own_twists
        a_side, a_part, b_side, b_part = layout.closure_sides
        # dU_i/dx_k on one side, less the turning of its part (counted with `above`):
        # W L_ik inv(W L) - U_i U_k
        first, second, bent = self._connector_curvature(x, fwd)
        same_ik = bent - own[first] @ own[second]
        same_ki = bent - own[second] @ own[first]
        above = layout.moves[:, layout.dof_part]  # [j, i]: j moves the part of i's side
        hessian = np.zeros((n, n))
        for k in range(len(a_side)):
            padded = np.zeros((4, 4))
            padded[:3] = weights[k]
            g = fwd.closure_b[k] @ padded.T @ fwd.closure_a_inverse[k]
            coefficient = layout.closure_coefficients[k]
            turn_a = _turns(layout, fwd, a_side[k], a_part[k])
            turn_b = _turns(layout, fwd, b_side[k], b_part[k])
            change = coefficient[:, None, None] * own  # D_i
            moved = turn_b @ g - g @ turn_a  # (n, 4, 4): X_j = Tb_j G - G Ta_j
            loop = change.reshape(n, 16) @ moved.transpose(0, 2, 1).reshape(n, 16).T  # trace(D_i X_j)
            commutator = own @ g - g @ own  # U_i G - G U_i: trace([T_j, U_i] G) = trace(T_j (U_i G - G U_i))
            turning = twists.reshape(n, 16) @ commutator.transpose(0, 2, 1).reshape(n, 16).T  # [j, i]
            loop += (coefficient[None, :] * np.where(above, turning, 0.0)).T
            loop[first, second] += coefficient[first] * np.einsum("pab,ba->p", same_ik, g)
            off_diagonal = first != second
            other = coefficient[second] * np.einsum("pab,ba->p", same_ki, g)
            loop[second[off_diagonal], first[off_diagonal]] += other[off_diagonal]
            hessian += loop
        return hessian

    def _connector_curvature(self, x: Array, fwd: Forward) -> tuple[Index, Index, Array]:
        """For each pair of DoFs (i, k), i <= k, of one connection side: i, k and
        W L_ik inv(W L), the second derivative of its connector frame L carried
        into the world by its part's frame W (`load_hessian`, `closure_hessian`)."""
        layout = self.layout
        first, second, curvature = layout.local_second_derivatives(x)
        on_part = fwd.frames[layout.dof_part[first]]
        return first, second, on_part @ curvature @ invert(on_part @ fwd.local[layout.dof_side[first]])

    def connection_points(self, fwd: Forward) -> Array:
        """(n_joints, 3) mm, world: where each connection touches (its b side's connector)."""
        part_b = np.array([j.b.part for j in self.joints], dtype=int)
        return (fwd.frames[part_b] @ fwd.local[2 * np.arange(len(self.joints)) + 1])[:, :3, 3]

    def frame_derivatives(self, fwd: Forward, part: int) -> Array:
        """(n_dofs, 4, 4): d(part-to-world frame of `part`) / dx."""
        assert fwd.twists is not None
        return self.layout.moves[:, part, None, None] * (fwd.twists @ fwd.frames[part])

    @cached_property
    def layout(self) -> ChainLayout:
        return _chain_layout(self)

    def placed_sides(self, edge: TreeEdge) -> tuple[Side, Side]:
        """(parent, child) of a tree edge: the side already placed, then the one it places."""
        joint = self.joints[edge.joint]
        return (joint.a, joint.b) if edge.parent_side == "a" else (joint.b, joint.a)

    def loop_node(self, part: int) -> int:
        """A part as a place on a loop: ENVIRONMENT for any environment part."""
        return ENVIRONMENT if self.parts[part].environment else part

    @cached_property
    def loops(self) -> tuple[Loop, ...]:
        """One loop per closing joint: its tree paths up to where they meet."""
        parent: dict[int, tuple[int, int]] = {}  # child part -> (parent part, joint)
        for edge in self.tree:
            up, down = self.placed_sides(edge)
            parent[down.part] = (self.loop_node(up.part), edge.joint)

        def path(part: int) -> list[tuple[int, int]]:
            """(node, joint to its parent) from part up to the environment."""
            out = []
            node = self.loop_node(part)
            while node != ENVIRONMENT:
                up, joint = parent[node]
                out.append((node, joint))
                node = up
            return out

        loops = []
        for j in self.closures:
            joint = self.joints[j]
            up_a, up_b = path(joint.a.part), path(joint.b.part)
            nodes_b = [n for n, _ in up_b]
            # climb from a until we meet b's path (or the environment)
            climb_a: list[tuple[int, int]] = []
            meet = ENVIRONMENT
            for node, via in up_a:
                if node in nodes_b:
                    meet = node
                    break
                climb_a.append((node, via))
            climb_b: list[tuple[int, int]] = []
            for node, via in up_b:
                if node == meet:
                    break
                climb_b.append((node, via))
            parts = [n for n, _ in climb_a] + [meet] + [n for n, _ in reversed(climb_b)]
            joints = [e for _, e in climb_a] + [e for _, e in reversed(climb_b)] + [j]
            loops.append(Loop(j, tuple(parts), tuple(joints)))
        return tuple(loops)

    def lines_setting(self, joints: Iterable[int]) -> tuple[int, ...]:
        """The lines of these joints' connections that write settings (`set (...)`)."""
        connections = [self.joints[j].connection for j in joints]
        return tuple(sorted({connection.span.line for connection in connections if connection.settings}))

    def on_loops(self) -> frozenset[Connection]:
        """The connections that lie on a loop (`loops`)."""
        return frozenset(self.joints[j].connection for loop in self.loops for j in loop.joints)

    @cached_property
    def tree_child(self) -> dict[int, int]:
        """For each tree joint, the part it hangs in place (its child side's part)."""
        return {edge.joint: self.placed_sides(edge)[1].part for edge in self.tree}

    @cached_property
    def subtrees(self) -> dict[int, set[int]]:
        """For each part, itself and every part hung below it in the tree."""
        return _subtrees(self)


@dataclass(frozen=True)
class Forward:
    frames: Array  # (n_parts, 4, 4)
    local: Array  # (n_sides, 4, 4) every connector in its part
    twists: Array | None  # (n_dofs, 4, 4) world twist of each tree DoF (zero for the others)
    own_twists: Array | None  # (n_dofs, 4, 4) each DoF's twist of its own side's connector
    # per loop (with the twists): inv(world of connector a with the offset), world of b
    closure_a_inverse: Array | None = None
    closure_b: Array | None = None


@dataclass(frozen=True, eq=False)
class SideGroup:
    """The connection sides of one primitive variant, evaluated together."""

    sides: Array  # (n,) side indices: 2 * joint + (0 for a, 1 for b)
    formula: FrameFormula
    params: dict[str, Array]  # (n,) each
    base: Array  # (n, 4, 4) primitive-in-part frames
    dofs: Array  # (n, k) indices into x

    @cached_property
    def probe_steps(self) -> Array:
        """(2k + 1, k): the point itself, then +-_STEP on each DoF in turn."""
        k = self.dofs.shape[1]
        steps = np.zeros((2 * k + 1, k))
        steps[1::2][np.arange(k), np.arange(k)] = _STEP
        steps[2::2][np.arange(k), np.arange(k)] = -_STEP
        return steps

    @cached_property
    def curvature_probes(self) -> tuple[Array, Array, Array]:
        """Central second differences of the formula: (R, k) probe steps (the
        point first), (P, R) weights that turn the R values into the P second
        derivatives d2/dx_a dx_b, a <= b, and (P, 2) the pairs (a, b)."""
        k = self.dofs.shape[1]
        pairs = [(a, b) for a in range(k) for b in range(a, k)]
        steps: list[Array] = [np.zeros(k)]
        weights = []
        for a, b in pairs:
            first = len(steps)
            if a == b:  # (f(+h) - 2 f + f(-h)) / h^2
                steps += [_CURVATURE_STEP * np.eye(k)[a], -_CURVATURE_STEP * np.eye(k)[a]]
                combination = {0: -2.0, first: 1.0, first + 1: 1.0}
                scale = _CURVATURE_STEP**2
            else:  # (f(+a+b) - f(+a-b) - f(-a+b) + f(-a-b)) / 4h^2
                for sa, sb in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                    steps.append(_CURVATURE_STEP * (sa * np.eye(k)[a] + sb * np.eye(k)[b]))
                combination = {first: 1.0, first + 1: -1.0, first + 2: -1.0, first + 3: 1.0}
                scale = 4 * _CURVATURE_STEP**2
            row = np.zeros(1 + 2 * k + 4 * (len(pairs) - k))
            for r, w in combination.items():
                row[r] = w / scale
            weights.append(row)
        return np.array(steps), np.array(weights).reshape(len(pairs), len(steps)), np.array(pairs, dtype=int)

    @cached_property
    def probe_params(self) -> dict[str, Array]:
        return {name: values[:, None] for name, values in self.params.items()}

    @cached_property
    def probe_base(self) -> Array:
        return self.base[:, None]


@dataclass(frozen=True)
class Jump:
    """One round of pointer jumping over the tree (`_forward`): each pending part's
    frame, relative to its current ancestor, is composed with that ancestor's."""

    pending: Index  # (m,) part indices whose frame is not yet in the world
    ancestor: Index  # (m,) the part each one's frame is relative to

    @cached_property
    def indices(self) -> tuple[Index | int, Index | int]:
        """(pending, ancestor), as plain indices where the round has one part (a
        chain's levels): a 4 x 4 product then, 2 us against 6 for one gathered (the
        same arithmetic, to the bit)."""
        if len(self.pending) == 1:
            return int(self.pending[0]), int(self.ancestor[0])
        return self.pending, self.ancestor


@dataclass(frozen=True)
class TreeEdges:
    """Every tree edge: what places each child relative to its parent."""

    parent_side: Array  # (e,) side indices
    child_side: Array
    child: Array  # (e,) the part each edge places
    offset: Array  # (e, 4, 4) alignment, oriented parent -> child


@dataclass(frozen=True)
class ChainLayout:
    """Index arrays that turn the model's kinematics into batched numpy products."""

    groups: tuple[SideGroup, ...]
    n_sides: int
    n_dofs: int
    environment_frames: Array  # (n_parts, 4, 4); identity for parts the tree places
    jumps: tuple[Jump, ...]
    edges: TreeEdges
    dof_side: Array  # (n_dofs,) side of each DoF
    dof_part: Array  # (n_dofs,) part of that side
    tree_sign: Array  # (n_dofs,) +1 parent side, -1 child side, 0 off the tree
    moves: Array  # (n_dofs, n_parts) bool: the parts a tree DoF moves (the child's subtree)
    closure_sides: tuple[Array, Array, Array, Array]  # a side, a part, b side, b part: (k,) each
    closure_offsets: Array  # (k, 4, 4)
    closure_coefficients: Array  # (k, n_dofs): +1 moves b against a, -1 a against b

    def local_frames(self, x: Array) -> Array:
        """(n_sides, 4, 4): every side's connector frame in its part."""
        out = np.empty((self.n_sides, 4, 4))
        for group in self.groups:
            out[group.sides] = group.base @ group.formula(group.params, x[group.dofs])
        return out

    def local_frames_and_derivatives(self, x: Array) -> tuple[Array, Array]:
        """`local_frames` and (n_dofs, 4, 4): d(connector frame in its part)/dx_i
        for each DoF's own side, to ~1e-10 (central differences of the smooth
        closed-form formulas), from one formula call per variant."""
        frames = np.empty((self.n_sides, 4, 4))
        derivatives = np.zeros((self.n_dofs, 4, 4))
        for group in self.groups:
            n, k = group.dofs.shape
            probes = x[group.dofs][:, None, :] + group.probe_steps  # (n, 2k + 1, k)
            values = group.probe_base @ group.formula(group.probe_params, probes)  # (n, 2k + 1, 4, 4)
            frames[group.sides] = values[:, 0]
            if k:
                derivative = (values[:, 1::2] - values[:, 2::2]) / (2 * _STEP)  # (n, k, 4, 4)
                derivatives[group.dofs.ravel()] = derivative.reshape(n * k, 4, 4)
        return frames, derivatives

    def local_second_derivatives(self, x: Array) -> tuple[Index, Index, Array]:
        """For each pair of DoFs (i, k), i <= k, of one connection side: i, k and
        (P, 4, 4) d2(connector frame in its part)/dx_i dx_k, by central second
        differences of the closed-form formulas (`SideGroup.curvature_probes`;
        error ~1e-8 relative)."""
        firsts, seconds, values = [], [], []
        for group in self.groups:
            if not group.dofs.shape[1]:
                continue
            steps, weights, pairs = group.curvature_probes
            probes = x[group.dofs][:, None, :] + steps  # (n, R, k)
            frames = group.probe_base @ group.formula(group.probe_params, probes)  # (n, R, 4, 4)
            values.append(np.einsum("pr,nrij->npij", weights, frames).reshape(-1, 4, 4))
            firsts.append(group.dofs[:, pairs[:, 0]].ravel())
            seconds.append(group.dofs[:, pairs[:, 1]].ravel())
        if not values:
            return np.zeros(0, dtype=int), np.zeros(0, dtype=int), np.zeros((0, 4, 4))
        return np.concatenate(firsts), np.concatenate(seconds), np.concatenate(values)

    def closure_worlds(self, local: Array, frames: Array) -> tuple[Array, Array]:
        """(k, 4, 4) world frames of each loop's a connector (with the offset) and b connector,
        from every side's connector in its part (`local_frames`) and the part frames."""
        a_side, a_part, b_side, b_part = self.closure_sides
        return frames[a_part] @ local[a_side] @ self.closure_offsets, frames[b_part] @ local[b_side]


_STEP = 1e-6  # central differences of one connector formula: error ~1e-12 relative
# its second differences: rounding ~1e-16 x 1000 mm / h^2 = 1e-7 mm, truncation ~h^2 / 12 relative
_CURVATURE_STEP = 1e-3


def _chain_layout(model: Model) -> ChainLayout:
    sides = [side for joint in model.joints for side in (joint.a, joint.b)]
    n_dofs, n_parts = len(model.variables), len(model.parts)
    # variants that share a formula (a hook and a ring are both arcs) and a DoF count
    # are evaluated together: every group is a handful of numpy calls
    by_formula: dict[tuple[FrameFormula, int], list[int]] = {}
    for s, side in enumerate(sides):
        key = (FRAME_FORMULAS[side.primitive.variant], len(side.dof_indices))
        by_formula.setdefault(key, []).append(s)
    groups = []
    for (formula, _), members in by_formula.items():
        primitives = [sides[s].primitive for s in members]
        names = set.intersection(*(set(p.params) for p in primitives))
        groups.append(
            SideGroup(
                np.array(members),
                formula,
                {name: np.array([p.params[name] for p in primitives]) for name in sorted(names)},
                np.stack([p.base_frame() for p in primitives]),
                np.array([sides[s].dof_indices for s in members], dtype=int).reshape(len(members), -1),
            )
        )
    environment_frames = np.tile(np.eye(4), (n_parts, 1, 1))
    for i, part in enumerate(model.parts):
        if part.environment:
            environment_frames[i] = frame_matrix(part.position, part.rotation)
    dof_side = np.zeros(n_dofs, dtype=int)
    for s, side in enumerate(sides):
        dof_side[list(side.dof_indices)] = s
    tree_sign = np.zeros(n_dofs)
    moves = np.zeros((n_dofs, n_parts), dtype=bool)
    subtrees = model.subtrees
    for edge in model.tree:
        joint = model.joints[edge.joint]
        parent, child = model.placed_sides(edge)
        tree_sign[list(parent.dof_indices)] = 1.0
        tree_sign[list(child.dof_indices)] = -1.0
        for i in joint.a.dof_indices + joint.b.dof_indices:
            moves[i, list(subtrees[child.part])] = True
    closures = [model.joints[j] for j in model.closures]
    a_side = np.array([2 * j.index for j in closures], dtype=int)
    b_side = a_side + 1
    a_part = np.array([j.a.part for j in closures], dtype=int)
    b_part = np.array([j.b.part for j in closures], dtype=int)
    coefficients = (moves[:, b_part].T.astype(float) - moves[:, a_part].T) * tree_sign
    for k, joint in enumerate(closures):
        coefficients[k, list(joint.a.dof_indices)] = -1.0
        coefficients[k, list(joint.b.dof_indices)] = 1.0
    return ChainLayout(
        tuple(groups),
        len(sides),
        n_dofs,
        environment_frames,
        *_tree_jumps(model),
        dof_side,
        np.array([sides[s].part for s in dof_side], dtype=int),
        tree_sign,
        moves,
        (a_side, a_part, b_side, b_part),
        np.array([j.offset for j in closures]).reshape(len(closures), 4, 4),
        coefficients,
    )


def _turns(layout: ChainLayout, fwd: Forward, side: int, part: int) -> Array:
    """(n_dofs, 4, 4): how each DoF turns the world frame of a loop's connector
    (`side` on `part`): its tree twist if it moves the part, its own twist if it
    is that side's, else nothing."""
    assert fwd.twists is not None and fwd.own_twists is not None
    own_side = (layout.dof_side == side)[:, None, None]
    moves = (layout.moves[:, part] | (layout.dof_side == side))[:, None, None]
    return np.where(own_side, fwd.own_twists, fwd.twists) * moves


def _subtrees(model: Model) -> dict[int, set[int]]:
    """For each part, itself and every part hung below it in the tree."""
    children: dict[int, list[int]] = {}
    for edge in model.tree:
        parent, child = model.placed_sides(edge)
        children.setdefault(parent.part, []).append(child.part)
    subtrees: dict[int, set[int]] = {}
    for part in range(len(model.parts)):
        found, stack = set(), [part]
        while stack:
            here = stack.pop()
            found.add(here)
            stack.extend(children.get(here, []))
        subtrees[part] = found
    return subtrees


def _tree_jumps(model: Model) -> tuple[tuple[Jump, ...], TreeEdges]:
    """The tree's edges, and the rounds that compose them into world frames.

    A tree up to POINTER_JUMPING_DEPTH deep is composed a level at a time (each
    part's frame after its parent's world frame). A deeper one by pointer
    jumping: each round composes every pending part's frame with its current
    ancestor's and takes that ancestor's ancestor, so a chain of 100 S-hooks
    takes 7 rounds instead of 100. Jumping re-associates the products, so the
    last bits of the frames differ from the level order's, and a settle that
    balances on a knife's edge may then land elsewhere; on shallow trees it
    gains little (10 of a pass's 240 microseconds on the reading nook), so they
    keep the level order."""
    ancestor = np.full(len(model.parts), -1, dtype=int)
    depth = np.zeros(len(model.parts), dtype=int)
    edges = []
    for edge in model.tree:  # parents come before children
        joint = model.joints[edge.joint]
        parent, child = model.placed_sides(edge)
        offset = joint.offset if edge.parent_side == "a" else joint.offset.T
        parent_side = 2 * joint.index + (0 if edge.parent_side == "a" else 1)
        ancestor[child.part] = parent.part
        depth[child.part] = depth[parent.part] + 1
        edges.append((parent_side, parent_side ^ 1, child.part, offset))
    if depth.max(initial=0) <= POINTER_JUMPING_DEPTH:
        levels = (np.flatnonzero(depth == d) for d in range(1, depth.max(initial=0) + 1))
        jumps = tuple(Jump(level, ancestor[level]) for level in levels)
    else:
        jumps = _pointer_jumps(ancestor)
    return jumps, TreeEdges(
        np.array([e[0] for e in edges], dtype=int),
        np.array([e[1] for e in edges], dtype=int),
        np.array([e[2] for e in edges], dtype=int),
        np.array([e[3] for e in edges]).reshape(len(edges), 4, 4),
    )


def _pointer_jumps(ancestor: Index) -> tuple[Jump, ...]:
    """Rounds of pointer jumping over a tree given by each part's parent (-1 for
    the environments and unplaced parts, whose frames are already known)."""
    jumps = []
    while np.any(ancestor >= 0):
        pending = np.flatnonzero(ancestor >= 0)
        jumps.append(Jump(pending, ancestor[pending]))
        further = ancestor[ancestor[pending]]  # an environment's is -1: done next round
        ancestor = ancestor.copy()
        ancestor[pending] = further
    return tuple(jumps)


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


def build_model(program: FlatProgram, turning_on_contact: bool = False) -> Model:
    """Lay out the DoF vector and grow the spanning tree from the environments.
    The parts are ordered as the tree reaches them, not as written: the
    environments by name, then each part as the connections (in their
    canonical order) hang it from what is already placed, then any part
    nothing places, by name. Every sum over parts (the weights, the contacts)
    is then added in the same order whatever the order of the declarations
    (the diaper caddy, its parts declared in reverse, once came to rest 27 mm
    elsewhere: its valley is flat enough for rounding to choose).
    `turning_on_contact`: plain hooks and rings round rods (and, on a loop, on
    hooks and rings) turn about the line of their contact (`_turning_on_its_contact`)."""
    by_name = _assemble(program, tuple(sorted(program.parts, key=lambda part: part.name)))
    environments = [i for i, part in enumerate(by_name.parts) if part.environment]
    reached = [by_name.placed_sides(edge)[1].part for edge in by_name.tree]
    order = [*environments, *reached, *by_name.unplaced]
    loops = bool(by_name.closures)
    turning = by_name.on_loops() if turning_on_contact else None
    return _assemble(program, tuple(by_name.parts[i] for i in order), loops, turning)


def _assemble(
    program: FlatProgram,
    parts: tuple[PartInstance, ...],
    loops: bool = True,
    turning: frozenset[Connection] | None = None,
) -> Model:
    """The model of `program` with its parts in this order; without `loops`,
    the spinning rings' twists left out (`_twisting`); with `turning` (the
    connections on loops), plain hooks and rings turning on what they go round
    (`_turning_on_its_contact`)."""
    index = {p.name: i for i, p in enumerate(parts)}
    variables: list[DofVariable] = []
    joints: list[Joint] = []
    for j, connection in enumerate(sorted(program.connections, key=_connection_key)):
        sides = []
        ends = (("a", connection.a), ("b", connection.b))
        resolved = [parts[index[end.part]].spec.primitive(end.primitive) for _, end in ends]
        for (label, end), primitive, other in zip(ends, resolved, reversed(resolved), strict=True):
            assert primitive is not None and other is not None, end  # elaboration resolved them
            part = index[end.part]
            primitive = _twisting(primitive, connection, label, loops)
            if turning is not None:
                primitive = _turning_on_its_contact(primitive, other, connection in turning)
            start = len(variables)
            for dof in primitive.dofs:
                variables.append(DofVariable(f"{end.part}.{end.primitive}.{dof.name}", dof, j, label))
            sides.append(Side(part, primitive, tuple(range(start, len(variables)))))
        a, b = sides
        offset = alignment_offset(a.primitive, b.primitive, connection.flip)
        held = connection.fixed or _holds_by_itself(a.primitive.kind, b.primitive.kind)
        joints.append(Joint(j, a, b, offset, connection, held))
    environments = frozenset(i for i, part in enumerate(parts) if part.environment)
    target = index[program.targets[0].part] if program.targets else None
    for joint in joints:
        _keep_on_floor(joint, variables, environments)
        _rest_on_the_top_line(joint, variables, parts)
        _keep_threaded(joint, variables)
        _jam(joint, variables)
    written = _written_settings(joints, variables)
    tree, closures, unplaced = _spanning_tree(parts, joints)
    together = tuple(
        turn for joint in joints if (turn := _turning_together(joint, variables, written, not closures))
    )
    pinned = (
        written
        | frozenset(
            i
            for joint in joints
            for i in (
                *_resting_surface(joint, environments),
                *_fixed_rod_line(joint, parts),
                *_ring_spin_off_hooks(joint),
                *_threaded_centre(joint),
                *_unturning_yaws(joint),
                *_untilting_grips(joint),
            )
        )
        | frozenset(turn.second for turn in together if turn.folded)
    ) - _stood_where_asked(joints, environments, target, written)
    standing = tuple(
        s
        for joint in joints
        if not joint.connection.fixed and (s := _standing(joint, environments)) is not None
    )
    return Model(
        program,
        parts,
        tuple(joints),
        tree,
        closures,
        tuple(variables),
        unplaced,
        pinned,
        standing,
        written=written,
        turn_limits=together,
        turning_on_contact=turning is not None,
    )


def _twisting(primitive: Primitive, connection: Connection, label: str, loops: bool) -> Primitive:
    """A spinning ring (a toss ring's round wire: `spin` and `flex`) as it
    connects: without loops, and unless the program sets it, without its twist
    about the line of its contact (the reference's ring). There the twist
    carries no load: at rest the line of a contact is the line of the load it
    carries, the weight of what hangs below, vertical, and gravity has no
    moment about the vertical; so it only turns what hangs below about the
    vertical, and cost the clip lights a third more time (four rings, eight
    twists). In a loop it is what lets a chain swing: without it, the rings
    on two ceiling hooks held a broom hung on two chains 102 mm above where
    the chains end, its S-hooks 34 mm out of plumb
    (tests/solve/test_ring_spin.py)."""
    if loops or not any(is_ring_twist(primitive.variant, dof.name) for dof in primitive.dofs):
        return primitive
    if any(s.side == label and s.dof == "phi" for s in connection.settings):
        return primitive
    return _flexing(primitive, False)


PLAIN_LOOPS = ("Hook", "Ring")  # hooks and rings that do not say `flex`


def _turning_on_its_contact(primitive: Primitive, other: Primitive, in_a_loop: bool) -> Primitive:
    """A plain hook or ring (no `flex`) round a rod, or on another hook or ring
    `in_a_loop`, with the turn about the line of its contact that a flexing one has (its
    `phi`, as far as its wire jams on what it goes round,
    `primitives.yaw_jam_deg`; none where it grips a rod). A rod touching a wire
    at a point turns so, and so do two round wires crossing; the reference
    keeps the loop square round the rod, and a hook's plane square to the hook
    it hangs on, and in a loop the contact may then carry a moment about that
    line that a point cannot (E514), or the loops close only with two parts in
    one place (E423): a flag stick laid in two ceiling hooks, one turned 30
    degrees, was held diagonal, up the turned hook's side, where the real stick
    lies in both hooks' bottoms; a broom on two chains of a curtain ring and a
    flat S-hook under a shower rod could only lie across the rod, and knotted.
    Only where the solver finds that (`solve._with_loops_turning`): elsewhere
    the turn carries nothing (without loops, or a contact with something else
    that closes one, the weight's line is the contact's) and, given to every
    such hook, it cost the reading nook, balanced on knife edges, 20 s instead
    of 2 for the same not-at-rest result.
    A hook on a hook below the loops is left square: what hangs there turns
    about the vertical for free, and the turn only gave the aim a DoF that
    carries nothing (a mug on an S-hook under a flag stick in two ceiling
    hooks hung 27.7 mm from its request instead of 4.9); a rod below them
    turns (a basket's loose handle, its grip in a ceiling hook above the
    handle's loop, E514)."""
    if primitive.variant not in PLAIN_LOOPS:
        return primitive
    if other.variant in TILTING or (other.kind in LOOPS and in_a_loop):
        return _flexing(primitive, True)
    return primitive


def _flexing(primitive: Primitive, flex: bool) -> Primitive:
    """The primitive with its `flex` flag set so (its variant, DoFs and frame formula with it)."""
    flags = {**primitive.flags, "flex": flex}
    return make_primitive(
        primitive.name, primitive.kind, primitive.params, flags, primitive.position, primitive.rotation
    )


def _written_settings(joints: list[Joint], variables: list[DofVariable]) -> frozenset[int]:
    """The DoFs the program sets (`set (...)` on a connection), each made to
    start at its written value: they stay there (pinned) through every step."""
    written = set()
    for joint in joints:
        for setting in joint.connection.settings:
            side = joint.a if setting.side == "a" else joint.b
            i = next(i for i in side.dof_indices if variables[i].dof.name == setting.dof)
            variables[i] = replace(variables[i], dof=replace(variables[i].dof, default=setting.value))
            written.add(i)
    return frozenset(written)


def _connection_key(connection: Connection) -> tuple[tuple[str, str], ...]:
    """Connections in an order of their own, not the program's: the parts and
    primitives they join. The spanning tree, the loops it cuts and the order of
    the unknowns then follow from what is connected, so a program's answer does
    not depend on the order of its lines."""
    return tuple(
        sorted(((connection.a.part, connection.a.primitive), (connection.b.part, connection.b.primitive)))
    )


def _holds_by_itself(first: str, second: str) -> bool:
    """A clip's grip, and anything standing on a surface, stay put when the hack
    settles: friction holds them. An object standing on a floor may still slide
    over it where gravity beats friction (`Standing`: the solver frees that
    slide and puts Coulomb friction on it); its turn stays."""
    kinds = {first, second}
    return "clip" in kinds or kinds in ({"surface"}, {"surface", "hemisphere"})


def _fixed_rod_line(joint: Joint, parts: tuple[PartInstance, ...]) -> tuple[int, ...]:
    """The spin of a rod that belongs to an environment: the contact stays on its
    top line (`_rest_on_the_top_line`). A part's rod turns in what holds it (a
    basket's handle in a hook), but a fixed rod cannot turn, and letting the
    contact wander round it only gives step 1 a valley under the rod to fall into;
    whatever hangs from one point rests on the top line anyway."""
    return tuple(
        side.dof_indices[2]
        for side in (joint.a, joint.b)
        if parts[side.part].environment and side.primitive.variant == "Rod"
    )


def _rest_on_the_top_line(
    joint: Joint, variables: list[DofVariable], parts: tuple[PartInstance, ...]
) -> None:
    """What rests on an environment's rod touches it on its top line: the rod's
    pinned spin (`_fixed_rod_line`) starts, and stays, where the contact's
    normal points most nearly up in the world. The reference keeps the line its
    rod's frame puts at +y, which is the top only for some parts: a tension rod
    or shower curtain rod along x has +y on its side, and an S-hook hung there
    was `solved` touching the rod's side, its whole load on a horizontal
    contact. Not where a connection is held (`fixed`: tape holds a hook where it
    is put, the reading nook's on its shelf edge's face), nor on an upright rod
    (no top line: a car seat's headrest posts keep their frame's)."""
    if joint.held:
        return
    for side in (joint.a, joint.b):
        if not parts[side.part].environment or side.primitive.variant != "Rod":
            continue
        part = parts[side.part]
        placed = (frame_matrix(part.position, part.rotation) @ side.primitive.base_frame())[:3, :3]
        # the normal at spin s is Rz(s) (0, 1, 0) in the rod's frame: its height is
        # -sin(s) placed[2, 0] + cos(s) placed[2, 1], highest at s = atan2(-placed[2, 0], placed[2, 1])
        if np.hypot(placed[2, 0], placed[2, 1]) < UPRIGHT:
            continue
        spin = float(np.degrees(np.arctan2(-placed[2, 0], placed[2, 1])))
        if abs(spin) < 1e-6:
            continue  # the frame's +y is the top already: kept to the bit
        i = side.dof_indices[2]
        variables[i] = replace(variables[i], dof=replace(variables[i].dof, default=spin % 360.0))


# below this, the sine of a rod's slope from the vertical: an upright rod has no top line
UPRIGHT = 1e-6


def _ring_spin_off_hooks(joint: Joint) -> tuple[int, ...]:
    """The spin of a ring that is not on a hook: on a rod or tube it would turn
    the ring about its wire, the turn the rod's tilt (or the tube's) makes
    already; the same motion twice would leave the solver a direction that
    changes nothing."""
    return tuple(
        i
        for side, other in ((joint.a, joint.b), (joint.b, joint.a))
        if side.primitive.variant in SPINNING and other.primitive.kind != "hook"
        for i, dof in zip(side.dof_indices, side.primitive.dofs, strict=True)
        if dof.name == "spin"
    )


def _floor_and_object(joint: Joint, environments: frozenset[int]) -> tuple[Side, Side] | None:
    """Of a connection of two surfaces, the floor and the object standing on it:
    an environment's surface is the floor (a bottle on a pedestal narrower than
    its base stands on the pedestal), else the larger; None for other connections."""
    a, b = joint.a.primitive, joint.b.primitive
    if a.kind != "surface" or b.kind != "surface":
        return None
    on_the_world = [side.part in environments for side in (joint.a, joint.b)]
    if on_the_world[0] != on_the_world[1]:
        return (joint.a, joint.b) if on_the_world[0] else (joint.b, joint.a)
    area = [p.params["width"] * p.params["length"] for p in (a, b)]
    return (joint.b, joint.a) if area[0] <= area[1] else (joint.a, joint.b)


def _resting_surface(joint: Joint, environments: frozenset[int]) -> tuple[int, ...]:
    """Where a surface rests on another, the DoFs that place it there: step 1
    stands an object in the middle of what it rests on (the reference does the
    same), so the smaller's t1, t2 and s and the larger's t1, t2 stay at their
    defaults; only the larger's spin s turns it. The solver does not slide a
    bottle across its basket's floor to chase the target: the floor is not a
    designed joint (gravity may slide it there in step 2: `Standing`), but
    for the target on the world's floor (`_stood_where_asked`)."""
    sides = _floor_and_object(joint, environments)
    if sides is None:
        return ()
    floor, standing = sides
    return standing.dof_indices + floor.dof_indices[:2]


def _stood_where_asked(
    joints: list[Joint], environments: frozenset[int], target: int | None, written: frozenset[int]
) -> frozenset[int]:
    """Where on the world's floor (a shelf, a counter) the target stands, for
    step 1 to choose: it is stood where it is asked for (a bottle asked 60 mm
    left of a shelf's middle stood in the middle, W505 saying to add parts),
    as nothing else moves with it. Not where another object on that floor
    stands wherever the solver puts it (in the middle: moving the target away
    from it, step 1 took it past its request); set where that one stands and
    the target is placed (E508 says so when the two stand on one spot)."""
    on_floors: dict[tuple[int, str], list[tuple[int, tuple[int, ...]]]] = {}
    for joint in joints:
        sides = _floor_and_object(joint, environments)
        if sides is not None and sides[0].part in environments and not joint.connection.fixed:
            floor, standing = sides
            on_floors.setdefault((floor.part, floor.primitive.name), []).append(
                (standing.part, floor.dof_indices[:2])
            )
    free: set[int] = set()
    for objects in on_floors.values():
        # placed: the program says where (one of its two slides, at least)
        others_placed = all(set(slide) & written for part, slide in objects if part != target)
        if others_placed:
            free.update(i for part, slide in objects if part == target for i in slide)
    return frozenset(free - written)


def _keep_on_floor(joint: Joint, variables: list[DofVariable], environments: frozenset[int]) -> None:
    """An object standing on a floor keeps its whole base on it: its centre stays
    half its width and length from the floor's border (the reference's ranges;
    the base's turn on the floor is not counted); where its base is the wider,
    its centre stays over the floor, and no wall holds it there. A floor's
    border is a wall unless the floor says `slide_off: true` (then the object
    falls off it)."""
    sides = _floor_and_object(joint, environments)
    if sides is None:
        return
    floor, standing = sides
    for i, size in zip(floor.dof_indices[:2], ("width", "length"), strict=True):
        margin = standing.primitive.params[size] / (2.0 * floor.primitive.params[size])
        if margin < 0.5:
            _keep_within(variables, i, margin)
        else:  # a base wider than its floor (a pedestal): its centre stays over it, and past its edge falls
            variables[i] = replace(variables[i], dof=replace(variables[i].dof, low_open=True, high_open=True))


COAXIAL = ({"TubeCtl", "Tube"}, {"TubeCtl", "Rod"})


def threaded(joint: Joint) -> tuple[Side, Side] | None:
    """Of a sleeve on a rod or tube (a centre-line tube round the other: a towel
    roll on a broom handle), the shorter and the longer; None for other
    connections. Their two slides would say one thing twice (where the one
    lies along the other), so the shorter is held at its middle (`_threaded_centre`)
    and the longer's slide keeps it whole on it (`_keep_threaded`), as the
    reference does for these pairings."""
    if {joint.a.primitive.variant, joint.b.primitive.variant} not in COAXIAL:
        return None
    lengths = [side.primitive.params["length"] for side in (joint.a, joint.b)]
    return (joint.a, joint.b) if lengths[0] <= lengths[1] else (joint.b, joint.a)


def _threaded_centre(joint: Joint) -> tuple[int, ...]:
    sides = threaded(joint)
    return () if sides is None else (sides[0].dof_indices[0],)


def _keep_threaded(joint: Joint, variables: list[DofVariable]) -> None:
    sides = threaded(joint)
    if sides is None:
        return
    shorter, longer = sides
    _keep_within(
        variables,
        longer.dof_indices[0],
        shorter.primitive.params["length"] / (2.0 * longer.primitive.params["length"]),
    )


def _yaws(joint: Joint) -> tuple[int, ...]:
    """The flex angles (`phi` of a flexible hook or ring) of a connection: turns
    of a loop about the line of the contact, both about the same line."""
    return tuple(
        i
        for side in (joint.a, joint.b)
        for i, dof in zip(side.dof_indices, side.primitive.dofs, strict=True)
        if is_flex_angle(dof, side.primitive.variant)
    )


def _jam(joint: Joint, variables: list[DofVariable]) -> None:
    """Each flex angle, and each rod's tilt of the loop on it, turns only until
    a wire jams (`primitives.jam_of`): before, a clip light's turnbuckle hook
    turned 44 degrees on its ring's 6.6 mm wire, where it jams at 28, its wire
    through the ring's. Where both sides flex, each is limited so, and their
    sum too (`_turning_together`)."""
    gripped = _untilting_grips(joint)
    for side, other in ((joint.a, joint.b), (joint.b, joint.a)):
        for i in side.dof_indices:
            dof = variables[i].dof
            jam = 0.0 if i in gripped else jam_of(dof, side.primitive, other.primitive)
            variables[i] = replace(variables[i], dof=turning_to_the_jam(dof, jam))


def _turning_together(
    joint: Joint, variables: list[DofVariable], written: frozenset[int], fold: bool
) -> TurnLimit | None:
    """Where both sides of a connection flex (`_yaws`), their turns bounded
    together (`TurnLimit`; `fold`: one carries both). Each turn is an Rz at
    the end of its side's connector frame, and the alignment maps a's z to
    sigma times b's (sigma = +-1, with no shift: it is a rotation), so b hangs
    from a through Rz(a's turn) offset Rz(-b's turn) = Rz(a's turn - sigma
    b's turn) offset: the turns add where the alignment flips z (two hooks
    face to face). None where one side does not flex, the jam is 0 (both
    pinned square: `_unturning_yaws`), the program sets both, or the
    alignment does not keep the line."""
    yaws = _yaws(joint)
    jam = yaw_jam_between(joint.a.primitive, joint.b.primitive)
    sigma = float(joint.offset[2, 2])
    if len(yaws) != 2 or not jam or set(yaws) <= written or abs(abs(sigma) - 1.0) > 1e-9:
        return None
    first, second = yaws[::-1] if yaws[0] in written else yaws  # a written one stays put
    if fold:
        _carry_both(variables, first, second, -sigma, jam, second in written)
    return TurnLimit(first, second, -sigma, jam, fold)


def _carry_both(
    variables: list[DofVariable], first: int, second: int, sign: float, jam: float, second_written: bool
) -> None:
    """Fold a pair of flex angles into `first`: its range becomes the turns
    the pair can make, |u| <= jam with `second` where it stays. With `second`
    square that is +-jam (each side alone turns to its own jam, at least as
    far: `primitives.turning_to_the_jam`). With `second` written, `first`
    keeps its own range too, and its ends are real stops only where the jam,
    or its own jam, sets them."""
    dof = variables[first].dof
    square = (dof.low + dof.high) / 2.0  # both ranges are symmetric about square (90)
    shift = sign * (variables[second].dof.default - square)
    low, high = square - jam - shift, square + jam - shift
    real = True
    if second_written:
        real = dof.jammed or (dof.low <= low and high <= dof.high)
        low, high = max(low, dof.low), min(high, dof.high)
    variables[first] = replace(variables[first], dof=replace(dof, low=low, high=high, jammed=real))


def _unturning_yaws(joint: Joint) -> tuple[int, ...]:
    """The flex angles of a loop too snug on what it goes round to turn at all
    (a wire hook bent open round a rod: N416): they stay square (pinned)."""
    return _yaws(joint) if yaw_jam_between(joint.a.primitive, joint.b.primitive) == 0.0 else ()


def _untilting_grips(joint: Joint) -> tuple[int, ...]:
    """A rod's tilt of a loop that grips it (`primitives.grips`: a wire hook
    bent open round it) stays square (pinned): its plane cannot turn along
    the rod. Not where the connection is held (`fixed`, taped): there the
    builder sets the tilt (the reading nook's shelf hooks)."""
    if joint.held:
        return ()
    return tuple(
        i
        for side, other in ((joint.a, joint.b), (joint.b, joint.a))
        if side.primitive.variant in TILTING and grips(other.primitive, side.primitive)
        for i, dof in zip(side.dof_indices, side.primitive.dofs, strict=True)
        if dof.name == "phi"
    )


def _keep_within(variables: list[DofVariable], i: int, margin: float) -> None:
    """Narrow the slide DoF i to [margin, 1 - margin] (a margin past the middle: the middle)."""
    margin = min(margin, 0.5)
    variables[i] = replace(variables[i], dof=replace(variables[i].dof, low=margin, high=1.0 - margin))


def _standing(joint: Joint, environments: frozenset[int]) -> Standing | None:
    sides = _floor_and_object(joint, environments)
    if sides is None:
        return None
    floor, standing = sides
    t1, t2 = floor.dof_indices[:2]
    base, under = standing.primitive.params, floor.primitive.params
    # where they touch: the base, or the floor where it is the narrower (a pedestal)
    patch = (min(base["width"], under["width"]), min(base["length"], under["length"]))
    return Standing(joint.index, "a" if floor is joint.a else "b", (t1, t2), patch)


def _spanning_tree(
    parts: tuple[PartInstance, ...], joints: list[Joint]
) -> tuple[tuple[TreeEdge, ...], tuple[int, ...], tuple[int, ...]]:
    """Grow the tree over the connections in their order (`_connection_key`): a
    connection that reaches a new part is a tree edge, one between two placed
    parts closes a loop; a connection between two unplaced parts waits for a
    later pass."""
    placed = {i for i, p in enumerate(parts) if p.environment}
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
    unplaced = tuple(i for i in range(len(parts)) if i not in placed)
    return tuple(tree), tuple(closures), unplaced
