"""Contact: movable parts kept out of the environment's meshes and out of each
other, and the forces with which the environment holds what rests on it.

Each movable part carries points sampled on its surface; each obstacle (an
environment, or another movable part) a signed distance grid in its own frame
(fabhal/meshes.py, fabhal/kinematics/contact.py). A point inside an obstacle
is pushed out by a stiff spring along the distance's gradient (a penalty
contact: it gives CONTACT_GIVE_MM under the whole assembly's weight on one
point). Against the environment the springs are part of the settle's energy:
a part that leans on a wall comes to rest against it, and the wall carries
what it takes. Between movable parts they serve step 1 (`penetration`), the
final check (fabhal/solve/__init__.py, E508) and, where a settle left two parts
inside each other or their walls crossing (`crossings`), the settle again
(`Pairs.against`), softer than the world's (PARTS_GIVE_MM); the push acts on
both parts, equal and opposite. Walls that cross are taken apart in step 1 by
the parts' convex hulls (`Pairs.hulls`): inside a thin wall the way out is
either face, inside the hull it is the way apart. Contacts are frictionless (a part may slide along the
wall), which errs towards reporting that a hack moves. The contact that a
connection itself makes is not a collision: a part's points around its own
primitive of a connection to an environment (within the reach of the other
side's primitive) are not tested against that environment, and two movable
parts joined by a connection are not tested against each other (how they
meet is the connection's: its DoFs and ranges), but for an object standing on
a surface: its floor's slides stand for the walls at the floor, and what spans
the floor higher up (a basket's handle) is looked for by the check's points
alone, without the two faces' (`contact_pairs`). Which points are left
out is fixed in the part's frame, not measured from where the connection
touches at each step: a point switched in and out at full depth would make
the settle's energy jump.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from fabhal.kinematics.contact import DistanceGrid, PointCells, penalty
from fabhal.kinematics.frames import Array, angular_velocities, invert
from fabhal.library import PartSpec
from fabhal.meshes import contact_grid, contact_points, hull_grid, inside_bounds, near_primitive
from fabhal.model import Forward, Joint, Model
from fabhal.primitives import Primitive
from fabhal.solve.energy import Energy

Index = NDArray[np.intp]
T = TypeVar("T")

# how far the environment gives under the assembly's whole weight on one point
# (mm): stiff enough that what rests on a wall enters it well under a millimetre
CONTACT_GIVE_MM = 0.2
# how far two movable parts give each other under the same load (mm): softer than the
# world, since their springs switch on mid-way through a solve (leaning, crossing walls)
# and against stiff ones such settles creep (three mugs on one rod stopped 0.2 % short of
# rest at 0.2 mm, and came to rest at 0.5); their many points share the load: two mugs
# side by side sink 0.02 mm into each other
PARTS_GIVE_MM = 0.5
# around a connection point, this much more than its primitives' reach is the connection's own contact
CONNECTION_CLEARANCE_MM = 5.0
# where the check's points find a part deeper than this inside an obstacle (mm), the
# settle's points missed it (they are up to 40 mm apart on a large part, and an edge or a
# wire passes between them): the check's points there join the settle's (`Pairs.refined`).
# Deeper than the springs' give (0.2 mm under the whole weight on one point)
REFINE_DEPTH_MM = 0.5
# ...those within this distance (mm, the part's frame) of a check point found inside:
# a few of the settle's spacings, so the contact's neighbourhood is covered as it slides
REFINE_RADIUS_MM = 15.0
# touching points in the same or neighbouring cubes this size (mm), or chained so, are one
# contact (`contacts_at`): more than the settle's points' spacing (8 mm), less than a hack's
# separate contacts lie apart (the caddy's two handles: 450 mm)
REGION_MM = 20.0
# where the check's points of one movable part lie inside another (deeper than
# REFINE_DEPTH_MM) spread over more than this (mm), one's wall passes through the
# other: more than a contact's patch (a part resting on another sinks into it over a
# few millimetres; the reading nook's wire rings cross its links over at most 17 mm),
# as two mugs whose rims cut through each other (165 mm) do, though only their 2.2 mm
# walls' depth shows
CROSSING_SPAN_MM = 2 * REGION_MM
# step 1 takes two movable parts apart where one is this far inside the other (mm; a
# part resting on another sinks a few tenths: `wires_crossed`)
WIRES_CROSSED_MM = 1.0
# two parts lie in one place where nearly all of one's check points (this share) lie
# within COINCIDE_MM of the other's surface: two alike at one pose (two rings written at
# one place on a hook), whose points are none of them inside the other, so no depth
# shows; parts that merely touch have a patch of their points there, not all
COINCIDE_MM = 0.5
COINCIDE_SHARE = 0.9


@dataclass(frozen=True)
class Pair:
    """A movable part's points against one obstacle's shape."""

    part: int
    obstacle: int  # an environment, or another movable part
    points: Array  # (N, 3) mm in the part's frame, less those a connection to the obstacle touches with
    check: Array  # (M, 3) the same, CHECK_POINT_SPACING_MM apart (fabhal/meshes.py), for the check
    shape: PartSpec  # the obstacle's: its grid is built when first needed (`grid`)
    box: Array  # (2, 3) mm, where its grid may read inside (`inside_bounds`), in its frame
    building: Callable[[], None] | None = None  # told before the obstacle's grid is first built
    added: Index = field(default_factory=lambda: np.zeros(0, dtype=int))  # the check's points in `points`
    hull: bool = False  # against the obstacle's convex hull (`Pairs.hulls`), not its surface
    environment: bool = False  # the obstacle is an environment: its grid is read smooth (`grid`)
    # a surface connection stands one on the other: checked only, never given springs (the
    # connection holds them together along its normal, and springs would fight it)
    standing: bool = False

    @cached_property
    def grid(self) -> DistanceGrid:
        """In the obstacle's frame (built once per machine: fabhal/meshes.py);
        an environment's read smooth (fabhal/kinematics/contact.py)."""
        grid = (hull_grid if self.hull else contact_grid)(self.shape, self.building)
        return _smooth_grid(grid) if self.environment else grid

    @cached_property
    def point_cells(self) -> PointCells:
        return PointCells.of(self.points)

    @cached_property
    def check_cells(self) -> PointCells:
        return PointCells.of(self.check)

    def with_check(self, added: Index) -> Pair:
        """The pair with the check's points `added` (indices into `check`) joining
        the settle's own, in place of those added before."""
        own = self.points[: len(self.points) - len(self.added)]
        return replace(self, points=np.vstack([own, self.check[added]]), added=added)


