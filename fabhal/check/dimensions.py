"""Does it fit, and is there room? Openings against what goes through them,
and the length (or area, or arc) each connection uses up on a primitive.

Sizes are compared as diameters or widths, in millimetres, and the messages
quote both numbers.
"""

from __future__ import annotations

import math
from pathlib import Path

from fabhal.check.context import CheckContext, other_end
from fabhal.diagnostics import Diagnostic, Severity, error
from fabhal.elaborate import Endpoint
from fabhal.primitives import LOOPS, Primitive, across, opening

# a flexible wire hook or ring (`flex: true`) can be bent open this much further
FLEX_STRETCH = 0.05


def _loop_word(p: Primitive) -> str:
    return "hook" if p.kind == "hook" else "ring"


def bent_open(a: Primitive, b: Primitive) -> tuple[str, str] | None:
    """(message, help) when a flexible loop fits only once bent open a little."""
    for loop, other in ((a, b), (b, a)):
        if loop.kind in LOOPS and loop.flags.get("flex") and other.kind != "tube":
            needed = across(other)
            if opening(loop) <= needed < opening(loop) * (1 + FLEX_STRETCH):
                return (
                    f"{_loop_word(loop)} opening {opening(loop):g} mm is "
                    f"{needed - opening(loop):.1g} mm narrower than the {other.kind} ({needed:g} mm across)",
                    "a flexible wire hook can be bent open that far",
                )
    return None


def fit_problem(a: Primitive, b: Primitive) -> tuple[str, str] | None:
    """(message, help) when a and b cannot physically meet, else None."""
    kinds = {a.kind, b.kind}
    for loop, other in ((a, b), (b, a)):
        if loop.kind not in LOOPS:
            continue
        if other.kind == "tube" and other.variant == "TubeCtl":
            continue  # threaded through the core: checked as the core's size below
        needed = across(other)
        stretch = 1 + FLEX_STRETCH if loop.flags.get("flex") else 1.0
        if opening(loop) * stretch <= needed:
            what = f"the {other.kind}'s {'wire' if other.kind in LOOPS else 'body'}"
            return (
                f"{_loop_word(loop)} opening {opening(loop):g} mm < {what} {needed:g} mm across",
                f"use a {_loop_word(loop)} with a wider opening, or a thinner {other.kind}",
            )
    for tube, other in ((a, b), (b, a)):
        if tube.kind != "tube" or other.kind not in ("rod", "tube", *LOOPS):
            continue
        core = 2.0 * tube.params["inner_radius"]
        goes_inside = other.kind == "rod" or tube.variant == "TubeCtl"
        if goes_inside and other.kind != "tube" and across(other) >= core:
            return (
                f"the tube's core {core:g} mm < the {other.kind} {across(other):g} mm across",
                "use a thinner rod (or wire), or a tube with a wider core",
            )
    if kinds == {"tube"}:
        inner = [2.0 * p.params["inner_radius"] for p in (a, b)]
        outer = [across(p) for p in (a, b)]
        if not (outer[0] < inner[1] or outer[1] < inner[0]):
            return (
                f"neither tube fits inside the other (outside {outer[0]:g} and {outer[1]:g} mm, "
                f"cores {inner[0]:g} and {inner[1]:g} mm)",
                "one tube must be thinner than the other's core",
            )
    for clip, other in ((a, b), (b, a)):
        if clip.kind == "clip" and other.kind in ("rod", "tube", "edge"):
            gap = clip.params["open_gap"]
            if across(other) >= gap:
                return (
                    f"clip opening {gap:g} mm < the {other.kind} {across(other):g} mm across",
                    "use a clip that opens wider",
                )
    for surface, dome in ((a, b), (b, a)):
        if surface.kind == "surface" and dome.kind == "hemisphere":
            size = min(surface.params["width"], surface.params["length"])
            if size < across(dome):
                return (
                    f"surface {size:g} mm wide < the hemisphere {across(dome):g} mm across",
                    "rest it on a larger surface",
                )
    if kinds == {"surface"}:
        dims = [sorted((p.params["width"], p.params["length"])) for p in (a, b)]
        fits = all(x <= y for x, y in zip(dims[0], dims[1], strict=True)) or all(
            x <= y for x, y in zip(dims[1], dims[0], strict=True)
        )
        if not fits:
            return (
                f"neither surface fits on the other ({dims[0][0]:g} x {dims[0][1]:g} mm and "
                f"{dims[1][0]:g} x {dims[1][1]:g} mm)",
                "the smaller surface must fit within the larger one",
            )
    return None


def _fitting_parts(ctx: CheckContext, part: str, replaced: Primitive, other: Primitive) -> str:
    """Up to three library parts with a primitive of the same kind that would fit `other`."""
    if ctx.part(part).environment:
        return ""
    found = []
    for name, part_type in sorted(ctx.library.parts.items()):
        scenery = Path(part_type.span.file).stem in ("environments", "targets")  # not things to hang with
        if scenery or part_type.parameters or name == ctx.part(part).type_name:
            continue
        spec = ctx.library.instantiate(name, {}, part_type.span)
        for candidate in spec.primitives:
            if candidate.kind == replaced.kind and fit_problem(candidate, other) is None:
                found.append(f"{name}.{candidate.name}")
                break
        if len(found) == 3:
            break
    return ", ".join(f"`{f}`" for f in found)


