"""The parser: what it builds, where it says things are, and round-trips."""

from __future__ import annotations

from pathlib import Path

import pytest
from lark import Lark

from fabhal import resources
from fabhal.source import SourceFile, Span
from fabhal.syntax import ast
from fabhal.syntax.format import format_module
from fabhal.syntax.parser import parse_source, parse_text
from tests.conftest import all_fhl_files

MUG = """\
# a comment line
environment rod = Rod(length: 500, radius: 2) at (0, 0, 200) rot (90, 0, 90)
s1 = DoubleHook()   # trailing comment
connect s1.hook2 -- rod flip fixed
target s1.hook1 at (0, 0, 50)
"""


def test_statements_and_their_spans() -> None:
    module = parse_text(MUG, "mug.fhl")
    env, inst, conn, target = module.statements
    assert isinstance(env, ast.EnvironmentDecl)
    line = MUG.splitlines()[1]
    assert env.span == Span("mug.fhl", 2, 1, 2, len(line) + 1)  # end column is exclusive
    assert env.call.callee == "Rod"
    assert [(a.name, a.value.value) for a in env.call.args] == [("length", 500.0), ("radius", 2.0)]
    assert env.call.args[1].span == Span("mug.fhl", 2, 36, 2, 45)
    assert isinstance(inst, ast.InstanceDecl) and inst.name.name == "s1"
    assert inst.span == Span("mug.fhl", 3, 1, 3, 18)  # the comment is not part of it
    assert isinstance(conn, ast.ConnectStmt)
    assert (conn.a.base.name, conn.a.primitive, conn.b.base.name, conn.b.primitive) == (
        "s1",
        "hook2",
        "rod",
        None,
    )
    assert conn.flip and conn.fixed
    assert conn.options[0].span == Span("mug.fhl", 4, 25, 4, 29)
    assert isinstance(target, ast.TargetStmt)
    assert target.placement.rotation is None
    assert target.placement.position is not None


def test_arguments_may_span_lines() -> None:
    module = parse_text("s = Rod(\n  length: 500,   # mm\n  radius: 2,\n)\n")
    (inst,) = module.statements
    assert isinstance(inst, ast.InstanceDecl)
    assert inst.span.line == 1 and inst.span.end_line == 4


def test_expressions_keep_precedence() -> None:
    module = parse_text("part P(e: 0 .. 10 = 2) {\n  rod r(length: 40 + e / 2 * 3, radius: -(1 - e))\n}\n")
    (part,) = module.statements
    assert isinstance(part, ast.PartDef)
    (prim,) = part.items
    assert isinstance(prim, ast.PrimitiveDecl)
    length = prim.args[0].value
    assert isinstance(length, ast.BinaryOp) and length.op == "+"
    assert isinstance(length.right, ast.BinaryOp) and length.right.op == "*"
    radius = prim.args[1].value
    assert isinstance(radius, ast.Negation)


def test_a_range_is_not_read_as_a_decimal_number() -> None:
    (param,) = parse_text("param n in 1..4 = 2\n").statements
    assert isinstance(param, ast.ParamDecl) and isinstance(param.domain, ast.RangeDomain)
    assert (param.domain.low.value, param.domain.high.value) == (1.0, 4.0)


def test_keywords_need_a_word_boundary() -> None:
    # `attach` is a name, not the keyword `at` followed by `tach`
    (alias,) = parse_text("attach = fliped.hook\n").statements
    assert isinstance(alias, ast.AliasDecl) and alias.ref.base.name == "fliped"


def test_family_constructs() -> None:
    text = """\
param n in 1 .. 4 = 3
param ext in linspace(0, 45.7, 20)
param Ring in [RingXS, RingS]
link = ceiling.hook
for i in 1 .. n {
  tb[i] = Turnbuckle(extension: ext)
  connect tb[i].hook1 -- link
  link = tb[i].hook2
}
assembly Chain(n = 2) "S-hooks in a row" {
  port top = s[1].hook2
}
"""
    module = parse_text(text)
    kinds = [type(s).__name__ for s in module.statements]
    assert kinds == ["ParamDecl", "ParamDecl", "ParamDecl", "AliasDecl", "ForLoop", "AssemblyDef"]
    loop = module.statements[4]
    assert isinstance(loop, ast.ForLoop) and len(loop.body) == 3
    first = loop.body[0]
    assert isinstance(first, ast.InstanceDecl) and isinstance(first.name.index, ast.Name)


def test_grammar_is_conflict_free_under_strict_mode() -> None:
    # strict=True turns shift/reduce conflicts and terminal collisions into errors;
    # built here without the cache, so the check really runs
    Lark.open(str(resources.grammar_path()), parser="lalr", lexer="contextual", strict=True)


FHL_FILES = all_fhl_files()


@pytest.mark.parametrize("path", FHL_FILES, ids=[p.name for p in FHL_FILES])
def test_every_repository_file_round_trips(path: Path) -> None:
    module = parse_source(SourceFile(path.name, path.read_text()))
    again = parse_text(format_module(module), path.name)
    assert ast.strip_spans(again) == ast.strip_spans(module)


def test_the_repository_has_fhl_files_to_round_trip() -> None:
    assert any(p.parent.name == "programs" for p in FHL_FILES)


def test_parenthesised_expressions_group() -> None:
    (inst,) = parse_text("s = Rod(length: (1 + 2) * 3, radius: -(-2))\n").statements
    assert isinstance(inst, ast.InstanceDecl)
    length, radius = (a.value for a in inst.call.args)
    assert isinstance(length, ast.BinaryOp) and isinstance(length.left, ast.BinaryOp)
    assert isinstance(radius, ast.Negation) and isinstance(radius.operand, ast.Negation)


def test_parser_tables_are_cached_in_the_user_cache_dir(tmp_path: Path) -> None:
    import subprocess
    import sys

    env = {"XDG_CACHE_HOME": str(tmp_path), "PATH": "/usr/bin:/bin"}
    code = "from fabhal.syntax.parser import parse_text; parse_text('s = X()\\n')"
    for _ in range(2):  # the first run writes the cache, the second reads it
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
    cached = list((tmp_path / "fabhal").glob("*.lark-cache"))
    assert len(cached) == 1
    package_dir = Path(resources.grammar_path()).parent.parent / "fabhal"
    assert not list(package_dir.rglob("*.lark-cache"))


def test_noflip_pins_the_default_alignment() -> None:
    """`noflip` is a connection option like `flip` (a keyword: `noflipped` stays a name)."""
    (connect,) = parse_text("connect s1.hook2 -- rod noflip fixed\n").statements
    assert isinstance(connect, ast.ConnectStmt)
    assert connect.noflip and connect.fixed and not connect.flip
    assert connect.options[0].span == Span("<string>", 1, 25, 1, 31)
    (alias,) = parse_text("attach = noflipped.hook\n").statements
    assert isinstance(alias, ast.AliasDecl) and alias.ref.base.name == "noflipped"
