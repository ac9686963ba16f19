"""The shape of the assembly: one target, an environment to hang from, every
part connected, the target reachable from an environment."""

from __future__ import annotations

from fabhal.check.context import CheckContext
from fabhal.diagnostics import Diagnostic, Severity, error, listed, note, warning
from fabhal.source import Span


def check(ctx: CheckContext) -> list[Diagnostic]:
    program, model = ctx.program, ctx.model
    problems: list[Diagnostic] = []
    first_line = Span(program.file, 1, 1, 1, 1)
    if not program.targets:
        problems.append(
            error(
                "E406",
                "the program has no target",
                first_line,
                "say what the hack holds and where: `target mug.hook at (0, 0, 50) rot (0, 0, 0)`",
            )
        )
    for extra in program.targets[1:]:
        problems.append(
            error(
                "E407",
                f"a second target (the first is on line {program.targets[0].span.line})",
                extra.span,
                "a program holds exactly one target; remove one `target` line",
            )
        )
    problems.extend(_target_frame_off_its_part(ctx))
    problems.extend(_written_in_metres(ctx))
    for target in program.targets[:1]:
        if program.part(target.part).environment:
            problems.append(
                error(
                    "E417",
                    f"the target `{target.part}` is an environment: it stays where its `at (...)` puts it",
                    target.span,
                    "target the object the hack holds (a part that moves), e.g. the one at the end of "
                    "the chain; to move the environment, change its `at (...)`",
                )
            )
    if not any(p.environment for p in program.parts):
        problems.append(
            error(
                "E408",
                "the program has no environment to hang from",
                first_line,
                "add one, e.g. `environment rod = Rod(length: 500, radius: 2) at (0, 0, 200) "
                "rot (90, 0, 90)`",
            )
        )
        return problems
    connected = {end.part for c in program.connections for end in (c.a, c.b)}
    target_part = program.targets[0].part if program.targets else None
    unplaced = {model.parts[i].name for i in model.unplaced}
    floating: list[str] = []
    for part in program.parts:
        if part.environment:
            continue
        if part.name not in connected:
            if part.name == target_part:
                problems.append(
                    error(
                        "E410",
                        f"the target `{part.name}` is not connected to anything",
                        part.span,
                        "connect one of its primitives, e.g. "
                        f"`connect {part.name}.{part.spec.primitives[0].name} -- other.primitive`",
                    )
                )
            else:
                problems.append(
                    warning(
                        "W413", f"`{part.name}` is never connected", part.span, "connect it, or remove it"
                    )
                )
        elif part.name in unplaced:
            floating.append(part.name)
    if floating:
        first = program.part(floating[0])
        names = ", ".join(f"`{n}`" for n in floating)
        code, what = ("E410", "the target hangs") if target_part in floating else ("E409", "these parts hang")
        problems.append(
            error(
                code,
                f"{what} from nothing: {names} connect only to each other, not to an environment",
                first.span,
                "connect one of them to an environment (or to a part that is)",
            )
        )
    problems.extend(_only_on_target(ctx, target_part))
    if target_part is not None and target_part not in floating and target_part in connected:
        problems.extend(_apart_from_the_target(ctx, target_part, set(floating)))
    problems.extend(_fixed_without_freedom(ctx))
    return problems


def _apart_from_the_target(ctx: CheckContext, target: str, floating: set[str]) -> list[Diagnostic]:
    """Parts that hang from an environment but are joined to the target only
    through it (a second S-hook on the rod beside the chain): they hold nothing
    toward the target. One note per such group, naming what it hangs from."""
    program = ctx.program
    if program.part(target).environment:  # E417 says what is wrong
        return []
    movable = {p.name for p in program.parts if not p.environment}
    neighbours = _neighbours(ctx)
    beside = {name: neighbours[name] & movable for name in movable}
    hangs_from = {name: neighbours[name] - movable for name in movable}
    held = _reached(target, beside)
    problems: list[Diagnostic] = []
    seen: set[str] = set()
    for part in program.parts:  # in the order written: the note points at a group's first part
        name = part.name
        if (
            name not in movable
            or name in held
            or name in seen
            or name in floating
            or not beside[name] | hangs_from[name]
        ):
            continue
        group = _reached(name, beside)
        seen |= group
        names = [p.name for p in program.parts if p.name in group]
        environments = sorted({e for n in group for e in hangs_from[n]})
        one = len(names) == 1
        hang, they, them = ("hangs", "it", "it") if one else ("hang", "they", "them")
        problems.append(
            note(
                "N419",
                f"{listed(names)} {hang} from {listed(environments)} apart from the target `{target}`: "
                f"{they} {'holds' if one else 'hold'} nothing toward it",
                part.span,
                f"connect {them} to what holds the target, or remove {them} (the target's parts may "
                f"still rest against {them})",
            )
        )
    return problems


