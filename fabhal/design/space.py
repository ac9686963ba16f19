"""The designs an inventory allows: chains that hang the target from one support,
and two-point hangs (a hub part, or the target itself, hung from two supports,
or from one rod at two places, by two chains). Each connection is tried
against the checker's own rules before it is kept (connectivity table and
closed primitives: E401, E402; sizes: E404), the inventory bounds how many of
each part a design may use, and a two-point hang whose two chains and hub
cannot span the distance between its supports is dropped (the loop's triangle
inequality, as E420). Every design carries an estimate of how far from the
request it would hang (chains hang straight down), by which the most promising
are solved first."""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from fabhal.check.connectivity import kind_problem
from fabhal.check.dimensions import fit_problem
from fabhal.elaborate import FlatProgram, PartInstance
from fabhal.kinematics.frames import frame_matrix
from fabhal.library import BARE_PRIMITIVES, Library
from fabhal.primitives import Primitive

REACH_SLACK_MM = 40.0  # hooks' and rings' own size beyond their connection points


@dataclass(frozen=True)
class Point:
    """A primitive of the spec a chain may end on: a support or the target."""

    written: str  # as a connection names it: `walls.hook1`, or `rod` for a bare primitive
    primitive: Primitive
    position: tuple[float, float, float]  # world, mm (where the part was placed)


@dataclass(frozen=True)
class Link:
    """An inventory part in a chain: held by its `up` primitive, holding by `down`."""

    type_name: str
    up: Primitive
    down: Primitive
    drop: float  # mm from `up`'s centre to `down`'s in the part's frame


@dataclass(frozen=True)
class Chain:
    """Links from a lower primitive up to a support (the first link holds the lower end)."""

    links: tuple[Link, ...]
    support: Point
    length: float  # mm from the lower primitive's centre to the support's, hanging straight


@dataclass(frozen=True)
class Design:
    """One way to hang the target: a chain, or a hub hung by two chains."""

    anchor: str  # the target's primitive that hangs (chains) or the hub's (two-point)
    below: Chain | None  # one support: the chain; two: the chain from the target up to the hub
    hub: tuple[str, Primitive] | None = (
        None  # two-point: the hub's part type and the primitive holding the target
    )
    hub_sides: tuple[Primitive, Primitive] | None = None  # two-point: the hub's primitives the branches hold
    branches: tuple[Chain, Chain] | None = None
    estimate: float = math.inf  # mm: where chains hanging straight down would leave the target
    short: bool = False  # too short to reach: solved only if no design can (to say how near it gets)
    # two-point without a hub: the target's own second primitive the second branch holds
    # (`anchor` holds the first; the same one where it takes two, a basket's handle)
    second_anchor: str | None = None

    @property
    def parts(self) -> Counter[str]:
        used = Counter(link.type_name for chain in self.chains() for link in chain.links)
        if self.hub is not None:
            used[self.hub[0]] += 1
        return used

    def chains(self) -> Iterator[Chain]:
        if self.below is not None:
            yield self.below
        if self.branches is not None:
            yield from self.branches


@dataclass
class Pruned:
    """How many partial designs each rule dropped."""

    counts: Counter[str] = field(default_factory=Counter)

    def add(self, rule: str) -> None:
        self.counts[rule] += 1


RULES = {
    "E401": "the connectivity table (E401)",
    "E402": "both sides closed (E402)",
    "E404": "sizes that do not fit (E404)",
    "reach": "being too short to reach the target",
    "E420": "two chains that cannot span their supports (E420)",
}


def fits(lower: Primitive, upper: Primitive) -> str | None:
    """The first rule that forbids connecting these two primitives, or None."""
    return kind_problem(lower, upper) or ("E404" if fit_problem(lower, upper) is not None else None)


def supports(flat: FlatProgram) -> list[Point]:
    return [point for part in flat.parts if part.environment for point in _points(part)]


def anchors(flat: FlatProgram) -> list[Point]:
    """Where a design may start: the free primitives (nothing in the spec
    connects them yet) of the target and of the parts the spec already
    connects to it (a spec may bring part of the hack: the target in a basket)."""
    used = {(e.part, e.primitive) for c in flat.connections for e in (c.a, c.b)}
    group = _connected(flat, flat.targets[0].part)
    return [
        point
        for part in flat.parts
        if part.name in group
        for point in _points(part)
        if (part.name, point.primitive.name) not in used
    ]