@dataclass(frozen=True)
class Pairs:
    """Every pair, and each side's bounding ball (mm, in its own part's frame)
    for a vectorised test of which pairs are near enough to look at."""

    pairs: tuple[Pair, ...]
    parts: Index  # (K,) the part of each pair
    obstacles: Index  # (K,) its obstacle
    part_balls: Array  # (K, 4): centre and radius of the part's points
    obstacle_balls: Array  # (K, 4): of where the obstacle's grid may read inside (`inside_bounds`)

    def __len__(self) -> int:
        return len(self.pairs)

    @cached_property
    def last_inside(self) -> dict[bytes, Touching]:
        return {}

    @cached_property
    def last_checked(self) -> dict[bytes, Checked]:
        return {}

    def refined(self, deep: dict[int, Array]) -> Pairs:
        """The pairs with, for each pair k in `deep`, the check's points within
        REFINE_RADIUS_MM of deep[k] (check points found inside, the part's frame)
        added to the settle's points."""
        if not deep:
            return self
        from scipy.spatial import cKDTree  # imported only here: 0.3 s of a process's start

        pairs = list(self.pairs)
        for k, inside in deep.items():
            pair = pairs[k]
            if pair.standing:
                continue
            near = cKDTree(pair.check).query_ball_point(inside, REFINE_RADIUS_MM)
            pairs[k] = pair.with_check(
                np.union1d(pair.added, np.concatenate([np.asarray(n, dtype=int) for n in near]))
            )
        return replace(self, pairs=tuple(pairs))

    def dense(self, between: frozenset[frozenset[int]]) -> Pairs:
        """The pairs with, for two movable parts that `between` names together,
        every one of the check's points added to the settle's: walls that once
        passed through each other (two mugs' 2.2 mm walls) pass between the
        settle's points, about 8 mm apart, not between the check's 3 mm."""
        if not between:
            return self  # and its look-ups kept
        pairs = list(self.pairs)
        for k in range(len(self)):
            if self.bodies(k) in between and not pairs[k].standing:
                pairs[k] = pairs[k].with_check(np.arange(len(pairs[k].check)))
        return replace(self, pairs=tuple(pairs))

    def hulls(self, between: frozenset[frozenset[int]]) -> Pairs:
        """The pairs of two movable parts that `between` names together, each
        part's settle's points against the other's convex hull: depths that say
        which way is out where walls cross (`crossings`), for step 1 to take
        such parts apart."""
        keep = [k for k in range(len(self)) if self.bodies(k) in between]
        hulls = [replace(self.pairs[k].with_check(np.zeros(0, dtype=int)), hull=True) for k in keep]
        rows = np.array(keep, dtype=int)
        return Pairs(
            tuple(hulls),
            self.parts[rows],
            self.obstacles[rows],
            self.part_balls[rows],
            self.obstacle_balls[rows],
        )

    def bodies(self, k: int) -> frozenset[int]:
        """The two parts of pair k, either way round."""
        return frozenset((int(self.parts[k]), int(self.obstacles[k])))

    def size(self) -> int:
        """How many points all the pairs' settles look up."""
        return sum(len(pair.points) for pair in self.pairs)

    def against(self, obstacles: set[int], between: frozenset[frozenset[int]] = frozenset()) -> Pairs:
        """The pairs whose obstacle is one of these parts, and those of two parts
        that `between` names together (either way round)."""
        named = [self.bodies(k) in between for k in range(len(self))]
        keep = np.flatnonzero(np.isin(self.obstacles, list(obstacles)) | np.array(named, dtype=bool))
        return Pairs(
            tuple(self.pairs[k] for k in keep),
            self.parts[keep],
            self.obstacles[keep],
            self.part_balls[keep],
            self.obstacle_balls[keep],
        )

    def near(self, frames: Array) -> Index:
        """The indices of the pairs whose balls meet, with the parts at `frames`."""
        if not self.pairs:
            return np.zeros(0, dtype=int)
        owners, centres, reach = self._balls
        placed = frames[owners]
        world = np.einsum("kij,kj->ki", placed[:, :3, :3], centres) + placed[:, :3, 3]
        gap = np.linalg.norm(world[: len(self.pairs)] - world[len(self.pairs) :], axis=1)
        return np.flatnonzero(gap <= reach)

    @cached_property
    def _balls(self) -> tuple[Index, Array, Array]:
        """Both sides' owners and ball centres stacked (parts, then obstacles: one
        look-up of frames a call, asked at every evaluation), and each pair's reach."""
        owners = np.concatenate([self.parts, self.obstacles])
        centres = np.vstack([self.part_balls[:, :3], self.obstacle_balls[:, :3]])
        return owners, centres, self.part_balls[:, 3] + self.obstacle_balls[:, 3]


