"""What every checking rule sees: the flat program, its model, and helpers to
talk about connections in the user's terms."""

from __future__ import annotations

from dataclasses import dataclass

from fabhal.elaborate import Connection, Endpoint, FlatProgram, PartInstance
from fabhal.library import Library
from fabhal.model import Model
from fabhal.primitives import Primitive


@dataclass(frozen=True)
class CheckContext:
    program: FlatProgram
    model: Model
    library: Library
    seed: int = 0
    deadline: float = float("inf")  # time.monotonic() when a --time-limit ends

    def part(self, name: str) -> PartInstance:
        return self.program.part(name)

    def primitive(self, end: Endpoint) -> Primitive:
        primitive = self.part(end.part).spec.primitive(end.primitive)
        assert primitive is not None  # elaboration resolved it
        return primitive

    def is_environment(self, end: Endpoint) -> bool:
        return self.part(end.part).environment

    def describe(self, end: Endpoint) -> str:
        """`bar.bar` (a bare `Rod(...)` environment) -> "rod `bar`"; `s1.hook2` -> "hook `s1.hook2`"."""
        primitive = self.primitive(end)
        bare = self.part(end.part).spec.type_name == primitive.kind.capitalize()
        return f"{primitive.kind} `{end.part if bare else f'{end.part}.{end.primitive}'}`"

    def connections_on(self, end: Endpoint) -> list[Connection]:
        """Connections touching this primitive, in program order."""
        return [
            c
            for c in self.program.connections
            if (c.a.part, c.a.primitive) == (end.part, end.primitive)
            or (c.b.part, c.b.primitive) == (end.part, end.primitive)
        ]


def other_end(connection: Connection, end: Endpoint) -> Endpoint:
    same = (connection.a.part, connection.a.primitive) == (end.part, end.primitive)
    return connection.b if same else connection.a