def _connected(flat: FlatProgram, start: str) -> set[str]:
    """The movable parts joined to `start` by the spec's connections."""
    movable = {p.name for p in flat.parts if not p.environment}
    group, frontier = {start}, [start]
    while frontier:
        name = frontier.pop()
        for c in flat.connections:
            for here, there in ((c.a.part, c.b.part), (c.b.part, c.a.part)):
                if here == name and there in movable and there not in group:
                    group.add(there)
                    frontier.append(there)
    return group


def _points(part: PartInstance) -> list[Point]:
    frame = frame_matrix(part.position, part.rotation)
    bare = part.type_name in BARE_PRIMITIVES
    points = []
    for primitive in part.spec.primitives:
        position = frame @ np.append(np.array(primitive.position, dtype=float), 1.0)
        written = part.name if bare else f"{part.name}.{primitive.name}"
        points.append(Point(written, primitive, (float(position[0]), float(position[1]), float(position[2]))))
    return points


def links(library: Library, inventory: Mapping[str, int]) -> list[Link]:
    """Every way each owned part can sit in a chain: held by one primitive, holding
    by another (by the same one only for a ring or a rod, which take several)."""
    found = []
    for type_name, count in sorted(inventory.items()):
        if count <= 0:
            continue
        part_type = library.parts[type_name]
        primitives = library.instantiate(type_name, {}, part_type.span).primitives
        for up in primitives:
            for down in primitives:
                shared = up is down and up.kind in ("hole", "rod") and not up.single_connection
                if up is not down or shared:
                    found.append(Link(type_name, up, down, abs(float(up.position[2] - down.position[2]))))
    return found


def hold(lower: Primitive, upper: Primitive) -> float:
    """How far below `upper`'s centre `lower`'s hangs when one holds the other:
    two arcs (hooks, rings) interlock, their radii add; a rod lies inside the
    arc that holds it (or holds one), its radius takes away."""
    return _radius(lower) + _radius(upper)


def _radius(primitive: Primitive) -> float:
    p = primitive.params
    if primitive.kind in ("hook", "hole"):
        return float(p.get("arc_radius", 0.0))
    if primitive.kind == "rod":
        return -float(p.get("radius", 0.0))
    if primitive.kind == "tube":
        return float(p.get("inner_radius", 0.0))
    return 0.0


def chains(
    lower: Primitive,
    tops: list[Point],
    options: list[Link],
    owned: Mapping[str, int],
    max_parts: int,
    pruned: Pruned,
    used: Counter[str] | None = None,
) -> Iterator[Chain]:
    """Every chain from `lower` up to one of `tops` with at most `max_parts` parts
    (counted with `used`) of those `owned`, each connection allowed by `fits`."""
    used = used or Counter()
    for top in tops:
        rule = fits(lower, top.primitive)
        if rule is None:
            yield Chain((), top, hold(lower, top.primitive))
        else:
            pruned.add(rule)
    if max_parts <= 0:
        return
    for link in options:
        if used[link.type_name] >= owned.get(link.type_name, 0):
            continue
        rule = fits(lower, link.down)
        if rule is not None:
            pruned.add(rule)
            continue
        used[link.type_name] += 1
        for rest in chains(link.up, tops, options, owned, max_parts - 1, pruned, used):
            yield Chain((link, *rest.links), rest.support, hold(lower, link.down) + link.drop + rest.length)
        used[link.type_name] -= 1


def one_point(
    target: Point, below: float | None, goal: np.ndarray, tops: list[Point], options: list[Link],
    owned: Mapping[str, int], max_parts: int, pruned: Pruned,
) -> Iterator[Design]:  # fmt: skip
    """Chains from the target's `target` primitive up to a support, each with its
    estimate; `below`: how far under that primitive the requested frame is (None:
    unknown, taken as 0 for the estimate and never called too short).
    Chains too short to reach are marked `short` (and counted), not dropped:
    when nothing reaches, the nearest of them says how far the inventory falls short."""
    for chain in chains(target.primitive, tops, options, owned, max_parts, pruned):
        hangs = np.array(chain.support.position) - np.array([0.0, 0.0, chain.length + (below or 0.0)])
        short = _too_short(chain, below, goal)
        if short:
            pruned.add("reach")
        yield Design(target.written, chain, estimate=float(np.linalg.norm(hangs - goal)), short=short)