@dataclass(frozen=True)
class Contact:
    """Where a part rests on another (an environment, or a movable part), and how hard."""

    part: int
    rests_on: int
    force: Array  # (3,) N the other exerts on the part, world axes
    moment: Array  # (3,) N mm the force's moment about the world origin
    point: Array  # (3,) mm world: where it acts (the penetration-weighted mean point), for the report
    depth: float  # mm, the deepest point's penetration


def contact_pairs(model: Model, report: Callable[[str], None] | None = None) -> Pairs:
    """Every movable, placed part against every environment with a shape and
    every other movable part, except two movable parts that a connection joins
    and two parts a `fixed` surface connection joins (glued, taped or pinned: a
    push pin's point goes into the cork).
    Where a surface connection stands the part on the obstacle, or the obstacle
    on it, the pair has the check's points only, less those near the two faces,
    and never springs: the floor's slides keep the object's base off the walls
    (springs against them made each settle a round of leaning: the one-eye-hook
    soap basket 1.8 s instead of 0.16), and the connection holds the two
    together along its normal, where springs would fight it (a basket stood on a
    shelf by its inner floor, 6 mm above its underside: 1.2 MN). What the check
    finds (a handle across the basket through the bottle) is reported (E508)."""
    movable = [i for i, p in enumerate(model.parts) if not p.environment and i not in model.unplaced]
    obstacles = [i for i, p in enumerate(model.parts) if p.environment or i in movable]
    between: dict[frozenset[int], list[Joint]] = {}
    for joint in model.joints:
        between.setdefault(frozenset((joint.a.part, joint.b.part)), []).append(joint)
    points = {part: contact_points(model.parts[part].spec) for part in movable}  # for the balls
    # one array per kind of pair, so that pairs alike are looked up at once
    kept: dict[tuple[object, ...], tuple[Array, Array]] = {}
    # where any point inside an obstacle must be, without building its grid: most pairs never come near
    boxes = {i: inside_bounds(model.parts[i].spec) for i in obstacles}
    box_balls = {i: _ball_of_box(box) for i, box in boxes.items()}
    pairs = []
    for part in movable:
        for obstacle in obstacles:
            joints = between.get(frozenset((part, obstacle)), [])
            if any("surface" in (j.a.primitive.kind, j.b.primitive.kind) and not j.stands for j in joints):
                continue  # glued, taped or pinned to it: what they do where they meet is the builder's
            standing = any(j.stands for j in joints)
            if obstacle == part or (joints and not model.parts[obstacle].environment and not standing):
                continue
            # (its own primitive, the obstacle's) for each connection joining them
            touching = tuple(
                (j.a.primitive, j.b.primitive) if j.a.part == part else (j.b.primitive, j.a.primitive)
                for j in joints
            )
            key = (model.parts[part].type_name, *((own.name, _reach(other)) for own, other in touching))
            if key not in kept:
                kept[key] = tuple(  # type: ignore[assignment]
                    _away_from(model.parts[part].spec, touching, check) for check in (False, True)
                )
            spec = model.parts[obstacle].spec
            building = None if report is None else _telling(report, model.parts[obstacle].type_name)
            environment = model.parts[obstacle].environment
            settle_points, check_points = kept[key]
            if standing:
                settle_points = settle_points[:0]
            pairs.append(
                Pair(
                    part,
                    obstacle,
                    settle_points,
                    check_points,
                    spec,
                    boxes[obstacle],
                    building,
                    environment=environment,
                    standing=standing,
                )
            )
    point_balls = {part: _ball_of_points(points[part]) for part in movable}
    return Pairs(
        tuple(pairs),
        np.array([pair.part for pair in pairs], dtype=int),
        np.array([pair.obstacle for pair in pairs], dtype=int),
        np.array([point_balls[pair.part] for pair in pairs]).reshape(-1, 4),
        np.array([box_balls[pair.obstacle] for pair in pairs]).reshape(-1, 4),
    )


