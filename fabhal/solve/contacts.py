"""Contact with the environment: movable parts kept out of the environment's
meshes, and the forces with which the environment holds them.

Each movable part carries points sampled on its surface; each environment a
signed distance grid (fabhal/meshes.py, fabhal/kinematics/contact.py). A
point inside the environment is pushed out by a stiff spring along the
distance's gradient (a penalty contact: the environment gives CONTACT_GIVE_MM
under the whole assembly's weight on one point), which is an energy the settle
minimises with gravity: a part that leans on a wall comes to rest against it,
and the wall carries what it takes. Contacts are frictionless (a part may slide
along the wall), which errs towards reporting that a hack moves. The contact
that a connection itself makes is not a collision: around each connection
point the two parts it joins may meet (within the reach of its primitives).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from fabhal.kinematics.contact import DistanceGrid, penalty
from fabhal.kinematics.frames import Array, angular_velocities
from fabhal.meshes import contact_grid, contact_points
from fabhal.model import Forward, Model
from fabhal.primitives import Primitive

# how far the environment gives under the assembly's whole weight on one point
# (mm): stiff enough that what rests on a wall enters it well under a millimetre
CONTACT_GIVE_MM = 0.2
# around a connection point, this much more than its primitives' reach is the connection's own contact
CONNECTION_CLEARANCE_MM = 5.0


@dataclass(frozen=True)
class Pair:
    """A movable part's points against one environment."""

    part: int
    environment: int
    points: Array  # (N, 3) mm in the part's frame
    grid: DistanceGrid  # in the environment's frame
    centre: Array  # (3,) mm in the part's frame: the points' bounding sphere, to skip a pair far apart
    radius: float
    # connections joining the two: (joint index, reach in mm) around whose point they may meet
    joined: tuple[tuple[int, float], ...]


@dataclass(frozen=True)
class Contact:
    """Where a part rests on an environment, and how hard."""

    part: int
    environment: int
    force: Array  # (3,) N the environment exerts on the part, world axes
    moment: Array  # (3,) N mm the force's moment about the world origin
    point: Array  # (3,) mm world: where it acts (the penetration-weighted mean point), for the report
    depth: float  # mm, the deepest point's penetration


def contact_pairs(model: Model) -> tuple[Pair, ...]:
    """Every movable, placed part against every environment with a shape, except
    where a surface connection stands the part on it (the whole face is the
    connection's own contact)."""
    environments = [i for i, p in enumerate(model.parts) if p.environment]
    movable = [i for i, p in enumerate(model.parts) if not p.environment and i not in model.unplaced]
    if not environments or not movable:
        return ()
    pairs = []
    for environment in environments:
        grid = contact_grid(model.parts[environment].spec)
        for part in movable:
            joints = [j for j in model.joints if {j.a.part, j.b.part} == {part, environment}]
            if any("surface" in (j.a.primitive.kind, j.b.primitive.kind) for j in joints):
                continue
            joined = tuple((j.index, _reach(j.a.primitive) + _reach(j.b.primitive)) for j in joints)
            points = contact_points(model.parts[part].spec)
            centre = (points.min(axis=0) + points.max(axis=0)) / 2
            radius = float(np.linalg.norm(points - centre, axis=1).max())
            pairs.append(Pair(part, environment, points, grid, centre, radius, joined))
    return tuple(pairs)


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


def _distances(model: Model, fwd: Forward, pair: Pair) -> tuple[Array, Array, Array]:
    """The pair's points in the world (N, 3), their signed distances from the
    environment (N,; +inf where a connection's own contact) and the distances'
    gradients in the world (N, 3)."""
    frame, environment = fwd.frames[pair.part], fwd.frames[pair.environment]
    if not pair.grid.near(
        (frame[:3, :3] @ pair.centre + frame[:3, 3] - environment[:3, 3]) @ environment[:3, :3], pair.radius
    ):
        far = np.full(len(pair.points), np.inf)
        return np.zeros((len(pair.points), 3)), far, np.zeros((len(pair.points), 3))
    world = pair.points @ frame[:3, :3].T + frame[:3, 3]
    local = (world - environment[:3, 3]) @ environment[:3, :3]
    distance, gradient = pair.grid.sample(local)
    if pair.joined:
        connections = model.connection_points(fwd)
        for joint, reach in pair.joined:
            distance[np.linalg.norm(world - connections[joint], axis=1) < reach] = np.inf
    return world, distance, gradient @ environment[:3, :3].T


