"""Lark parse tree -> AST. One short method per grammar rule, named like the rule."""

from __future__ import annotations

import itertools
from typing import Any

from lark import Token, Transformer, v_args
from lark.tree import Meta

from fabhal.source import Span
from fabhal.syntax import ast

# Punctuation and keywords the AST does not need to keep.
_SKIP = {
    "IMPORT", "PARAM", "IN", "LINSPACE", "ENVIRONMENT", "CONNECT", "TARGET", "FOR",
    "ASSEMBLY", "PORT", "PART", "MESH", "MASS", "MATERIAL", "AT", "ROT", "SET",
    "DASHDASH", "DOTDOT", "EQUALS", "COLON", "COMMA", "DOT",
    "LPAR", "RPAR", "LSQB", "RSQB", "LBRACE", "RBRACE",
}  # fmt: skip


def _kept(children: list[Any]) -> list[Any]:
    return [c for c in children if c is not None and not (isinstance(c, Token) and c.type in _SKIP)]


def _string(token: Token) -> str:
    return str(token)[1:-1]


def _of_type(items: list[Any], cls: type) -> list[Any]:
    return [i for i in items if isinstance(i, cls)]


@v_args(meta=True)
class ToAst(Transformer[Token, ast.Module]):
    def __init__(self, file: str):
        super().__init__()
        self.file = file

    def _span(self, meta: Meta) -> Span:
        return Span(self.file, meta.line, meta.column, meta.end_line, meta.end_column)

    def _token_span(self, token: Token) -> Span:
        return Span(
            self.file,
            token.line or 0,
            token.column or 0,
            token.end_line or 0,
            token.end_column or 0,
        )

    # ---- expressions

    def number(self, meta: Meta, children: list[Token]) -> ast.Number:
        (token,) = children
        return ast.Number(float(token), str(token), self._span(meta))

    def boolean(self, meta: Meta, children: list[Token]) -> ast.Boolean:
        (token,) = children
        return ast.Boolean(token.type == "TRUE", self._span(meta))

    def name(self, meta: Meta, children: list[Token]) -> ast.Name:
        (token,) = children
        return ast.Name(str(token), self._span(meta))

    def binary_op(self, meta: Meta, children: list[Any]) -> ast.BinaryOp:
        left, op, right = children
        return ast.BinaryOp(str(op), left, right, self._span(meta))

    def negation(self, meta: Meta, children: list[Any]) -> ast.Negation:
        _minus, operand = children
        return ast.Negation(operand, self._span(meta))

    def atom(self, meta: Meta, children: list[Any]) -> ast.Expr:
        (inner,) = _kept(children)  # `( expr )`: the brackets only group
        return inner

    def function_call(self, meta: Meta, children: list[Any]) -> ast.FunctionCall:
        items = _kept(children)
        return ast.FunctionCall(str(items[0]), tuple(items[1:]), self._span(meta))

    # ---- shared pieces

    def vector(self, meta: Meta, children: list[Any]) -> ast.Vector:
        x, y, z = _kept(children)
        return ast.Vector(x, y, z, self._span(meta))

    def placement(self, meta: Meta, children: list[Any]) -> ast.Placement:
        position: ast.Vector | None = None
        rotation: ast.Vector | None = None
        for previous, child in itertools.pairwise([None, *children]):
            if isinstance(child, ast.Vector):
                if isinstance(previous, Token) and previous.type == "ROT":
                    rotation = child
                else:
                    position = child
        return ast.Placement(position, rotation, self._span(meta))

    def argument(self, meta: Meta, children: list[Any]) -> ast.Argument:
        name, value = _kept(children)
        return ast.Argument(str(name), value, self._span(meta))

    def arguments(self, meta: Meta, children: list[Any]) -> tuple[ast.Argument, ...]:
        return tuple(_of_type(children, ast.Argument))

    def call(self, meta: Meta, children: list[Any]) -> ast.Call:
        items = _kept(children)
        args = items[1] if len(items) > 1 else ()
        return ast.Call(str(items[0]), args, self._span(meta))

    def lvalue(self, meta: Meta, children: list[Any]) -> ast.Lvalue:
        items = _kept(children)
        index = items[1] if len(items) > 1 else None
        return ast.Lvalue(str(items[0]), index, self._span(meta))

    def ref(self, meta: Meta, children: list[Any]) -> ast.Ref:
        items = _kept(children)
        primitive = str(items[1]) if len(items) > 1 else None
        return ast.Ref(items[0], primitive, self._span(meta))

    # ---- statements

    def start(self, meta: Meta, children: list[Any]) -> ast.Module:
        return ast.Module(self.file, tuple(children))

    def import_stmt(self, meta: Meta, children: list[Any]) -> ast.ImportStmt:
        (path,) = _kept(children)
        return ast.ImportStmt(_string(path), self._span(meta))

    def range_domain(self, meta: Meta, children: list[Any]) -> ast.RangeDomain:
        low, high = _kept(children)
        return ast.RangeDomain(low, high, self._span(meta))

    def linspace_domain(self, meta: Meta, children: list[Any]) -> ast.LinspaceDomain:
        start, stop, count = _kept(children)
        return ast.LinspaceDomain(start, stop, count, self._span(meta))

    def list_domain(self, meta: Meta, children: list[Any]) -> ast.ListDomain:
        return ast.ListDomain(tuple(_kept(children)), self._span(meta))

    def param_decl(self, meta: Meta, children: list[Any]) -> ast.ParamDecl:
        items = _kept(children)
        default = items[2] if len(items) > 2 else None
        return ast.ParamDecl(str(items[0]), items[1], default, self._span(meta))

    def environment_decl(self, meta: Meta, children: list[Any]) -> ast.EnvironmentDecl:
        items = _kept(children)
        placement = items[2] if len(items) > 2 else None
        return ast.EnvironmentDecl(items[0], items[1], placement, self._span(meta))

    def instance_decl(self, meta: Meta, children: list[Any]) -> ast.InstanceDecl:
        name, call = _kept(children)
        return ast.InstanceDecl(name, call, self._span(meta))

    def alias_decl(self, meta: Meta, children: list[Any]) -> ast.AliasDecl:
        name, ref = _kept(children)
        return ast.AliasDecl(name, ref, self._span(meta))

    def connect_option(self, meta: Meta, children: list[Token]) -> ast.ConnectOption:
        (token,) = children
        return ast.ConnectOption(str(token), self._span(meta))

    def dof_setting(self, meta: Meta, children: list[Any]) -> ast.DofSetting:
        base, *names, value = _kept(children)
        span = self._span(meta)
        primitive, dof = (str(names[0]), str(names[1])) if len(names) == 2 else (None, str(names[0]))
        return ast.DofSetting(ast.Ref(base, primitive, span), dof, value, span)

    def dof_settings(self, meta: Meta, children: list[Any]) -> tuple[ast.DofSetting, ...]:
        return tuple(_of_type(_kept(children), ast.DofSetting))

    def connect_stmt(self, meta: Meta, children: list[Any]) -> ast.ConnectStmt:
        items = _kept(children)
        options = tuple(_of_type(items, ast.ConnectOption))
        settings = next((item for item in items if isinstance(item, tuple)), ())
        return ast.ConnectStmt(items[0], items[1], options, self._span(meta), settings)

    def target_stmt(self, meta: Meta, children: list[Any]) -> ast.TargetStmt:
        ref, placement = _kept(children)
        return ast.TargetStmt(ref, placement, self._span(meta))

    def for_loop(self, meta: Meta, children: list[Any]) -> ast.ForLoop:
        items = _kept(children)
        variable, low, high, *body = items
        return ast.ForLoop(str(variable), low, high, tuple(body), self._span(meta))

    def part_param(self, meta: Meta, children: list[Any]) -> ast.PartParam:
        # children: NAME, [COLON low DOTDOT high], [EQUALS default]
        name = children[0]
        low = high = default = None
        for previous, child in itertools.pairwise(children):
            if isinstance(previous, Token) and previous.type == "COLON":
                low = child
            elif isinstance(previous, Token) and previous.type == "DOTDOT":
                high = child
            elif isinstance(previous, Token) and previous.type == "EQUALS":
                default = child
        return ast.PartParam(str(name), low, high, default, self._span(meta))

    def _header(self, children: list[Any]) -> tuple[str, tuple[ast.PartParam, ...], str | None, list[Any]]:
        items = _kept(children)
        name = str(items[0])
        params = tuple(_of_type(items, ast.PartParam))
        strings = [i for i in items if isinstance(i, Token) and i.type == "STRING"]
        description = _string(strings[0]) if strings else None
        body = [i for i in items[1:] if not isinstance(i, (Token, ast.PartParam))]
        return name, params, description, body

    def assembly_def(self, meta: Meta, children: list[Any]) -> ast.AssemblyDef:
        name, params, description, body = self._header(children)
        return ast.AssemblyDef(name, params, description, tuple(body), self._span(meta))

    def port_decl(self, meta: Meta, children: list[Any]) -> ast.PortDecl:
        name, ref = _kept(children)
        return ast.PortDecl(str(name), ref, self._span(meta))

    def part_def(self, meta: Meta, children: list[Any]) -> ast.PartDef:
        name, params, description, body = self._header(children)
        return ast.PartDef(name, params, description, tuple(body), self._span(meta))

    def mesh_line(self, meta: Meta, children: list[Any]) -> ast.MeshLine:
        (path,) = _kept(children)
        return ast.MeshLine(_string(path), self._span(meta))

    def mass_line(self, meta: Meta, children: list[Any]) -> ast.MassLine:
        (value,) = _kept(children)
        return ast.MassLine(value, self._span(meta))

    def material_line(self, meta: Meta, children: list[Any]) -> ast.MaterialLine:
        (name,) = _kept(children)
        return ast.MaterialLine(str(name), self._span(meta))

    def material_def(self, meta: Meta, children: list[Any]) -> ast.MaterialDef:
        items = _kept(children)
        args = next((i for i in items if isinstance(i, tuple)), ())
        strings = [i for i in items if isinstance(i, Token) and i.type == "STRING"]
        description = _string(strings[0]) if strings else None
        return ast.MaterialDef(str(items[0]), args, description, self._span(meta))

    def primitive_decl(self, meta: Meta, children: list[Any]) -> ast.PrimitiveDecl:
        items = _kept(children)
        kind, name = items[0], items[1]
        args: tuple[ast.Argument, ...] = ()
        placement = None
        for item in items[2:]:
            if isinstance(item, ast.Placement):
                placement = item
            elif isinstance(item, tuple):
                args = item
        return ast.PrimitiveDecl(
            str(kind), str(name), args, placement, self._span(meta), self._token_span(kind)
        )
