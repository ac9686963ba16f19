"""The docs stay true: examples parse, every diagnostic code is documented and
each syntax example produces the code it documents."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fabhal import api
from fabhal.diagnostics import FabhalError
from fabhal.syntax.parser import parse_text
from tests.conftest import REPO

LANGUAGE = (REPO / "docs" / "language.md").read_text()
ERRORS = (REPO / "docs" / "errors.md").read_text()
FENCE = re.compile(r"```fhl\n(.*?)```", re.S)


def language_examples() -> list[str]:
    return FENCE.findall(LANGUAGE)


@pytest.mark.parametrize("example", language_examples())
def test_language_examples_parse(example: str) -> None:
    parse_text(example, "docs/language.md")


def documented_sections() -> dict[str, str]:
    sections = re.split(r"^## ([EWN]\d{3})\b.*$", ERRORS, flags=re.M)
    return dict(zip(sections[1::2], sections[2::2], strict=True))


def emitted_codes() -> set[str]:
    sources = (p.read_text() for p in (REPO / "fabhal").rglob("*.py"))
    return {code for text in sources for code in re.findall(r'"([EWN]\d{3})"', text)}


def test_every_emitted_code_is_documented() -> None:
    missing = emitted_codes() - set(documented_sections())
    assert not missing, f"add these codes to docs/errors.md: {sorted(missing)}"


def test_no_documented_code_is_stale() -> None:
    stale = set(documented_sections()) - emitted_codes()
    assert not stale, f"docs/errors.md documents codes nothing emits: {sorted(stale)}"


def first_example(section: str) -> str:
    (example, *_) = FENCE.findall(section)
    return example


SYNTAX_SECTIONS = sorted((c, s) for c, s in documented_sections().items() if c.startswith("E1"))


@pytest.mark.parametrize(("code", "section"), SYNTAX_SECTIONS, ids=[c for c, _ in SYNTAX_SECTIONS])
def test_syntax_examples_produce_their_code(code: str, section: str) -> None:
    with pytest.raises(FabhalError) as caught:
        parse_text(first_example(section), "docs/errors.md")
    assert caught.value.diagnostics[0].code == code
    assert all(d.help for d in caught.value.diagnostics), "every diagnostic says how to fix it"


CHECK_SECTIONS = sorted(
    (c, s) for c, s in documented_sections().items() if not c.startswith("E1") and "```fhl" in s
)


@pytest.mark.parametrize(("code", "section"), CHECK_SECTIONS, ids=[c for c, _ in CHECK_SECTIONS])
def test_check_examples_produce_their_code(code: str, section: str, tmp_path: Path) -> None:
    program = tmp_path / "example.fhl"
    program.write_text(first_example(section))
    # codes 5xx come from solving, the others from checking
    result = api.solve(program) if code[1] == "5" else api.check(program)
    assert code in [d.code for d in result.diagnostics], result.diagnostics
    assert all(d.help for d in result.diagnostics), "every diagnostic says how to fix it"


def test_primitives_page_names_every_kind_parameter_and_flag() -> None:
    from fabhal.primitives import KINDS

    page = (REPO / "docs" / "primitives.md").read_text()
    for spec in KINDS.values():
        assert f"`{spec.kind}`" in page
        for name in [p.name for p in spec.params] + [f.name for f in spec.flags]:
            assert f"`{name}`" in page, name