def _away_from(spec: PartSpec, touching: tuple[tuple[Primitive, Primitive], ...], check: bool) -> Array:
    """The part's points (the check's if `check`) farther from each own
    primitive's shape than the other's reach."""
    points = contact_points(spec, check)
    keep = np.ones(len(points), dtype=bool)
    for own, other in touching:
        keep &= ~near_primitive(spec, own, _reach(other), check)
    return points[keep]


def _telling(report: Callable[[str], None], name: str) -> Callable[[], None]:
    return lambda: report(f"measuring the shape of {name} for contact (once per machine)")


def _ball_of_points(points: Array) -> Array:
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    return np.append(centre, np.linalg.norm(points - centre, axis=1).max())


# an environment's grid read smooth, one per grid (each keeps its own look-up tables),
# by the id of the grid it reads (kept alive here: the ids are never reused)
_SMOOTH: dict[int, tuple[DistanceGrid, DistanceGrid]] = {}


def _smooth_grid(grid: DistanceGrid) -> DistanceGrid:
    """`grid` read smooth. Parts rest on the environment: on a trilinear grid a
    resting point's settle ends on a cell face, where the depth's derivative
    jumps and no gradient holds (the diaper caddy's strap on a seat back, 9.6 mm
    cells: its settles crept there until they stalled). Movable parts keep the
    trilinear reading, exact at the samples: their walls are as thin as their
    cells (a mug's 2.2 mm on 2 mm), and the spline would thin them."""
    if id(grid) not in _SMOOTH:
        _SMOOTH[id(grid)] = (grid, replace(grid, smooth=True))
    return _SMOOTH[id(grid)][1]


def _ball_of_box(box: Array) -> Array:
    return np.append(box.mean(axis=0), np.linalg.norm(box[1] - box[0]) / 2)


def _reach(primitive: Primitive) -> float:
    """How far from its connection point a primitive's own shape extends (mm),
    along which the part it holds may touch it (a rod's length does not count:
    a hook touches it only around the point where it hangs)."""
    p = primitive.params
    sizes = {
        "hook": p.get("arc_radius", 0.0) + p.get("thickness", 0.0),
        "hole": p.get("arc_radius", 0.0) + p.get("thickness", 0.0),
        "rod": p.get("radius", 0.0),
        "tube": p.get("inner_radius", 0.0) + p.get("thickness", 0.0),
        "hemisphere": p.get("radius", 0.0),
        "clip": max(p.get("width", 0.0), p.get("height", 0.0), p.get("dist", 0.0) + p.get("open_gap", 0.0)),
        "edge": max(p.get("height", 0.0), p.get("width", 0.0)),
    }
    return sizes.get(primitive.kind, 0.0) + CONNECTION_CLEARANCE_MM


# a part with this many points or more (a mug's 8,500) moves only those of its cubes near
# the obstacle's box (`PointCells`); fewer (an S-hook's 64) all at once, which costs less
CELLS_FROM = 3000


def _in_box(points: Array, part: Array, obstacle: Array, box: Array) -> tuple[Array, Array, Index]:
    """Of `points` of a part at G places `part` (G, 4, 4), against its
    obstacles at `obstacle` (G, 4, 4): those within the obstacles' `box`
    (2, 3) in the obstacle's frame, in the world (M, 3) and in the
    obstacle's frame (M, 3), with their indices into the G x N points (M,),
    ascending."""
    # row vectors: p_world = R p + o is p @ R^T + o, and p_local = (p_world - o) @ R
    world = (points @ part[:, :3, :3].transpose(0, 2, 1) + part[:, None, :3, 3]).reshape(-1, 3)
    local = ((world.reshape(len(part), -1, 3) - obstacle[:, None, :3, 3]) @ obstacle[:, :3, :3]).reshape(
        -1, 3
    )
    boxed = np.flatnonzero(((local >= box[0]) & (local <= box[1])).all(axis=1))
    return world[boxed], local[boxed], boxed


def _in_box_by_cells(
    points: Array, cells: PointCells, part: Array, obstacle: Array, box: Array
) -> tuple[Array, Array, Index]:
    """`_in_box`, moving only the points of the cubes near the box
    (`PointCells.near_box`), by the same arithmetic."""
    near = cells.near_box(invert(obstacle) @ part, box[0], box[1])
    found: list[tuple[Array, Array, Index]] = []
    for row, (moved, frame) in enumerate(zip(part, obstacle, strict=True)):
        candidates = np.flatnonzero(near[row])
        world = points[candidates] @ moved[:3, :3].T + moved[:3, 3]
        local = (world - frame[:3, 3]) @ frame[:3, :3]
        within = ((local >= box[0]) & (local <= box[1])).all(axis=1)
        found.append((world[within], local[within], row * len(points) + candidates[within]))
    world, local, boxed = (np.concatenate(column) for column in zip(*found, strict=True))
    return world, local, boxed