def room(p: Primitive) -> tuple[float, str] | None:
    """(capacity, unit) of what connections use up on p, or None if unlimited."""
    if p.kind in ("rod", "tube", "edge"):
        return p.params["length"], "mm"
    if p.kind == "surface":
        return p.params["width"] * p.params["length"], "mm2"
    if p.kind == "hook":
        rho = p.params["arc_radius"] - p.params["thickness"]
        return rho * math.radians(p.params["arc_angle"]), "mm"
    if p.kind == "hole":
        return 2.0 * math.pi * (p.params["arc_radius"] - p.params["thickness"]), "mm"
    return None


def usage(host: Primitive, guest: Primitive) -> float:
    """What `guest` takes of `host`'s room."""
    if host.kind in ("rod", "tube", "edge"):
        if guest.kind in LOOPS:
            return 2.0 * guest.params["thickness"]
        if guest.kind == "clip":
            return guest.params["width"]
        if guest.kind == "tube" and host.kind == "rod":
            return guest.params["length"]
        return 0.0
    if host.kind == "surface":
        if guest.kind == "hemisphere":
            return across(guest) ** 2
        guest_area = guest.params["width"] * guest.params["length"] if guest.kind == "surface" else 0.0
        host_area = host.params["width"] * host.params["length"]
        return guest_area if guest_area <= host_area else 0.0  # the larger surface carries the smaller
    return across(guest)  # on a hook or ring: the thickness of what hangs there


def check(ctx: CheckContext) -> list[Diagnostic]:
    problems = []
    for connection in ctx.program.connections:
        a, b = ctx.primitive(connection.a), ctx.primitive(connection.b)
        pair = f"{ctx.describe(connection.a)} and {ctx.describe(connection.b)}"
        found = fit_problem(a, b)
        if found is not None:
            message, help_text = found
            alternatives = _fitting_parts(ctx, connection.a.part, a, b) or _fitting_parts(
                ctx, connection.b.part, b, a
            )
            if alternatives:
                help_text += f"; parts that fit: {alternatives}"
            problems.append(error("E404", f"{pair} do not fit: {message}", connection.span, help_text))
            continue
        tight = bent_open(a, b)
        if tight is not None:
            message, help_text = tight
            problems.append(
                Diagnostic(
                    Severity.NOTE, "N416", f"{pair} fit tightly: {message}", connection.span, help_text
                )
            )
    problems.extend(_room(ctx))
    problems.extend(_written_apart(ctx))
    return problems


def _room(ctx: CheckContext) -> list[Diagnostic]:
    problems = []
    done: set[tuple[str, str]] = set()
    for connection in ctx.program.connections:
        for end in (connection.a, connection.b):
            key = (end.part, end.primitive)
            host = ctx.primitive(end)
            capacity = room(host)
            if key in done or capacity is None:
                continue
            done.add(key)
            problems.extend(_fill(ctx, end, host, capacity))
    return problems


def _written_apart(ctx: CheckContext) -> list[Diagnostic]:
    """Parts whose places on one rod, tube or edge the program writes (`set
    (rod.t: ...)`) must be far enough apart for both: half of what each uses
    of it (`usage`) each way from its place. The solver moves only what the
    program leaves open, so it could not part them."""
    problems = []
    placed: dict[tuple[str, str], list[tuple[float, float, Endpoint]]] = {}  # mm along, half width, guest
    for connection in ctx.program.connections:
        for label, end in (("a", connection.a), ("b", connection.b)):
            host = ctx.primitive(end)
            slide = next((d.name for d in host.dofs if d.critical), None)
            written = next((s for s in connection.settings if (s.side, s.dof) == (label, slide)), None)
            if host.kind not in ("rod", "tube", "edge") or written is None:
                continue
            guest = other_end(connection, end)
            along, half = written.value * host.params["length"], usage(host, ctx.primitive(guest)) / 2.0
            for other_along, other_half, other in placed.get((end.part, end.primitive), []):
                needed = half + other_half
                if other.part != guest.part and abs(along - other_along) < needed - 1e-9:
                    problems.append(
                        error(
                            "E418",
                            f"`{guest}` is written {abs(along - other_along):.3g} mm from `{other}` on "
                            f"{ctx.describe(end)}; they need {needed:.3g} mm",
                            written.span,
                            f"write their places at least {needed / host.params['length']:.3g} apart (t runs "
                            "along the whole primitive), or leave one to the solver",
                        )
                    )
            placed.setdefault((end.part, end.primitive), []).append((along, half, guest))
    return problems


def _fill(ctx: CheckContext, end: Endpoint, host: Primitive, capacity: tuple[float, str]) -> list[Diagnostic]:
    total, unit = capacity
    used = 0.0
    occupants: list[str] = []
    for connection in ctx.connections_on(end):
        guest_end = other_end(connection, end)
        need = usage(host, ctx.primitive(guest_end))
        # one part alone always finds its place (a clip may grip a stub narrower than itself)
        if occupants and used + need > total + 1e-9:
            taken = ", ".join(occupants) if occupants else "nothing yet"
            return [
                error(
                    "E405",
                    f"no room on {ctx.describe(end)}: `{guest_end}` needs {need:g} {unit}, "
                    f"{total - used:g} of its {total:g} {unit} are left",
                    connection.span,
                    f"already taken: {taken}; use a longer (or larger) {host.kind}, or fewer parts on it",
                )
            ]
        used += need
        occupants.append(f"`{guest_end}` {need:g} {unit}")
    return []
