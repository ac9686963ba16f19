"""Can every loop close? First a quick reject by the polygon inequality (a loop
of rigid links closes only if no link is longer than all the others together),
then a closure solve from up to 16 seeded starts.

A part on a loop is a link between the two connectors the loop passes
through; its length can vary only within the range those connectors reach
(sampled over their degrees of freedom, then widened by the sampling's
resolution so that the range contains every length the part can take: a
quick reject must never refuse a loop that closes). All environments are
one rigid link.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from fabhal.check.context import CheckContext
from fabhal.diagnostics import Diagnostic, error, note, warning, written_settings_hint
from fabhal.kinematics.frames import Array, frame_matrix
from fabhal.model import ENVIRONMENT, Joint, Loop, Model, Side
from fabhal.optimize import least_squares_objective, minimize

MAX_STARTS = 16
CLOSED_MM = 1e-6  # a loop counts as closed when every residual is below this (mm, or mm-equivalent)
# a loop the closure solve leaves open by less than this still closes in the real
# objects: a hook on its rod, a ring in a hook, a clip's jaws have at least this
# much play (half a millimetre, or 0.29 degrees: rotation entries count x100 mm).
# Its closing connection takes the gap up (Model.with_play); the check says so
LOOP_PLAY_MM = 0.5
CLOSE_EVALUATIONS = 200  # per start of the closure solve
# when no start closes the loops, the best is continued this many times longer
# before the loop is called impossible: a large model (a hoop on 12 chains, 117
# DoFs) needed more than 200 evaluations from a start that does close it
POLISH_FACTOR = 10
_SLACK_MM = 1e-3  # tolerance on link ranges, as the reference
Samples = tuple[Array, float]  # connector positions and their grid's resolution (mm)


@dataclass(frozen=True)
class Link:
    part: int
    low: float
    high: float
    label: str


@dataclass(frozen=True)
class LoopReport:
    """What the cycle check found: the DoFs that close every loop (or the best try)."""

    x: Array
    closed: bool
    worst_position_mm: float
    worst_angle_deg: float
    starts_tried: int  # fewer than MAX_STARTS when the time limit ended the search
    play_mm: float = 0.0  # the largest residual the loops close with as play (0: exactly)


# ---------------------------------------------------------------- link ranges


def _samples(side: Side) -> Samples:
    """Connector positions of a primitive (in its part frame) over a grid of its
    DoFs, and the grid's resolution: the longest distance between neighbouring
    samples. Every reachable position lies within that distance of a sample (it
    is within half a grid cell of one along each DoF, and a step along a DoF moves
    the connector at most as far as between neighbours: arcs of at most 45
    degrees, whose length exceeds their chord by under 3 %)."""
    axes = []
    for dof in side.primitive.dofs:
        if dof.periodic:
            axes.append(np.linspace(0.0, 360.0, 12, endpoint=False))
        else:
            axes.append(np.linspace(dof.low, dof.high, 7))
    shape = tuple(len(axis) for axis in axes)
    grid = np.array(list(itertools.product(*axes)), dtype=float)
    points = side.primitive.connector_frames(grid)[:, :3, 3].reshape(*shape, 3)
    resolution = 0.0
    for k, dof in enumerate(side.primitive.dofs):
        n = shape[k]
        if dof.periodic:  # the last sample's neighbour is the first
            here, following = points, np.roll(points, -1, axis=k)
        else:
            here, following = points.take(range(n - 1), axis=k), points.take(range(1, n), axis=k)
        if here.size:
            resolution = max(resolution, float(np.linalg.norm(following - here, axis=-1).max()))
    return points.reshape(-1, 3), resolution


def _positions(model: Model, side: Side) -> Samples:
    points, resolution = _samples(side)
    part = model.parts[side.part]
    if part.environment:  # environments are one rigid body: compare in world coordinates
        frame = frame_matrix(part.position, part.rotation)
        points = points @ frame[:3, :3].T + frame[:3, 3]
    return points, resolution


def _distance_range(first: Samples, second: Samples, same: bool) -> tuple[float, float]:
    """The range of distances between the two connectors, widened by both grids' resolution."""
    (a, a_resolution), (b, b_resolution) = first, second
    distances = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1)
    margin = a_resolution + b_resolution
    return (0.0 if same else max(float(distances.min()) - margin, 0.0)), float(distances.max()) + margin