@dataclass(frozen=True)
class Looked:
    """A group's points looked up in its obstacle (`_distances`): for each,
    its row in the group and its index among the part's points (M,), where
    it is (world, (M, 3)), its signed distance (M,) and the distance's
    gradient (world, (M, 3); only where it is negative, and never for the
    check's points). Every other point is outside."""

    row: Index
    point: Index
    world: Array
    distance: Array
    gradient: Array


def _distances(fwd: Forward, pairs: Pairs, groups: list[list[int]], check: bool = False) -> list[Looked]:
    """For each group of pairs of one kind (the same points against the same
    grid, `_kinds`), its points (the check's if `check`) that may be inside
    the obstacle, looked up (`Looked`): only points within the obstacle's
    box, and read from a sample inside (`could_be_inside`), can be inside
    it. The groups that look at one grid look it up together (the caddy's
    S-hooks and the caddy against the seat backs: one look-up, not two;
    each look-up costs as much as its points)."""
    frames = fwd.frames
    boxed: list[tuple[Array, Array, Index, int]] = []  # world, local, index into G x N, N
    for group in groups:
        first = pairs.pairs[group[0]]
        part, obstacle = frames[pairs.parts[group]], frames[pairs.obstacles[group]]
        points = first.check if check else first.points
        if len(points) < CELLS_FROM:
            boxed.append((*_in_box(points, part, obstacle, first.box), len(points)))
        else:
            cells = first.check_cells if check else first.point_cells  # gathered when first needed
            boxed.append((*_in_box_by_cells(points, cells, part, obstacle, first.box), len(points)))
    looked: list[Looked] = [_nothing_looked()] * len(groups)
    by_grid: dict[int, list[int]] = {}
    for g, group in enumerate(groups):
        if len(boxed[g][2]):  # most look-ups (a part near an obstacle's ball, outside its box)
            by_grid.setdefault(id(pairs.pairs[group[0]].grid), []).append(g)
    for members in by_grid.values():
        grid = pairs.pairs[groups[members[0]][0]].grid
        local = np.concatenate([boxed[g][1] for g in members])
        near = grid.could_be_inside(local)
        if check:  # the check asks how deep, never the way out
            found, slopes = grid.distance(local[near]), np.zeros((int(near.sum()), 3))
        else:
            found, slopes = grid.sample_inside(local[near])
        start = done = 0
        for g in members:  # their points were looked up one member after the other
            world, _, index, count = boxed[g]
            kept = near[start : start + len(index)]
            start += len(index)
            mine = slice(done, done + int(np.count_nonzero(kept)))
            done = mine.stop
            if mine.start == mine.stop:
                continue  # every point certainly outside (most members: nothing looked up)
            row, point = np.divmod(index[kept], count)
            # each gradient into the world by its row's obstacle's rotation: g @ R^T
            rotations = frames[pairs.obstacles[groups[g]], :3, :3]
            gradient = slopes[mine] @ rotations[0].T
            for r in range(1, len(rotations)):
                same = row == r
                gradient[same] = slopes[mine][same] @ rotations[r].T
            looked[g] = Looked(row, point, world[kept], found[mine], gradient)
    return looked


def _nothing_looked() -> Looked:
    none = np.zeros(0, dtype=np.intp)
    return Looked(none, none, np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)))


@dataclass(frozen=True)
class Touching:
    """Every point inside an obstacle, over all pairs: (M,) the pair of each,
    (M, 3) where it is (world), (M,) how deep (mm) and (M, 3) the way out
    (the distance's gradient, world)."""

    pair: Index
    world: Array
    depth: Array
    normal: Array

    def per_pair(self, values: Array, count: int) -> Array:
        """(M, ...) values summed per pair: (count, ...)."""
        out = np.zeros((count, *values.shape[1:]))
        np.add.at(out, self.pair, values)
        return out

    def resultants(self, push: Array, count: int) -> tuple[Array, Array]:
        """Pushes (M, 3) at the touching points, per pair: (count, 3) forces and
        (count, 3) their moments about the world origin."""
        return self.per_pair(push, count), self.per_pair(np.cross(self.world, push), count)


def _inside(model: Model, fwd: Forward, pairs: Pairs) -> Touching:
    """The points inside an obstacle. The pairs near enough to look at are
    looked at a kind at a time (one grid lookup for all the S-hooks of a chain).
    The last answer is kept: the settle's energy, its verification and the
    report's contacts ask at the same place."""
    return _remembered(pairs.last_inside, fwd.frames.tobytes(), lambda: _look_inside(model, fwd, pairs))


def _remembered(last: dict[bytes, T], key: bytes, compute: Callable[[], T]) -> T:
    """The answer `last` keeps for configuration `key`, else `compute()`'s, kept
    instead (one configuration at a time: the one asked about again)."""
    if key not in last:
        answer = compute()
        last.clear()
        last[key] = answer
    return last[key]