def _too_short(chain: Chain, below: float | None, goal: np.ndarray) -> bool:
    """Hanging straight from its support, the chain (and the target `below` its
    end) cannot reach down to the request; never said where `below` is unknown
    (None: a part that holds the target, not standing on it)."""
    if below is None:
        return False
    distance = float(np.linalg.norm(np.subtract(chain.support.position, goal)))
    return distance > chain.length + below + REACH_SLACK_MM


def _cannot_span(first: Chain, second: Chain, between: float) -> bool:
    """The loop through two supports cannot close: its two chains and the part
    holding both (`between` mm across) are shorter than the supports are apart
    (the triangle inequality, as the checker's E420)."""
    span = float(np.linalg.norm(np.subtract(first.support.position, second.support.position)))
    return span > first.length + second.length + between + REACH_SLACK_MM


def two_point(
    target: Point, below: float | None, goal: np.ndarray, tops: list[Point], options: list[Link],
    owned: Mapping[str, int], max_parts: int, pruned: Pruned,
) -> Iterator[Design]:  # fmt: skip
    """A hub (an owned part with three primitives or more) under two supports,
    holding the target by a third; the loop through the two supports closes
    only if the chains and the hub span them (triangle inequality)."""
    seen: set[tuple[object, ...]] = set()
    for type_name in sorted({link.type_name for link in options}):
        primitives = _primitives_of(options, type_name)
        if len(primitives) < 3:
            continue
        for holding in primitives:
            used = Counter({type_name: 1})
            hub_point = Point("", holding, (0.0, 0.0, 0.0))
            for down in chains(target.primitive, [hub_point], options, owned, max_parts - 1, pruned, used):
                left = max_parts - 1 - len(down.links)
                used_below = used + Counter(link.type_name for link in down.links)
                sides = [p for p in primitives if p is not holding]
                for side_a in sides:
                    for side_b in sides:
                        if side_a is not side_b:
                            yield from _branches(
                                goal, below, tops, options, owned, pruned, (type_name, holding), down,
                                (side_a, side_b), left, used_below, seen, target.written,
                            )  # fmt: skip


def held_two_point(
    targets: list[Point], below: Mapping[str, float | None], goal: np.ndarray, tops: list[Point],
    options: list[Link], owned: Mapping[str, int], max_parts: int, pruned: Pruned,
) -> Iterator[Design]:  # fmt: skip
    """The target hung from two points by itself: a chain from each of two of its
    primitives (or twice from one that takes two, a handle) up to a support
    (two supports, or one rod with room for both). The loop closes only if the
    chains and the target's span between its primitives reach across."""
    seen: set[frozenset[tuple[str, tuple[object, ...]]]] = set()
    for i, first_anchor in enumerate(targets):
        for second_anchor in targets[i:]:
            shared = first_anchor is second_anchor
            if shared and (
                first_anchor.primitive.kind not in ("rod", "hook") or first_anchor.primitive.single_connection
            ):
                continue
            for first in chains(first_anchor.primitive, tops, options, owned, max_parts, pruned):
                used = Counter(link.type_name for link in first.links)
                left = max_parts - len(first.links)
                for second in chains(
                    second_anchor.primitive, tops, options, owned, left, pruned, Counter(used)
                ):
                    same_support = second.support.written == first.support.written
                    if same_support and second.support.primitive.kind != "rod":
                        continue  # two chains on one point are one chain; along a rod they are two
                    if shared and same_support:
                        continue
                    if any(
                        _too_short(c, below[a.written], goal)
                        for a, c in ((first_anchor, first), (second_anchor, second))
                    ):
                        pruned.add("reach")  # each branch must reach down to where the target is wanted
                        continue
                    held = float(np.linalg.norm(np.subtract(first_anchor.position, second_anchor.position)))
                    if _cannot_span(first, second, held):
                        pruned.add("E420")
                        continue
                    key = frozenset(
                        {
                            (first_anchor.written, _chain_key(first)),
                            (second_anchor.written, _chain_key(second)),
                        }
                    )
                    if key in seen:
                        continue
                    seen.add(key)
                    tops_z = [c.support.position[2] - c.length for c in (first, second)]
                    centre = np.mean([c.support.position for c in (first, second)], axis=0)
                    z = float(np.mean(tops_z)) - float(
                        np.mean([below[a.written] or 0.0 for a in (first_anchor, second_anchor)])
                    )
                    estimate = float(np.linalg.norm(np.array([centre[0], centre[1], z]) - goal))
                    yield Design(first_anchor.written, None, branches=(first, second),
                                 second_anchor=second_anchor.written, estimate=estimate)  # fmt: skip