def loop_links(model: Model, loop: Loop) -> list[Link]:
    """Each link's reach: between the connectors where the loop enters and leaves it."""
    links = []
    sides_by_node: dict[int, list[Side]] = {}
    for j in loop.joints:
        joint = model.joints[j]
        for side in (joint.a, joint.b):
            node = model.loop_node(side.part)
            if node in loop.parts:
                sides_by_node.setdefault(node, []).append(side)
    for node in loop.parts:
        entry, exit_ = _entry_exit(sides_by_node.get(node, []))
        if entry is None or exit_ is None:
            continue
        same = entry.part == exit_.part and entry.primitive.name == exit_.primitive.name
        low, high = _cached_range(model, entry, exit_, same)
        name = "the environment" if node == ENVIRONMENT else f"`{model.parts[node].name}`"
        links.append(Link(node, low, high, f"{name} ({entry.primitive.name} to {exit_.primitive.name})"))
    return links


def _entry_exit(sides: list[Side]) -> tuple[Side | None, Side | None]:
    if len(sides) < 2:
        return None, None
    return sides[0], sides[1]


def _cached_range(model: Model, entry: Side, exit_: Side, same: bool) -> tuple[float, float]:
    if model.parts[entry.part].environment or model.parts[exit_.part].environment:
        return _distance_range(_positions(model, entry), _positions(model, exit_), same)
    spec = model.parts[entry.part].spec
    key = (spec.type_name, tuple(sorted(spec.arguments.items())), entry.primitive.name, exit_.primitive.name)
    return _part_range(key, entry, exit_, same)


_RANGES: dict[tuple, tuple[float, float]] = {}  # part type + arguments + primitives -> reach


def _part_range(key: tuple, entry: Side, exit_: Side, same: bool) -> tuple[float, float]:
    if key not in _RANGES:
        _RANGES[key] = _distance_range(_samples(entry), _samples(exit_), same)
    return _RANGES[key]


def polygon_feasible(links: list[Link]) -> bool:
    """The quick reject: can each link take a length e_k in its range with
    e_k <= the sum of the others for every k? Exactly when no link's shortest
    length exceeds the longest the others reach together: take every link at
    its longest; at most one link can then be longer than the rest together,
    and shortening it to their sum (not below its shortest) closes the polygon."""
    if len(links) < 2:
        return True
    total_high = sum(link.high + _SLACK_MM for link in links)
    return all(max(link.low - _SLACK_MM, 0.0) <= total_high - (link.high + _SLACK_MM) for link in links)


# ---------------------------------------------------------------- closure solve


def close_loops(
    model: Model,
    seed: int = 0,
    starts: int = MAX_STARTS,
    x0: Array | None = None,
    evaluations: int = CLOSE_EVALUATIONS,
    deadline: float = np.inf,
    play_mm: float = 0.0,
) -> LoopReport:
    """Find DoFs that close every loop: least squares from `x0` (the defaults),
    then from seeded random starts, each for at most `evaluations`; stops at
    the first start that closes them all, or at `deadline` (time.monotonic()).
    When none closes them exactly, the best counts as closed if it leaves no
    residual above `play_mm` (the check's LOOP_PLAY_MM; the solver's own
    starts must close exactly)."""
    x0 = model.x_default() if x0 is None else x0
    if not model.closures:
        return LoopReport(x0, True, 0.0, 0.0, 0)
    free = np.array(
        sorted(
            {i for loop in model.loops for j in loop.joints for i in _dof_indices(model, j)} - model.pinned
        )
    )
    low, high = model.bounds()
    rng = np.random.default_rng(seed)

    def full(values: Array) -> Array:
        x = x0.copy()
        x[free] = values
        return x

    def residual_and_jacobian(values: Array) -> tuple[Array, Array]:
        x = full(values)
        return model.closure_residuals(x), model.closure_jacobian(x)[:, free]

    def attempt(start: Array, budget: int) -> tuple[Array, float]:
        fit = minimize(
            least_squares_objective(residual_and_jacobian),
            start,
            low[free],
            high[free],
            max_evaluations=budget,
            stop_below=0.5 * (0.01 * CLOSED_MM) ** 2,
            deadline=deadline,
        )
        return fit.x, float(np.abs(residual_and_jacobian(fit.x)[0]).max())

    best, best_cost, tried = x0[free], np.inf, 0
    for k in range(starts):
        if k and time.monotonic() > deadline:
            break
        tried += 1
        values, cost = attempt(x0[free] if k == 0 else _random_start(rng, low[free], high[free]), evaluations)
        if cost < best_cost:
            best, best_cost = values, cost
        if cost < CLOSED_MM:
            break
    if best_cost >= CLOSED_MM and starts > 1 and time.monotonic() <= deadline:
        best, best_cost = min(
            [(best, best_cost), attempt(best, POLISH_FACTOR * evaluations)], key=lambda t: t[1]
        )
    closed = best_cost < max(CLOSED_MM, play_mm)
    return _report(model, full(best), closed, tried, best_cost if closed and best_cost >= CLOSED_MM else 0.0)


