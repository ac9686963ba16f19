"""The Pygments lexer (fabhal/syntax/lexer.py) against the grammar and every
`.fhl` file the repository ships."""

from __future__ import annotations

from pathlib import Path

import pytest
from pygments.lexers import get_lexer_by_name, get_lexer_for_filename
from pygments.token import Error, Keyword, Name

from fabhal.syntax.lexer import FabhalLexer, colour_source_lines, grammar_keywords
from tests.conftest import all_fhl_files


def test_the_keywords_are_the_grammars() -> None:
    assert set(grammar_keywords()) == {
        "import", "param", "in", "linspace", "environment", "connect", "flip", "noflip", "fixed", "target",
        "for", "assembly", "port", "part", "mesh", "mass", "material", "at", "rot", "set",
    }  # fmt: skip


def test_the_entry_point_finds_it_by_alias_and_file_name() -> None:
    """Registered in pyproject.toml's `pygments.lexers` entry points (the package must be installed)."""
    assert isinstance(get_lexer_by_name("fhl"), FabhalLexer)
    assert isinstance(get_lexer_for_filename("mug_hanger.fhl"), FabhalLexer)


@pytest.mark.parametrize("path", all_fhl_files(), ids=lambda p: p.name)
def test_every_shipped_program_lexes_without_an_error_token(path: Path) -> None:
    tokens = list(FabhalLexer().get_tokens(path.read_text()))
    assert [value for kind, value in tokens if kind is Error] == []
    assert "".join(value for _, value in tokens) == path.read_text() + (
        "" if path.read_text().endswith("\n") else "\n"
    )


def test_a_line_is_told_apart_as_a_person_reads_it() -> None:
    line = "connect s1.hook2 -- rod flip # why\n"
    tokens = [(kind, value) for kind, value in FabhalLexer().get_tokens(line) if value.strip()]
    assert tokens[0] == (Keyword, "connect")
    assert (Keyword, "flip") in tokens and (Name, "s1") in tokens
    assert tokens[-1][1] == "# why"
    kinds = dict((v, k) for k, v in FabhalLexer().get_tokens("  hook2 hook(arc_radius: 5) Mug() fliped\n"))
    assert kinds["hook"] is Name.Builtin and kinds["Mug"] is Name.Class and kinds["fliped"] is Name


def test_diagnostics_on_a_terminal_colour_only_the_quoted_source() -> None:
    rendered = "x.fhl:1:18: error[E101]: expected `--`\n1 | connect s1.hook2 rod\n  |                  ^^^"
    coloured = colour_source_lines(rendered)
    assert coloured.splitlines()[0] == rendered.splitlines()[0]  # the message itself is left alone
    assert "\x1b[" in coloured.splitlines()[1] and coloured.splitlines()[1].startswith("1 | ")
    assert coloured.splitlines()[2] == rendered.splitlines()[2]


def test_every_fhl_block_of_the_docs_lexes_without_an_error_token() -> None:
    """The docs name their examples ```fhl, the lexer's alias: a Pygments-based
    renderer (MkDocs, Sphinx) highlights them with it, so none may confuse it."""
    import re

    from tests.conftest import REPO

    # docs/errors.md is left out: its examples are wrong on purpose (a stray `;`, an open string)
    documents = [
        REPO / "README.md",
        *sorted(p for p in (REPO / "docs").glob("*.md") if p.name != "errors.md"),
    ]
    blocks = [b for d in documents for b in re.findall(r"```fhl\n(.*?)```", d.read_text(), re.S)]
    assert len(blocks) > 10
    lexer = get_lexer_by_name("fhl")
    assert [b for b in blocks if any(kind is Error for kind, _ in lexer.get_tokens(b))] == []