def _inside(
    model: Model, fwd: Forward, pairs: tuple[Pair, ...]
) -> Iterator[tuple[int, Pair, Array, Array, Array]]:
    """For each pair with points inside the environment: its index, the pair,
    and those points (world, (n, 3)), their depths (mm, (n,)) and the way out
    (the distance's gradient, world, (n, 3))."""
    for k, pair in enumerate(pairs):
        world, distance, normal = _distances(model, fwd, pair)
        inside = distance < 0.0
        if inside.any():
            yield k, pair, world[inside], -distance[inside], normal[inside]


def _resultant(push: Array, world: Array) -> tuple[Array, Array]:
    """The force (3,) and its moment about the world origin (3,) of the pushes
    (n, 3) at the points `world` (n, 3)."""
    return push.sum(axis=0), np.cross(world, push).sum(axis=0)


def _per_part(model: Model, loads: Iterable[tuple[int, Array, Array]]) -> tuple[Array, Array]:
    """(part, force, moment about the origin) loads summed per part: (P, 3), (P, 3)."""
    forces = np.zeros((len(model.parts), 3))
    moments = np.zeros((len(model.parts), 3))
    for part, force, moment in loads:
        forces[part] += force
        moments[part] += moment
    return forces, moments


def with_contacts(
    model: Model, energy: Callable[[Array], tuple[float, Array]], pairs: tuple[Pair, ...], weight: float
) -> Callable[[Array], tuple[float, Array]]:
    """The energy plus the contacts' springs. weight: the assembly's, joules per mm."""
    if not pairs:
        return energy
    stiffness = weight / CONTACT_GIVE_MM  # joules per mm^2 of penetration

    def total(x: Array) -> tuple[float, Array]:
        value, gradient = energy(x)
        fwd = model.forward(x, with_twists=True)
        loads = []
        for _, pair, world, depth, normal in _inside(model, fwd, pairs):
            spring, slope = penalty(-depth, stiffness)
            value += spring
            # d(spring) / d(point) as a load on the part: its generalised force is the gradient
            loads.append((pair.part, *_resultant(slope[:, None] * normal, world)))
        if not loads:
            return value, gradient
        return value, gradient + model.wrench_gradient(fwd, *_per_part(model, loads))

    return total


def penetration(model: Model, x: Array, pairs: tuple[Pair, ...]) -> tuple[Array, Array]:
    """Per pair, how deep its points are inside the environment: the root of the
    sum of their squared depths (mm; 0 when none is inside: one entry per pair,
    so the length never changes), and its exact derivative by x (pairs x DoFs).
    As residuals for step 1 they cost what each point's depth would, squared."""
    fwd = model.forward(x, with_twists=True)
    assert fwd.twists is not None
    angular = angular_velocities(fwd.twists)
    depths, rows = np.zeros(len(pairs)), np.zeros((len(pairs), len(x)))
    for k, pair, world, depth, normal in _inside(model, fwd, pairs):
        depths[k] = float(np.linalg.norm(depth))
        # d(distance) / dx_j = normal . (w_j x p + v_j), for the DoFs that move the part
        force, moment = depth @ normal, depth @ np.cross(world, normal)
        change = fwd.twists[:, :3, 3] @ force + angular @ moment
        rows[k] = -change * model.layout.moves[:, pair.part] / depths[k]
    return depths, rows


def contacts_at(model: Model, x: Array, pairs: tuple[Pair, ...], weight: float) -> tuple[Contact, ...]:
    """The contacts at x: each pair whose points are inside, with the force the
    environment exerts (N) and where."""
    stiffness = weight / CONTACT_GIVE_MM
    fwd = model.forward(x, with_twists=True)
    found = []
    for _, pair, world, depth, normal in _inside(model, fwd, pairs):
        push = 1000.0 * stiffness * depth[:, None] * normal  # J/mm -> N
        force, moment = _resultant(push, world)
        point = (depth @ world) / depth.sum()
        found.append(Contact(pair.part, pair.environment, force, moment, point, float(depth.max())))
    return tuple(found)


def contact_loads(model: Model, contacts: tuple[Contact, ...]) -> tuple[Array, Array]:
    """(P, 3) N the contacts' forces on each part, and (P, 3) N mm their moments about the world origin."""
    return _per_part(model, ((contact.part, contact.force, contact.moment) for contact in contacts))