def _dof_indices(model: Model, joint: int) -> tuple[int, ...]:
    j = model.joints[joint]
    return j.a.dof_indices + j.b.dof_indices


def _random_start(rng: np.random.Generator, low: Array, high: Array) -> Array:
    lo = np.where(np.isfinite(low), low, 0.0)
    hi = np.where(np.isfinite(high), high, 360.0)
    return rng.uniform(lo, hi)


def _report(model: Model, x: Array, closed: bool, tried: int, play_mm: float = 0.0) -> LoopReport:
    errors = model.closure_errors(x)
    position = float(np.linalg.norm(errors[:, :3, 3], axis=1).max())
    cosines = np.clip((np.trace(errors[:, :3, :3], axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return LoopReport(x, closed, position, float(np.degrees(np.arccos(cosines)).max()), tried, play_mm)


# ---------------------------------------------------------------- the rule


def check(ctx: CheckContext) -> tuple[list[Diagnostic], LoopReport | None]:
    model = ctx.model
    loops = model.loops
    problems = []
    for loop in loops:
        links = loop_links(model, loop)
        if not polygon_feasible(links):
            problems.append(_too_long(ctx, loop, links))
    if problems or not loops:
        return problems, None
    report = close_loops(model, ctx.seed, deadline=ctx.deadline, play_mm=LOOP_PLAY_MM)
    if report.closed and report.play_mm:
        problems.append(_closed_with_play(ctx, loops[0], report))
    if not report.closed:
        loop = loops[0]
        joint = _written_last(model, loop)
        if time.monotonic() > ctx.deadline:  # not shown to be impossible: out of time
            problems.append(
                warning(
                    "W502",
                    f"stopped at the time limit before this loop was closed ({report.starts_tried} of "
                    f"{MAX_STARTS} starts tried): {_loop_text(ctx, loop)}",
                    joint.connection.span,
                    "allow more time with --time-limit",
                )
            )
            return problems, report
        problems.append(
            error(
                "E421",
                f"this connection closes a loop that cannot close: {_loop_text(ctx, loop)}",
                joint.connection.span,
                f"the best of {MAX_STARTS} tries, continued {POLISH_FACTOR} times longer, leaves a gap of "
                f"{report.worst_position_mm:.1f} mm and "
                f"{report.worst_angle_deg:.1f} degrees; try `flip` on a connection of the loop, "
                f"or parts of other lengths{written_settings_hint(model.lines_setting(loop.joints))}",
            )
        )
    return problems, report


def _closed_with_play(ctx: CheckContext, loop: Loop, report: LoopReport) -> Diagnostic:
    return note(
        "N422",
        f"this connection closes its loop only with {_gap_text(report)} of play: {_loop_text(ctx, loop)}",
        _written_last(ctx.model, loop).connection.span,
        f"the parts around the loop fit together exactly only at other dimensions; up to {LOOP_PLAY_MM} mm "
        "(a hook's or a clip's play) the real objects still go together, and the solver takes the gap up "
        "at this connection",
    )


def _gap_text(report: LoopReport) -> str:
    """The gap as a builder reads it: micrometres below a tenth of a millimetre."""
    position = report.worst_position_mm
    length = f"{1000 * position:.2g} micrometres" if position < 0.1 else f"{position:.2f} mm"
    return f"{length} and {report.worst_angle_deg:.2g} degrees"


def _written_last(model: Model, loop: Loop) -> Joint:
    """The loop's connection the user wrote last: the one that reads as closing
    it (the model's own closing joint follows a canonical order, not the text's)."""
    written = {id(c): i for i, c in enumerate(model.program.connections)}
    return max((model.joints[j] for j in loop.joints), key=lambda joint: written[id(joint.connection)])


def _loop_text(ctx: CheckContext, loop: Loop) -> str:
    """The loop's parts in order, starting from the environment when it is on the loop."""
    names = ["environment" if n == ENVIRONMENT else ctx.model.parts[n].name for n in loop.parts]
    if "environment" in names:
        start = names.index("environment")
        names = names[start:] + names[:start]
    return " -> ".join([*names, names[0]])


def _too_long(ctx: CheckContext, loop: Loop, links: list[Link]) -> Diagnostic:
    total_high = sum(link.high for link in links)
    longest = max(links, key=lambda link: link.low - (total_high - link.high))
    rest = total_high - longest.high
    joint = _written_last(ctx.model, loop)
    return error(
        "E420",
        f"this connection closes a loop whose parts are too short: {_loop_text(ctx, loop)}",
        joint.connection.span,
        f"{longest.label} spans at least {longest.low:.1f} mm, but the rest of the loop reaches "
        f"at most {rest:.1f} mm; add parts (or longer ones) to the loop",
    )
