"""A Pygments lexer for `.fhl` files, registered through the `pygments.lexers`
entry point (aliases `fhl`, `fabhal`): Markdown and Sphinx docs highlight
```fhl blocks with it, and `fabhal` colours the source lines it shows in
diagnostics on a terminal.

Its keywords are read from the grammar (every `NAME.2: /word\\b/` terminal),
so the lexer can never disagree with the parser about what a keyword is;
the primitive kinds come from fabhal.primitives."""

from __future__ import annotations

import re
from typing import ClassVar

from pygments.lexer import RegexLexer, words
from pygments.token import Comment, Keyword, Name, Number, Operator, Punctuation, String, Text, _TokenType

from fabhal.primitives import KINDS
from fabhal.resources import grammar_path

_KEYWORD_TERMINAL = re.compile(r"^[A-Z_]+\.2: /([a-z]+)\\b/", re.MULTILINE)
CONSTANTS = ("true", "false")


def grammar_keywords() -> tuple[str, ...]:
    """Every keyword of the language, as the grammar defines them."""
    found = _KEYWORD_TERMINAL.findall(grammar_path().read_text(encoding="utf-8"))
    return tuple(word for word in found if word not in CONSTANTS)


class FabhalLexer(RegexLexer):
    name = "FabHaL"
    aliases: ClassVar[list[str]] = ["fhl", "fabhal"]
    filenames: ClassVar[list[str]] = ["*.fhl"]
    mimetypes: ClassVar[list[str]] = ["text/x-fabhal"]
    url = "docs/language.md"

    tokens: ClassVar[dict[str, list[tuple[str, _TokenType] | tuple[str, _TokenType, str]]]] = {
        "root": [
            (r"#.*$", Comment.Single),
            (r'"[^"\n]*"', String.Double),
            (words(grammar_keywords(), suffix=r"\b"), Keyword),
            (words(CONSTANTS, suffix=r"\b"), Keyword.Constant),
            (words(tuple(KINDS), suffix=r"\b"), Name.Builtin),  # rod(...), hook(...) in part definitions
            (r"[A-Z][A-Za-z0-9_]*", Name.Class),  # part types and assemblies, by convention
            (r"[A-Za-z_][A-Za-z0-9_]*", Name),
            (r"(\d+(\.(?!\.)\d*)?|\.\d+)([eE][+-]?\d+)?", Number),
            (r"--|\.\.|[=+\-*/]", Operator),
            (r"[()\[\]{},:.]", Punctuation),
            (r"\s+", Text),
        ],
    }


_SOURCE_LINE = re.compile(r"^(\d+ \| )(.*)$", re.MULTILINE)


def colour_source_lines(rendered: str) -> str:
    """Diagnostics as `render_all` writes them, with each quoted source line
    (`12 | connect s1.hook2 rod`) highlighted for a terminal (ANSI colours)."""
    from pygments import highlight
    from pygments.formatters import TerminalFormatter

    lexer, formatter = FabhalLexer(), TerminalFormatter()

    def coloured(line: re.Match[str]) -> str:
        return line.group(1) + highlight(line.group(2), lexer, formatter).rstrip("\n")

    return _SOURCE_LINE.sub(coloured, rendered)
