"""A design as a program of its own: the spec's text, then the parts the
design adds and its connections, readable and solvable (`fabhal solve` on it
gives the answer `fabhal design` ranked: the same text, the same solver)."""

from __future__ import annotations

from collections import Counter

from fabhal.design.space import Chain, Design, snake


def design_text(spec_text: str, design: Design, title: str) -> str:
    namer = _Namer()
    parts: list[str] = []
    connections: list[str] = []
    hub_name = namer.name(design.hub[0], parts) if design.hub is not None else None
    if design.below is not None:  # one support, or the hub holding the target
        top = f"{hub_name}.{design.hub[1].name}" if design.hub is not None else design.below.support.written
        _chain(design.anchor, design.below, top, namer, parts, connections)
    if design.branches is not None and design.hub_sides is not None and hub_name is not None:
        for side, chain in zip(design.hub_sides, design.branches, strict=True):
            _chain(f"{hub_name}.{side.name}", chain, chain.support.written, namer, parts, connections)
    if design.branches is not None and design.second_anchor is not None:  # the target hung by itself
        for anchor, chain in zip((design.anchor, design.second_anchor), design.branches, strict=True):
            _chain(anchor, chain, chain.support.written, namer, parts, connections)
    body = "\n".join([f"# {title}", *parts, "", *connections])
    return spec_text.rstrip("\n") + "\n\n" + body + "\n"


def _chain(
    lower: str, chain: Chain, top: str, namer: _Namer, parts: list[str], connections: list[str]
) -> None:
    """Connections from `lower` up through the chain's links to `top`, each held side first."""
    for link in chain.links:
        name = namer.name(link.type_name, parts)
        connections.append(f"connect {lower} -- {name}.{link.down.name}")
        lower = f"{name}.{link.up.name}"
    connections.append(f"connect {lower} -- {top}")


class _Namer:
    """Part names from their types: `double_hook1`, `double_hook2`, `hanger1`."""

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()

    def name(self, type_name: str, parts: list[str]) -> str:
        self.counts[type_name] += 1
        name = f"{snake(type_name)}{self.counts[type_name]}"
        parts.append(f"{name} = {type_name}()")
        return name


def summary(design: Design) -> str:
    """One line: what hangs from what, bottom up (`mug.hook <- DoubleHook <- rod`;
    a hub's sides named: `Hanger(hook2 <- walls.hook1, hook3 <- DoubleHook <- walls.hook2)`)."""
    below = [link.type_name for link in design.below.links] if design.below is not None else []
    if design.second_anchor is not None and design.branches is not None:
        first, second = design.branches
        return " + ".join(
            " <- ".join([anchor, *(link.type_name for link in chain.links), chain.support.written])
            for anchor, chain in ((design.anchor, first), (design.second_anchor, second))
        )
    if design.hub is None or design.branches is None or design.hub_sides is None:
        assert design.below is not None
        return " <- ".join([design.anchor, *below, design.below.support.written])
    sides = ", ".join(
        " <- ".join([side.name, *(link.type_name for link in chain.links), chain.support.written])
        for side, chain in zip(design.hub_sides, design.branches, strict=True)
    )
    return " <- ".join([design.anchor, *below, f"{design.hub[0]}.{design.hub[1].name}({sides})"])