def _kinds(pairs: Pairs, fwd: Forward, check: bool = False) -> list[list[int]]:
    """The pairs near enough to look at, by kind: the same points against the same grid."""
    kinds: dict[tuple[int, int], list[int]] = {}
    for k in pairs.near(fwd.frames).tolist():
        pair = pairs.pairs[k]
        kinds.setdefault((id(pair.check if check else pair.points), id(pair.grid)), []).append(k)
    return list(kinds.values())


def _look_inside(model: Model, fwd: Forward, pairs: Pairs) -> Touching:
    found: list[tuple[Array, Array, Array, Array]] = []
    groups = _kinds(pairs, fwd)
    for group, looked in zip(groups, _distances(fwd, pairs, groups), strict=True):
        inside = looked.distance < 0.0
        if not inside.any():  # the usual answer: nothing to gather
            continue
        which = np.array(group)[looked.row[inside]]
        found.append((which, looked.world[inside], -looked.distance[inside], looked.gradient[inside]))
    if not found:
        return Touching(np.zeros(0, dtype=int), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)))
    which, world, depth, normal = (np.concatenate(column) for column in zip(*found, strict=True))
    return Touching(which, world, depth, normal)


def _on_parts(
    resting: Index, rests_on: Index, forces: Array, moments: Array, parts: int
) -> tuple[Array, Array]:
    """Forces and moments (K, 3) that obstacles `rests_on` exert on parts
    `resting`, as loads per part: (parts, 3) each, the reaction on the obstacle
    (an environment's is never used: it does not move)."""
    part_forces, part_moments = np.zeros((parts, 3)), np.zeros((parts, 3))
    for owners, sign in ((resting, 1.0), (rests_on, -1.0)):
        np.add.at(part_forces, owners, sign * forces)
        np.add.at(part_moments, owners, sign * moments)
    return part_forces, part_moments


def _stiffness(weight: float) -> float:
    """The springs' stiffness (joules per mm^2, fabhal/kinematics/contact.py
    `penalty`): the assembly's whole weight (joules per mm) on one point sinks
    it CONTACT_GIVE_MM."""
    return weight / CONTACT_GIVE_MM


def _pair_stiffness(model: Model, pairs: Pairs, weight: float) -> Array:
    """(K,) each pair's spring stiffness (joules per mm^2): against the
    environment `_stiffness`; between two movable parts a softer one
    (PARTS_GIVE_MM). Made once per energy: it depends on the pairs alone."""
    world = np.array([model.parts[int(o)].environment for o in pairs.obstacles], dtype=bool)
    return np.where(world, _stiffness(weight), weight / PARTS_GIVE_MM)


def with_contacts(model: Model, energy: Energy, pairs: Pairs, weight: float) -> Energy:
    """The energy plus the contacts' springs. weight: the assembly's, joules per mm.
    Their Hessian is zero where no point is inside an obstacle, and not given
    (None: measured) where one is (fabhal/solve/energy.py)."""
    if not pairs:
        return energy
    stiffness = _pair_stiffness(model, pairs, weight)

    def total(x: Array) -> tuple[float, Array]:
        value, gradient = energy(x)
        fwd = model.forward(x, with_twists=True)
        touching = _inside(model, fwd, pairs)
        if not len(touching.depth):
            return value, gradient
        spring, slope = penalty(-touching.depth, stiffness[touching.pair])
        # d(spring) / d(point) as a load on the part (and the reaction on a movable
        # obstacle): their generalised forces are the gradient
        forces, moments = touching.resultants(slope[:, None] * touching.normal, len(pairs))
        loads = _on_parts(pairs.parts, pairs.obstacles, forces, moments, len(model.parts))
        return value + float(np.sum(spring)), gradient + model.wrench_gradient(fwd, *loads)

    def hessian(x: Array) -> Array | None:
        touching = _inside(model, model.forward(x, with_twists=True), pairs)
        return None if len(touching.depth) else np.zeros((len(x), len(x)))

    def nearly(x: Array) -> Array:
        fwd = model.forward(x, with_twists=True)
        return spring_hessian(model, x, fwd, pairs, _inside(model, fwd, pairs), stiffness)

    return energy.plus(total, hessian, nearly)


def spring_hessian(
    model: Model, x: Array, fwd: Forward, pairs: Pairs, touching: Touching, stiffness: Array
) -> Array:
    """The springs' Hessian but for the obstacles' curvature under the points:
    Gauss-Newton's k (dd/dx)^T (dd/dx) for each point's depth d, plus its push
    held constant as a load on the points (`Model.load_hessian`; the reaction
    on a movable obstacle likewise)."""
    n = len(x)
    if not len(touching.depth):
        return np.zeros((n, n))
    assert fwd.twists is not None
    k = stiffness[touching.pair]
    push = (k * touching.depth)[:, None] * touching.normal  # on the part, outwards
    parts, obstacles = pairs.parts[touching.pair], pairs.obstacles[touching.pair]
    at = np.concatenate([touching.world, np.ones((len(k), 1))], axis=1)
    loads = np.zeros((len(model.parts), 3, 4))  # the pushes' f (x) (X, 1): their potential is -f . X
    np.add.at(loads, parts, -push[:, :, None] * at[:, None, :])
    np.add.at(loads, obstacles, push[:, :, None] * at[:, None, :])
    rate = (
        angular_velocities(fwd.twists) @ np.cross(touching.world, touching.normal).T
        + fwd.twists[:, :3, 3] @ touching.normal.T
    )  # (n, M): how fast each DoF moves each point along its way out
    moves = model.layout.moves
    outwards = (moves[:, parts].astype(float) - moves[:, obstacles]) * rate  # -d depth / dx
    return model.load_hessian(x, fwd, loads) + (outwards * k) @ outwards.T