def _branches(
    goal: np.ndarray, below: float | None, tops: list[Point], options: list[Link], owned: Mapping[str, int],
    pruned: Pruned, hub: tuple[str, Primitive], down: Chain, sides: tuple[Primitive, Primitive], left: int,
    used: Counter[str], seen: set[tuple[object, ...]], anchor: str,
) -> Iterator[Design]:  # fmt: skip
    side_a, side_b = sides
    for first in chains(side_a, tops, options, owned, left, pruned, Counter(used)):
        used_first = used + Counter(link.type_name for link in first.links)
        for second in chains(
            side_b, tops, options, owned, left - len(first.links), pruned, Counter(used_first)
        ):
            if second.support.written == first.support.written:
                continue  # two points, not one
            hub_span = float(np.linalg.norm(np.subtract(side_a.position, side_b.position)))
            if _cannot_span(first, second, hub_span):
                pruned.add("E420")
                continue
            branches = {(_shape(side_a), _chain_key(first)), (_shape(side_b), _chain_key(second))}
            signature = (hub[0], id(hub[1]), _chain_key(down), frozenset(branches))
            if signature in seen:
                continue  # the same design with identical parts swapped
            seen.add(signature)
            estimate = _two_point_estimate(goal, below, hub[1], down, (first, second), (side_a, side_b))
            yield Design(anchor, down, hub, (side_a, side_b), (first, second), estimate)


def _two_point_estimate(
    goal: np.ndarray, below: float | None, holding: Primitive, down: Chain, branches: tuple[Chain, Chain],
    sides: tuple[Primitive, Primitive],
) -> float:  # fmt: skip
    """Where the target would hang: the hub level midway between the supports,
    each branch slanting in from its support to the hub's side (its height the
    rest of its length), the hub's holding primitive swung below its sides, the
    chain below and the target straight down from there."""
    tops = [np.array(chain.support.position) for chain in branches]
    span = float(np.linalg.norm(tops[1][:2] - tops[0][:2]))
    hub_span = float(np.linalg.norm(np.subtract(sides[0].position, sides[1].position)))
    slant = max(0.0, (span - hub_span) / 2)
    drops = [math.sqrt(max(chain.length**2 - slant**2, 0.0)) for chain in branches]
    heights = [top[2] - drop for top, drop in zip(tops, drops, strict=True)]
    middle = np.mean(np.array([s.position for s in sides], dtype=float), axis=0)
    swing = float(np.linalg.norm(np.asarray(holding.position, dtype=float) - middle))
    # unequal branches tilt the hub: what it holds swings towards the lower side
    tilt = math.asin(float(np.clip((heights[0] - heights[1]) / max(hub_span, 1.0), -1.0, 1.0)))
    along = (tops[1] - tops[0]) / max(float(np.linalg.norm(tops[1] - tops[0])), 1e-9)
    centre = np.mean(tops, axis=0) + along * swing * math.sin(tilt)
    z = float(np.mean(heights)) - swing * math.cos(tilt) - down.length - (below or 0.0)
    return float(np.linalg.norm(np.array([centre[0], centre[1], z]) - goal))


def _primitives_of(options: list[Link], type_name: str) -> list[Primitive]:
    found: list[Primitive] = []
    for link in options:
        if link.type_name == type_name and all(link.up is not p for p in found):
            found.append(link.up)
    return found


def _shape(primitive: Primitive) -> tuple[object, ...]:
    return (primitive.kind, tuple(sorted(primitive.params.items())))


def _chain_key(chain: Chain) -> tuple[object, ...]:
    return (
        *tuple((link.type_name, id(link.up), id(link.down)) for link in chain.links),
        chain.support.written,
    )


def snake(type_name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", type_name).lower()
