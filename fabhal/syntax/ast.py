"""The FabHaL syntax tree: frozen dataclasses, tuple children, a span on every node.

Class names mirror the grammar's rule names (`connect_stmt` -> `ConnectStmt`).
Nodes compare equal by content *and* span; `strip_spans` gives the span-free
view used to compare a program with its formatted-and-reparsed copy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from fabhal.source import Span

# ---------------------------------------------------------------- expressions


@dataclass(frozen=True)
class Number:
    value: float
    text: str
    span: Span


@dataclass(frozen=True)
class Boolean:
    value: bool
    span: Span


@dataclass(frozen=True)
class Name:
    name: str
    span: Span


@dataclass(frozen=True)
class BinaryOp:
    op: str  # one of + - * /
    left: Expr
    right: Expr
    span: Span


@dataclass(frozen=True)
class Negation:
    operand: Expr
    span: Span


@dataclass(frozen=True)
class FunctionCall:
    function: str
    args: tuple[Expr, ...]
    span: Span


Expr = Number | Boolean | Name | BinaryOp | Negation | FunctionCall

# ---------------------------------------------------------------- shared pieces


@dataclass(frozen=True)
class Vector:
    x: Expr
    y: Expr
    z: Expr
    span: Span


@dataclass(frozen=True)
class Placement:
    """`at (x, y, z) rot (a, b, c)`; either part may be absent (origin / no rotation)."""

    position: Vector | None
    rotation: Vector | None
    span: Span


@dataclass(frozen=True)
class Argument:
    name: str
    value: Expr
    span: Span


@dataclass(frozen=True)
class Call:
    """`Mug()` or `Rod(length: 500, radius: 2)`: a part (or bare primitive) made."""

    callee: str
    args: tuple[Argument, ...]
    span: Span


@dataclass(frozen=True)
class Lvalue:
    """A name, optionally indexed: `s1`, `tb[i]`."""

    name: str
    index: Expr | None
    span: Span


@dataclass(frozen=True)
class Ref:
    """`part`, `part.primitive`, `tb[i].hook1`, or an alias / port name."""

    base: Lvalue
    primitive: str | None
    span: Span


# ---------------------------------------------------------------- statements


@dataclass(frozen=True)
class ImportStmt:
    path: str
    span: Span


@dataclass(frozen=True)
class RangeDomain:
    low: Expr
    high: Expr
    span: Span


@dataclass(frozen=True)
class LinspaceDomain:
    start: Expr
    stop: Expr
    count: Expr
    span: Span


@dataclass(frozen=True)
class ListDomain:
    items: tuple[Expr, ...]
    span: Span


Domain = RangeDomain | LinspaceDomain | ListDomain


@dataclass(frozen=True)
class ParamDecl:
    name: str
    domain: Domain
    default: Expr | None
    span: Span


@dataclass(frozen=True)
class EnvironmentDecl:
    name: Lvalue
    call: Call
    placement: Placement | None
    span: Span


@dataclass(frozen=True)
class InstanceDecl:
    name: Lvalue
    call: Call
    span: Span


@dataclass(frozen=True)
class AliasDecl:
    """`link = r[i].ring`: a name for a primitive (re-assignable, e.g. in loops)."""

    name: Lvalue
    ref: Ref
    span: Span


@dataclass(frozen=True)
class ConnectOption:
    name: str  # "flip", "noflip" or "fixed"
    span: Span


@dataclass(frozen=True)
class DofSetting:
    """`hanger.rod.t: 0.47` in a connection's `set (...)`: a DoF of one side
    (`side`, as that side is written) held at a value."""

    side: Ref
    dof: str
    value: Expr
    span: Span


@dataclass(frozen=True)
class ConnectStmt:
    a: Ref
    b: Ref
    options: tuple[ConnectOption, ...]
    span: Span
    settings: tuple[DofSetting, ...] = ()

    @property
    def flip(self) -> bool:
        return any(o.name == "flip" for o in self.options)

    @property
    def noflip(self) -> bool:
        return any(o.name == "noflip" for o in self.options)

    @property
    def fixed(self) -> bool:
        return any(o.name == "fixed" for o in self.options)


@dataclass(frozen=True)
class TargetStmt:
    ref: Ref
    placement: Placement
    span: Span


@dataclass(frozen=True)
class ForLoop:
    variable: str
    low: Expr
    high: Expr
    body: tuple[Statement, ...]
    span: Span


@dataclass(frozen=True)
class PartParam:
    """A parameter of a part or sub-assembly: `extension: 0 .. 45.7 = 0`."""

    name: str
    low: Expr | None
    high: Expr | None
    default: Expr | None
    span: Span


@dataclass(frozen=True)
class PortDecl:
    name: str
    ref: Ref
    span: Span


@dataclass(frozen=True)
class AssemblyDef:
    name: str
    params: tuple[PartParam, ...]
    description: str | None
    body: tuple[Statement, ...]
    span: Span


@dataclass(frozen=True)
class MeshLine:
    path: str
    span: Span


@dataclass(frozen=True)
class MassLine:
    value: Expr
    span: Span


@dataclass(frozen=True)
class MaterialLine:
    name: str
    span: Span


@dataclass(frozen=True)
class PrimitiveDecl:
    kind: str
    name: str
    args: tuple[Argument, ...]
    placement: Placement | None
    span: Span
    kind_span: Span


@dataclass(frozen=True)
class MaterialDef:
    """`material steel(density: 7.85) "carbon steel wire"`: density in g/cm3."""

    name: str
    args: tuple[Argument, ...]
    description: str | None
    span: Span


PartItem = MeshLine | MassLine | MaterialLine | PrimitiveDecl


@dataclass(frozen=True)
class PartDef:
    name: str
    params: tuple[PartParam, ...]
    description: str | None
    items: tuple[PartItem, ...]
    span: Span


Statement = (
    ImportStmt
    | ParamDecl
    | EnvironmentDecl
    | InstanceDecl
    | AliasDecl
    | ConnectStmt
    | TargetStmt
    | ForLoop
    | PartDef
    | AssemblyDef
    | PortDecl
    | MaterialDef
)


@dataclass(frozen=True)
class Module:
    """One parsed `.fhl` file."""

    file: str
    statements: tuple[Statement, ...]


# ---------------------------------------------------------------- helpers


def strip_spans(node: Any) -> Any:
    """The node with every span (and number spelling) blanked: content-only equality."""
    if isinstance(node, tuple):
        return tuple(strip_spans(child) for child in node)
    if not dataclasses.is_dataclass(node) or isinstance(node, type):
        return node
    changes: dict[str, Any] = {}
    for f in dataclasses.fields(node):
        value = getattr(node, f.name)
        if isinstance(value, Span):
            changes[f.name] = None
        elif f.name == "text" and isinstance(node, Number):
            changes[f.name] = ""
        else:
            changes[f.name] = strip_spans(value)
    return dataclasses.replace(node, **changes)