def penetration(model: Model, x: Array, pairs: Pairs) -> tuple[Array, Array]:
    """Per part, how deep its points are inside obstacles: the root of the sum of
    their squared depths (mm; 0 when none is inside: one entry per part, so the
    length never changes), and its exact derivative by x (parts x DoFs). As
    residuals for step 1 they cost what each point's depth would, squared."""
    fwd = model.forward(x, with_twists=True)
    assert fwd.twists is not None
    touching = _inside(model, fwd, pairs)
    parts = len(model.parts)
    depths = np.zeros(parts)
    np.add.at(depths, pairs.parts[touching.pair], touching.depth**2)
    depths = np.sqrt(depths)
    rows = np.zeros((parts, len(x)))
    if not len(touching.depth):
        return depths, rows
    # d(distance) / dx_j = normal . (w_j x p + v_j) for the DoFs that move the
    # part, less the same for those that move the obstacle (never an environment)
    touched = np.unique(touching.pair)
    force, moment = (
        r[touched] for r in touching.resultants(touching.depth[:, None] * touching.normal, len(pairs))
    )
    change = force @ fwd.twists[:, :3, 3].T + moment @ angular_velocities(fwd.twists).T
    moves = model.layout.moves.astype(float)
    change *= (moves[:, pairs.parts[touched]] - moves[:, pairs.obstacles[touched]]).T
    np.add.at(rows, pairs.parts[touched], -change)
    inside = depths > 0.0
    rows[inside] /= depths[inside, None]
    return depths, rows


@dataclass(frozen=True)
class Checked:
    """What the check's points find at a configuration: per pair, how deep its
    deepest point is inside the obstacle (mm, 0 if none), and for the pairs
    deeper than REFINE_DEPTH_MM the points found so (the part's frame)."""

    depth: Array  # (K,)
    deep: dict[int, Array]
    on_surface: Array  # (K,) the share of the pair's points within COINCIDE_MM of the obstacle's surface

    def overlaps(self, pairs: Pairs, deeper: float) -> list[tuple[int, int, float]]:
        """(part, obstacle, depth) of every pair deeper than `deeper` mm, deepest first."""
        found = np.flatnonzero(self.depth > deeper)
        found = found[np.argsort(-self.depth[found])]
        return [(int(pairs.parts[k]), int(pairs.obstacles[k]), float(self.depth[k])) for k in found]


def check(model: Model, x: Array, pairs: Pairs) -> Checked:
    """The check's points (about 3 mm apart) against every obstacle near: the
    measure of whether parts are inside each other or the world (E508), finer
    than the settle's springs, which it refines where they missed. The last
    answer is kept: the settle's refinement and the final E508 ask at the same
    place."""
    fwd = model.forward(x)
    return _remembered(pairs.last_checked, fwd.frames.tobytes(), lambda: _look_finely(fwd, pairs))


def _look_finely(fwd: Forward, pairs: Pairs) -> Checked:
    depth, on_surface = np.zeros(len(pairs)), np.zeros(len(pairs))
    deep: dict[int, Array] = {}
    groups = _kinds(pairs, fwd, check=True)
    for group, looked in zip(groups, _distances(fwd, pairs, groups, check=True), strict=True):
        for row, k in enumerate(group):
            mine = looked.row == row
            inside, point = -looked.distance[mine], looked.point[mine]  # every other point is outside
            depth[k] = max(0.0, float(inside.max(initial=0.0)))
            points = len(pairs.pairs[k].check)
            on_surface[k] = float(np.count_nonzero(np.abs(inside) <= COINCIDE_MM)) / points if points else 0.0
            if depth[k] > REFINE_DEPTH_MM:
                deep[k] = pairs.pairs[k].check[point[inside > REFINE_DEPTH_MM]]
    return Checked(depth, deep, on_surface)


def crossings(model: Model, x: Array, pairs: Pairs) -> list[tuple[int, int, float]]:
    """(part, other movable part, mm) where the part's wall passes through the
    other's at x: the check's points of the part found inside the other spread
    over that many millimetres in one touching region (`_regions`: two large
    rings that touch at two places 400 mm apart touch twice, briefly), more
    than CROSSING_SPAN_MM; widest first."""
    checked = check(model, x, pairs)
    found = []
    for k, inside in checked.deep.items():
        if model.parts[int(pairs.obstacles[k])].environment:
            continue
        span = max(float(np.linalg.norm(np.ptp(inside[region], axis=0))) for region in _regions(inside))
        if span > CROSSING_SPAN_MM:
            found.append((int(pairs.parts[k]), int(pairs.obstacles[k]), span))
    return sorted(found, key=lambda crossing: -crossing[2])


