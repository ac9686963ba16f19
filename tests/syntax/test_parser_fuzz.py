"""Property tests: whatever the text, the parser returns an AST or raises
FabhalError with located diagnostics; nothing else escapes."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fabhal.diagnostics import FabhalError
from fabhal.syntax import ast
from fabhal.syntax.format import format_module
from fabhal.syntax.parser import MAX_SYNTAX_ERRORS, parse_text
from tests.conftest import REPO

VALID = (
    (REPO / "programs" / "mug_hanger.fhl").read_text()
    + """
param n in 1 .. 4 = 2
part Peg(len: 10 .. 90 = 60) "a peg" {
  mesh "meshes/peg.obj"
  material wood
  rod rod(radius: 4, length: len * 2 - 1) at (0, 0, len / 2) rot (0, 90, 0)
}
for i in 1 .. n {
  p[i] = Peg(len: 20 + i)
}
connect p[1].rod -- s3.hook2 fixed set (p[1].rod.t: 1 / 3, s3.hook2.theta: 90)
"""
)

# fragments users type, to splice into valid programs
TOKENS = [
    "connect", "--", "-", "=", "(", ")", "[", "]", "{", "}", ".", "..", ",", ":", "#", '"',
    "at", "rot", "flip", "noflip", "fixed", "set", "part", "for", "in", "\n", " ", "s1", "0", "1.5", ";", "@",
]  # fmt: skip


def parse_or_diagnose(text: str) -> None:
    lines = text.count("\n") + 2
    try:
        module = parse_text(text, "fuzz.fhl")
    except FabhalError as exc:
        assert 0 < len(exc.diagnostics) <= MAX_SYNTAX_ERRORS
        for d in exc.diagnostics:
            assert d.code.startswith("E") and d.message
            assert d.span is not None and 1 <= d.span.line <= lines
            assert d.span.column >= 1
        return
    # what parses must also survive formatting
    assert ast.strip_spans(parse_text(format_module(module), "fuzz.fhl")) == ast.strip_spans(module)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=200))
def test_arbitrary_text(text: str) -> None:
    parse_or_diagnose(text)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(TOKENS), max_size=40))
def test_token_soup(tokens: list[str]) -> None:
    parse_or_diagnose(" ".join(tokens))


@st.composite
def mutated_program(draw: st.DrawFn) -> str:
    text = VALID
    for _ in range(draw(st.integers(1, 4))):
        pos = draw(st.integers(0, len(text)))
        action = draw(st.sampled_from(["insert", "delete", "replace"]))
        if action == "insert":
            text = text[:pos] + draw(st.sampled_from(TOKENS)) + text[pos:]
        elif action == "delete":
            text = text[:pos] + text[pos + draw(st.integers(1, 8)) :]
        else:
            text = text[:pos] + draw(st.sampled_from(TOKENS)) + text[pos + 1 :]
    return text


@settings(max_examples=400, deadline=None)
@given(mutated_program())
def test_mutated_valid_programs(text: str) -> None:
    parse_or_diagnose(text)