def _neighbours(ctx: CheckContext) -> dict[str, set[str]]:
    """Every part (environments too) and the other parts it is connected to."""
    neighbours: dict[str, set[str]] = {part.name: set() for part in ctx.program.parts}
    for c in ctx.program.connections:
        if c.a.part != c.b.part:  # a part connected to itself (E414) is not its own neighbour
            neighbours[c.a.part].add(c.b.part)
            neighbours[c.b.part].add(c.a.part)
    return neighbours


def _reached(start: str, beside: dict[str, set[str]]) -> set[str]:
    """The movable parts joined to `start` without passing through an environment."""
    reached, frontier = {start}, [start]
    while frontier:
        for other in beside[frontier.pop()] - reached:
            reached.add(other)
            frontier.append(other)
    return reached


def _target_frame_off_its_part(ctx: CheckContext) -> list[Diagnostic]:
    """A target on a part's own frame (no primitive) where that frame lies far
    outside the part: where its mesh was modelled, not where the part is."""
    from fabhal.meshes import FRAME_OUTSIDE_SAID_MM, mass_properties  # measures shipped, or cached

    problems = []
    for target in ctx.program.targets[:1]:
        part = ctx.program.part(target.part)
        if target.primitive is not None or part.environment:
            continue
        gap = mass_properties(part.spec).frame_outside_mm
        if gap <= FRAME_OUTSIDE_SAID_MM:
            continue
        primitive = part.spec.primitives[0].name if part.spec.primitives else "primitive"
        problems.append(
            note(
                "N424",
                f"the target places `{part.name}`'s own frame, which lies {gap:.0f} mm outside the "
                f"{part.type_name} (where its mesh was modelled), not a point on it",
                target.span,
                f"target one of its primitives to place the part by it (`target {part.name}.{primitive} at "
                f"...`); `fabhal parts {part.type_name}` shows where its frame and primitives are",
            )
        )
    return problems


# every place a program writes within this of the origin (some not at it) reads as metres
METRES_SAID_MM = 10.0


def _written_in_metres(ctx: CheckContext) -> list[Diagnostic]:
    """W425: the environments' places and the target's all written within
    METRES_SAID_MM of the origin, not all at it: a room is metres across, so
    such a program was written in metres (a ceiling hook at (0, 0, 2) is 2 mm
    above the floor, and a mug asked for at (0, 0, 1.8) hangs under the floor,
    `solved`). Lengths are millimetres."""
    program = ctx.program
    environments = [part.position for part in program.parts if part.environment]
    if not program.targets or not environments:
        return []
    places = [*environments, program.targets[0].position]
    farthest = max(abs(value) for place in places for value in place)
    if not 0.0 < farthest <= METRES_SAID_MM:
        return []
    target = program.targets[0]
    in_mm = ", ".join(f"{value * 1000:g}" for value in target.position)
    return [
        warning(
            "W425",
            f"every place this program writes lies within {farthest:g} mm of the origin: lengths in FabHaL "
            "are millimetres, and these read like metres",
            target.span,
            f"write millimetres: the target at ({in_mm}) if these were metres, and each environment's "
            "`at (...)` likewise",
        )
    ]


def _fixed_without_freedom(ctx: CheckContext) -> list[Diagnostic]:
    """`fixed` holds a connection's DoFs when the hack settles; on a connection
    that is held anyway (a clip's grip) or has no free DoF it changes nothing."""
    problems = []
    for joint in ctx.model.joints:
        connection = joint.connection
        if not connection.fixed:
            continue
        sides = (joint.a.primitive, joint.b.primitive)
        free = [d for p in sides for d in p.dofs]
        reason = None
        if not free:
            reason = "this connection has no degrees of freedom"
        elif any(p.kind == "clip" for p in sides):
            reason = "a clip already holds what it grips"
        if reason is not None:
            problems.append(
                Diagnostic(
                    Severity.NOTE,
                    "N412",
                    f"`fixed` changes nothing here: {reason}",
                    connection.fixed_span or connection.span,
                    "you may remove `fixed`",
                )
            )
    return problems


def _only_on_target(ctx: CheckContext, target: str | None) -> list[Diagnostic]:
    if target is None or ctx.program.part(target).environment:  # E417 says what is wrong
        return []
    problems = []
    neighbours = _neighbours(ctx)
    for part in ctx.program.parts:
        if part.environment or part.name == target:
            continue
        if neighbours[part.name] == {target}:
            problems.append(
                warning(
                    "W411",
                    f"`{part.name}` is connected only to the target `{target}`",
                    part.span,
                    "it adds weight but holds nothing up; connect it toward an environment",
                )
            )
    return problems
