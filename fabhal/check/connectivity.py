"""Which primitives may meet: the connectivity table, closed primitives,
single-connection primitives, a part touching itself, a repeated connection."""

from __future__ import annotations

from fabhal.check.context import CheckContext
from fabhal.diagnostics import Diagnostic, error
from fabhal.primitives import CONNECTABLE, Primitive, partners


def _opening(primitive: Primitive) -> bool:
    """Can something closed be threaded onto it (through an open end)?"""
    if primitive.kind in ("rod", "hook"):
        return primitive.flags["threadable"]
    if primitive.kind == "tube":
        return primitive.flags["slide_off"]
    return primitive.kind != "hole"  # a hole (ring) is always closed


# pairs where one side must go around or through the other
_THREADED = {
    frozenset(("hook", "hook")),
    frozenset(("hook", "hole")),
    frozenset(("hook", "rod")),
    frozenset(("hook", "tube")),
    frozenset(("hole", "rod")),
    frozenset(("hole", "tube")),
    frozenset(("rod", "tube")),
    frozenset(("tube", "tube")),
}


def kind_problem(a: Primitive, b: Primitive) -> str | None:
    """Why two primitives can never meet, whatever their sizes: E401 (the
    connectivity table has no such pair), E402 (both closed where one must be
    threaded onto the other); None if they may."""
    if frozenset((a.kind, b.kind)) not in CONNECTABLE:
        return "E401"
    if frozenset((a.kind, b.kind)) in _THREADED and not (_opening(a) or _opening(b)):
        return "E402"
    return None


def check(ctx: CheckContext) -> list[Diagnostic]:
    problems: list[Diagnostic] = []
    seen_pairs: dict[frozenset[tuple[str, str]], int] = {}
    for connection in ctx.program.connections:
        a, b = ctx.primitive(connection.a), ctx.primitive(connection.b)
        pair = frozenset(
            ((connection.a.part, connection.a.primitive), (connection.b.part, connection.b.primitive))
        )
        if connection.a.part == connection.b.part:
            problems.append(
                error(
                    "E414",
                    f"`{connection.a.part}` cannot connect to itself",
                    connection.span,
                    "a part's primitives are already rigidly joined; connect it to another part",
                )
            )
            continue
        if pair in seen_pairs:
            problems.append(
                error(
                    "E415",
                    f"`{connection.a}` and `{connection.b}` are already connected (line {seen_pairs[pair]})",
                    connection.span,
                    "remove the repeated line",
                )
            )
            continue
        seen_pairs[pair] = connection.span.line
        found = kind_problem(a, b)
        if found == "E401":
            problems.append(
                error(
                    "E401",
                    f"{_article(a.kind)} {a.kind} cannot connect to {_article(b.kind)} {b.kind}",
                    connection.span,
                    _partners_help(a.kind, b.kind),
                )
            )
            continue
        if found == "E402":
            problems.append(
                error(
                    "E402",
                    f"{ctx.describe(connection.a)} and {ctx.describe(connection.b)} are both closed: "
                    "neither can be threaded onto the other",
                    connection.span,
                    "one side needs an open end (a hook, an S-hook or a rod with a free end); "
                    "link them through an open part, e.g. an S-hook",
                )
            )
    problems.extend(_single_connections(ctx))
    return problems


def _partners_help(first: str, second: str) -> str:
    lines = [
        f"{_article(kind)} {kind} connects to: {', '.join(partners(kind)) or 'nothing'}"
        for kind in dict.fromkeys((first, second))
    ]
    return "; ".join(lines)


def _article(word: str) -> str:
    return "an" if word[0] in "aeiou" else "a"


def _single_connections(ctx: CheckContext) -> list[Diagnostic]:
    problems = []
    done: set[tuple[str, str]] = set()
    for connection in ctx.program.connections:
        for end in (connection.a, connection.b):
            key = (end.part, end.primitive)
            primitive = ctx.primitive(end)
            if not primitive.single_connection or key in done:
                continue
            done.add(key)
            uses = ctx.connections_on(end)
            for extra in uses[1:]:
                first = uses[0]
                what = (
                    "a clip grips one thing"
                    if primitive.kind == "clip"
                    else "a hemisphere rests on one thing"
                )
                problems.append(
                    error(
                        "E403",
                        f"{ctx.describe(end)} is already connected (line {first.span.line}); {what}",
                        extra.span,
                        "use another part for the second connection",
                    )
                )
    return problems