def coinciding(model: Model, x: Array, pairs: Pairs) -> list[tuple[int, int]]:
    """(part, other movable part) lying in one place at x: nearly all the part's
    check points (COINCIDE_SHARE) lie on the other's surface."""
    on_surface = check(model, x, pairs).on_surface
    return [
        (int(pairs.parts[k]), int(pairs.obstacles[k]))
        for k in np.flatnonzero(on_surface >= COINCIDE_SHARE).tolist()
        if not model.parts[int(pairs.obstacles[k])].environment
    ]


def passing_through(model: Model, x: Array, pairs: Pairs) -> frozenset[frozenset[int]]:
    """The movable parts whose walls cross at x (`crossings`), in twos."""
    return frozenset(frozenset(crossing[:2]) for crossing in crossings(model, x, pairs))


def wires_crossed(model: Model, x: Array, pairs: Pairs) -> frozenset[frozenset[int]]:
    """The movable parts, in twos, that the check's points find one inside the
    other by more than WIRES_CROSSED_MM at x: a wire through a wire, between the
    settle's points. Step 1 fits with no contact and can leave them so (an
    S-hook's wire 2.3 mm through a toss ring's it is not hung on), and a settle
    keeps the way round it starts in: the ring then rested in that S-hook's
    arc, carrying the hack through a contact the program never made."""
    return frozenset(
        frozenset((part, obstacle))
        for part, obstacle, _ in check(model, x, pairs).overlaps(pairs, WIRES_CROSSED_MM)
        if not model.parts[obstacle].environment
    )


def contacts_at(model: Model, x: Array, pairs: Pairs, weight: float) -> tuple[Contact, ...]:
    """The contacts at x, with the force the other body exerts (N) and where:
    one per region where two bodies touch (`_regions`: a caddy's two handles
    on the seats are two contacts, each drawn where it is). Two movable parts
    touch as two pairs (each one's points in the other's grid), taken together:
    a region is named by its deepest point's pair (its part is the one inside
    the other), and the other pair's pushes, on the other part, count as
    their reactions."""
    touching = _inside(model, model.forward(x, with_twists=True), pairs)
    slope = penalty(-touching.depth, _pair_stiffness(model, pairs, weight)[touching.pair])[1]
    push = -1000.0 * slope[:, None] * touching.normal  # J/mm -> N, on each point's part
    parts, obstacles = pairs.parts[touching.pair], pairs.obstacles[touching.pair]
    bodies = np.minimum(parts, obstacles) * len(model.parts) + np.maximum(parts, obstacles)
    contacts = []
    for key in np.unique(bodies).tolist():
        together = np.flatnonzero(bodies == key)
        for region in _regions(touching.world[together]):
            rows = together[region]
            named = rows[np.argmax(touching.depth[rows])]
            on_named = np.where(parts[rows] == parts[named], 1.0, -1.0)[:, None] * push[rows]
            depth = touching.depth[rows]
            contacts.append(
                Contact(
                    int(parts[named]),
                    int(obstacles[named]),
                    on_named.sum(axis=0),
                    np.cross(touching.world[rows], on_named).sum(axis=0),
                    depth @ touching.world[rows] / depth.sum(),  # the penetration-weighted mean point
                    float(depth.max()),
                )
            )
    return tuple(contacts)


def _regions(points: Array) -> list[Index]:
    """The points (M, 3) in groups, one per touching region: points in the same
    or neighbouring REGION_MM cubes (of a grid over space) are one group, and so
    are chains of such. Linear in M (a part deep in a wall has thousands of
    points inside), without scipy (its import would cost a process 0.3 s)."""
    cells, of_point = np.unique(np.floor(points / REGION_MM).astype(int), axis=0, return_inverse=True)
    index = {tuple(cell): k for k, cell in enumerate(cells.tolist())}
    parent = list(range(len(cells)))

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    steps = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)]
    for cell, k in index.items():
        for step in steps:
            other = index.get((cell[0] + step[0], cell[1] + step[1], cell[2] + step[2]))
            if other is not None:
                parent[root(other)] = root(k)
    labels = np.array([root(k) for k in range(len(cells))], dtype=int)[of_point.ravel()]
    return [np.flatnonzero(labels == label) for label in np.unique(labels)]


def contact_loads(model: Model, contacts: tuple[Contact, ...]) -> tuple[Array, Array]:
    """(P, 3) N the contacts' forces on each part (a movable part that another
    rests on bears the reaction), and (P, 3) N mm their moments about the world origin."""
    return _on_parts(
        np.array([c.part for c in contacts], dtype=int),
        np.array([c.rests_on for c in contacts], dtype=int),
        np.array([c.force for c in contacts]).reshape(-1, 3),
        np.array([c.moment for c in contacts]).reshape(-1, 3),
        len(model.parts),
    )
