"""Turn Lark's syntax errors into diagnostics a user understands.

Each rule below recognises one usual mistake from the parser state (what was
expected, what came instead, what came before) and says what to write. What no
rule recognises still gets "expected X, found Y" in words, not token names.

`describe_syntax_error` also says which part of the text to blank out so that
parsing can resume after the bad statement and find the next error.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Protocol

from lark import Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from fabhal.diagnostics import Diagnostic, error
from fabhal.source import Span

STATEMENT_KEYWORDS = (
    "import", "param", "environment", "connect", "target", "for", "part", "assembly", "port",
)  # fmt: skip
PART_KEYWORDS = ("mesh", "mass", "material")
CONNECT_OPTIONS = ("flip", "noflip", "fixed")

_WORDS = {
    "NAME": "a name",
    "NUMBER": "a number",
    "STRING": 'a quoted string like "file.fhl"',
    "_NL": "end of line",
    "$END": "end of file",
    "DASHDASH": "`--`",
    "DOTDOT": "`..`",
    "EQUALS": "`=`",
    "COLON": "`:`",
    "COMMA": "`,`",
    "DOT": "`.`",
    "PLUS": "`+`",
    "MINUS": "`-`",
    "STAR": "`*`",
    "SLASH": "`/`",
    "LPAR": "`(`",
    "RPAR": "`)`",
    "LSQB": "`[`",
    "RSQB": "`]`",
    "LBRACE": "`{`",
    "RBRACE": "`}`",
}
_VALUE_STARTS = {"NUMBER", "NAME", "LPAR", "MINUS", "TRUE", "FALSE"}
_OPERATORS = {"PLUS", "MINUS", "STAR", "SLASH"}
_CLOSING = {"RPAR": "(", "RSQB": "[", "RBRACE": "{"}


@dataclass(frozen=True)
class TokenContext:
    """What came before a token: the token just before it, the first token of
    its statement, and the brackets open (each with the token before it)."""

    previous: Token | None
    statement_first: Token | None
    open_brackets: tuple[tuple[Token, Token | None], ...]


class ParserState(Protocol):
    """The post-lexer, which remembers the tokens before an error."""

    def context_of(self, token: Token) -> TokenContext: ...


def token_words(token_type: str, value: str = "") -> str:
    if token_type in _WORDS:
        if token_type in ("NAME", "NUMBER", "STRING") and value:
            return f"`{value}`"
        return _WORDS[token_type]
    return f"`{token_type.lower()}`"  # keywords are named after their spelling


def expected_words(expected: Iterable[str]) -> str:
    """`{"NUMBER","NAME","LPAR",...}` -> "a value (a number, a name or an expression)"."""
    kinds = set(expected)
    words: list[str] = []
    if {"NUMBER", "NAME", "LPAR"} <= kinds:
        kinds -= _VALUE_STARTS
        words.append("a value (a number, a name or an expression)")
    if kinds - _OPERATORS:
        kinds -= _OPERATORS
    words.extend(sorted(token_words(k) for k in kinds))
    if len(words) <= 1:
        return words[0] if words else "something else"
    return ", ".join(words[:-1]) + " or " + words[-1]


def did_you_mean(word: str, choices: Iterable[str]) -> str | None:
    matches = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return matches[0] if matches else None


def suggestion(word: str, choices: Iterable[str], listing: str, empty: str, quoted: bool = True) -> str:
    """A help line: "did you mean `x`?" for a near miss, else `listing` with the
    choices filled in for {choices}, else `empty` when there are none."""
    options = list(choices)
    close = did_you_mean(word, options)
    if close is not None:
        return f"did you mean `{close}`?"
    if options:
        return listing.format(choices=", ".join(f"`{o}`" if quoted else o for o in options))
    return empty


# ---------------------------------------------------------------- the rules


@dataclass(frozen=True)
class ErrorContext:
    """Everything the rules look at, gathered once."""

    token: Token
    expected: frozenset[str]
    before: TokenContext
    text: str
    file: str

    @property
    def previous(self) -> Token | None:
        return self.before.previous

    @property
    def statement_first(self) -> Token | None:
        return self.before.statement_first

    @property
    def open_brackets(self) -> tuple[tuple[Token, Token | None], ...]:
        return self.before.open_brackets

    def span_of(self, token: Token) -> Span:
        return Span(self.file, token.line or 1, token.column or 1, token.end_line or 1, token.end_column or 1)

    @property
    def span(self) -> Span:
        """The offending token; for a line end, the column just after the previous token."""
        if self.token.type in ("_NL", "$END") and self.previous is not None:
            prev = self.span_of(self.previous)
            return Span(self.file, prev.end_line, prev.end_column, prev.end_line, prev.end_column + 1)
        return self.span_of(self.token)

    @property
    def found(self) -> str:
        return token_words(self.token.type, str(self.token.value))


Rule = Callable[[ErrorContext], "Diagnostic | None"]


def _unclosed_bracket(ctx: ErrorContext) -> Diagnostic | None:
    if not ctx.open_brackets:
        return None
    opener, _ = ctx.open_brackets[-1]
    if ctx.token.type != "$END" and (ctx.token.line or 0) <= (opener.line or 0):
        return None
    closer = ")" if opener.type == "LPAR" else "]"
    return error(
        "E102",
        f"`{opener.value}` is never closed",
        ctx.span_of(opener),
        f"add `{closer}` at the end of this line",
    )


def _unmatched_closer(ctx: ErrorContext) -> Diagnostic | None:
    if ctx.token.type not in _CLOSING or ctx.token.type in ctx.expected:
        return None
    if ctx.token.type == "RBRACE" and "_NL" in ctx.expected:
        return None  # `}` on the same line as a statement: a missing line end
    if any(_CLOSING[ctx.token.type] == opener.value for opener, _ in ctx.open_brackets):
        return None  # it does close something; what is wrong lies before it
    return error(
        "E107",
        f"`{ctx.token.value}` has no matching `{_CLOSING[ctx.token.type]}`",
        ctx.span,
        "remove it, or add the opening bracket it was meant to close",
    )


def _keyword_out_of_place(ctx: ErrorContext) -> Diagnostic | None:
    """A keyword the lexer read as a name because it is not allowed where it stands."""
    first = ctx.statement_first
    if first is None or first.type != "NAME":
        return None
    if first.value in STATEMENT_KEYWORDS:
        return error(
            "E113",
            f"`{first.value}` cannot appear inside a `part` definition",
            ctx.span_of(first),
            "a part lists only its primitives and `mesh`, `mass`, `material` lines; "
            "connections go in the program or in an `assembly`",
        )
    if first.value in PART_KEYWORDS:
        return error(
            "E113",
            f"`{first.value}` belongs inside a `part` definition",
            ctx.span_of(first),
            "move it into a `part Name { ... }` block",
        )
    return None


def _unknown_statement(ctx: ErrorContext) -> Diagnostic | None:
    first = ctx.statement_first
    if first is None or first.type != "NAME" or ctx.previous is not first:
        return None
    if ctx.token.type in ("EQUALS", "LSQB", "_NL"):
        return None
    in_part = "NAME" in ctx.expected and "EQUALS" not in ctx.expected
    keywords = PART_KEYWORDS if in_part else STATEMENT_KEYWORDS
    suggestion = did_you_mean(str(first), keywords)
    if suggestion is not None:
        return error(
            "E103", f"unknown keyword `{first}`", ctx.span_of(first), f"did you mean `{suggestion}`?"
        )
    if in_part:
        return None
    if ctx.token.type == "NAME":
        return error(
            "E111",
            f"missing `=` between `{first}` and `{ctx.token.value}`",
            ctx.span_of(ctx.token),
            f"a part is made with `{first} = {ctx.token.value}(...)`",
        )
    listed = ", ".join(f"`{k}`" for k in STATEMENT_KEYWORDS)
    return error(
        "E103",
        f"`{first}` does not start a statement",
        ctx.span_of(first),
        f"a statement starts with a keyword ({listed}) or is `name = Part(...)`",
    )


def _missing_dashdash(ctx: ErrorContext) -> Diagnostic | None:
    if "DASHDASH" not in ctx.expected:
        return None
    return error(
        "E101",
        f"expected `--` between the two sides of `connect`, found {ctx.found}",
        ctx.span,
        "write the connection as `connect part.primitive -- other.primitive`",
    )


def _connect_option(ctx: ErrorContext) -> Diagnostic | None:
    if not {"FLIP", "FIXED"} <= ctx.expected or ctx.token.type != "NAME":
        return None
    suggestion = did_you_mean(str(ctx.token.value), CONNECT_OPTIONS)
    help_text = (
        f"did you mean `{suggestion}`?" if suggestion else "the options are `flip`, `noflip` and `fixed`"
    )
    return error("E112", f"unknown connection option `{ctx.token.value}`", ctx.span, help_text)


def _vector_arity(ctx: ErrorContext) -> Diagnostic | None:
    if not ctx.open_brackets:
        return None
    opener, before = ctx.open_brackets[-1]
    if opener.type != "LPAR" or before is None or before.type not in ("AT", "ROT", "LINSPACE"):
        return None
    too_few = ctx.token.type == "RPAR" and "COMMA" in ctx.expected and "RPAR" not in ctx.expected
    too_many = ctx.token.type == "COMMA" and "RPAR" in ctx.expected and "COMMA" not in ctx.expected
    if not (too_few or too_many):
        return None
    what = {
        "AT": ("a position", "`at (x, y, z)` in millimetres"),
        "ROT": ("a rotation", "`rot (a, b, c)` in degrees"),
        "LINSPACE": ("`linspace`", "`linspace(start, stop, count)`"),
    }[before.type]
    amount = "only three" if too_many else "three"
    return error("E110", f"{what[0]} takes {amount} values", ctx.span, f"write {what[1]}")


def _positional_argument(ctx: ErrorContext) -> Diagnostic | None:
    previous = ctx.previous
    if previous is None:
        return None
    if "COLON" in ctx.expected and previous.type == "NAME" and ctx.token.type in ("COMMA", "RPAR", "EQUALS"):
        message = (
            "arguments are written `name: value`, not `name = value`"
            if ctx.token.type == "EQUALS"
            else f"argument `{previous.value}` has no value"
        )
        return error("E109", message, ctx.span, f"write `{previous.value}: value`")
    value_starts = ("NUMBER", "MINUS", "LPAR", "STRING", "TRUE", "FALSE")
    if {"NAME", "RPAR"} <= ctx.expected and ctx.token.type in value_starts:
        return error(
            "E109",
            "arguments are written `name: value`",
            ctx.span,
            "name each argument, for example `Rod(length: 500, radius: 2)`",
        )
    return None


def _missing_value(ctx: ErrorContext) -> Diagnostic | None:
    if not {"NUMBER", "NAME", "LPAR"} <= ctx.expected:
        return None
    first, previous = ctx.statement_first, ctx.previous
    domain = first is not None and first.value == "param" and previous is not None and previous.value == "in"
    return error(
        "E108",
        f"expected a value, found {ctx.found}",
        ctx.span,
        "a param's values are a range `1 .. 4`, `linspace(0, 45.7, 21)` or a list in square brackets "
        "`[RingS, RingM]`"
        if domain
        else "write a number, a name or an expression such as `40 + extension / 2`",
    )


def _two_statements_on_a_line(ctx: ErrorContext) -> Diagnostic | None:
    if "_NL" not in ctx.expected or ctx.token.type in ("_NL", "$END"):
        return None
    if ctx.token.type == "NAME" and ctx.token.value in STATEMENT_KEYWORDS:
        pass
    elif str(ctx.token.type).lower() not in STATEMENT_KEYWORDS + PART_KEYWORDS and ctx.token.type != "RBRACE":
        return None
    return error(
        "E114",
        f"expected end of line before {ctx.found}",
        ctx.span,
        "put each statement on its own line",
    )


def _primitive_without_arguments(ctx: ErrorContext) -> Diagnostic | None:
    if ctx.expected != {"LPAR"} or ctx.previous is None or ctx.statement_first is None:
        return None
    return error(
        "E116",
        "a primitive needs its shape parameters in parentheses",
        ctx.span,
        f"write `{ctx.statement_first.value} {ctx.previous.value}(...)`, e.g. "
        "`rod rod(radius: 2, length: 500)`",
    )


def _missing_placement(ctx: ErrorContext) -> Diagnostic | None:
    if not {"AT", "ROT"} <= ctx.expected or "_NL" in ctx.expected:
        return None
    return error(
        "E117",
        f"expected `at` or `rot` before {ctx.found}",
        ctx.span,
        "write `target part.primitive at (x, y, z) rot (a, b, c)`",
    )


def _block_without_brace(ctx: ErrorContext) -> Diagnostic | None:
    if ctx.expected != {"LBRACE"} or ctx.statement_first is None:
        return None
    keyword = str(ctx.statement_first.value)
    return error(
        "E118",
        f"expected `{{` to open the body of this `{keyword}`, found {ctx.found}",
        ctx.span,
        "end the line with `{` and close the body with `}` on its own line",
    )


RULES: tuple[Rule, ...] = (
    _unclosed_bracket,
    _vector_arity,
    _unmatched_closer,
    _keyword_out_of_place,
    _unknown_statement,
    _missing_dashdash,
    _connect_option,
    _positional_argument,
    _two_statements_on_a_line,
    _primitive_without_arguments,
    _missing_placement,
    _block_without_brace,
    _missing_value,
)


def _generic(ctx: ErrorContext) -> Diagnostic:
    if ctx.token.type == "$END":
        return error(
            "E106",
            "the file ends in the middle of a statement",
            ctx.span,
            "finish the last statement, and close every `(`, `[` and `{` it opened",
        )
    return error(
        "E100",
        f"expected {expected_words(ctx.expected)}, found {ctx.found}",
        ctx.span,
        "write one statement per line: `NAME = Part()`, `connect a.p -- b.q`, `target ...`, "
        "`environment ...` (docs/language.md has them all)",
    )


# ---------------------------------------------------------------- entry point


def describe_syntax_error(
    exc: UnexpectedInput, text: str, file: str, state: ParserState
) -> tuple[Diagnostic, tuple[int, int, frozenset[int]] | None]:
    """The diagnostic for `exc`, and what to blank (start, end, kept offsets) to go on."""
    if isinstance(exc, UnexpectedCharacters):
        return _bad_character(exc, text, file, state)
    assert isinstance(exc, UnexpectedToken) or hasattr(exc, "expected")
    token: Token = getattr(exc, "token", None) or Token("$END", "", exc.pos_in_stream or len(text))
    if token.type == "$END":
        unclosed = _unclosed_brace(text, file)
        if unclosed is not None:
            return unclosed, None
    ctx = ErrorContext(
        token=token,
        expected=frozenset(_accepted(exc)),
        before=state.context_of(token),
        text=text,
        file=file,
    )
    for rule in RULES:
        diagnostic = rule(ctx)
        if diagnostic is not None:
            break
    else:
        diagnostic = _generic(ctx)
    if token.type == "$END":
        return diagnostic, None
    if diagnostic.code == "E102":
        opener = ctx.open_brackets[-1][0]
        return diagnostic, _region(text, _line_start(text, opener.start_pos or 0), opener.end_pos or 0, 0)
    return diagnostic, _statement_region(ctx)


def _accepted(exc: UnexpectedInput) -> set[str]:
    """The terminals the parser really accepts here (LALR's `expected` may list
    more: lookaheads of merged states)."""
    try:
        return set(getattr(exc, "accepts", None) or getattr(exc, "expected", ()) or ())
    except Exception:  # accepts() replays the parser; never let a hint crash the report
        return set(getattr(exc, "expected", ()) or ())


def _bad_character(
    exc: UnexpectedCharacters, text: str, file: str, state: ParserState
) -> tuple[Diagnostic, tuple[int, int, frozenset[int]] | None]:
    pos = exc.pos_in_stream or 0
    char = text[pos]
    line, column = exc.line, exc.column
    end_of_line = text.find("\n", pos)
    if char == '"':
        span = Span(file, line, column, line, column + max(end_of_line - pos, 1))
        diagnostic = error(
            "E105", "this string is never closed", span, 'add the closing `"` on the same line'
        )
    else:
        span = Span(file, line, column, line, column + 1)
        help_text = {
            ";": "statements end at the end of the line; remove the `;`",
            ">": "connections are written with `--`, as in `connect a.hook -- b.rod`",
            "'": 'strings use double quotes: "file.fhl"',
        }.get(char, "remove it")
        diagnostic = error("E104", f"unexpected character `{char}`", span, help_text)
    before = state.context_of(Token("$BAD", char))
    first = before.statement_first
    start = first.start_pos if first is not None and first.line == line else _line_start(text, pos)
    return diagnostic, _region(text, start or 0, pos, len(before.open_brackets))


def _statement_region(ctx: ErrorContext) -> tuple[int, int, frozenset[int]] | None:
    """From the start of the failing statement to the end of its logical line."""
    if ctx.token.type == "RBRACE" and ctx.token.type not in ctx.expected and "_NL" not in ctx.expected:
        pos = ctx.token.start_pos or 0
        return (pos, pos + 1, frozenset())
    first = ctx.statement_first
    start = first.start_pos if first is not None else ctx.token.start_pos
    region = _region(ctx.text, start or 0, ctx.token.start_pos or 0, len(ctx.open_brackets))
    if region is not None and ctx.expected == {"LBRACE"}:
        # the body of a block whose `{` is missing goes too, up to its `}`
        indent = (first.column or 1) - 1 if first is not None else 0
        closing = ctx.text.find("\n" + " " * indent + "}", region[1])
        if closing >= 0:
            end = ctx.text.find("\n", closing + 1)
            region = (region[0], len(ctx.text) if end < 0 else end, region[2])
    return region


def _line_start(text: str, pos: int) -> int:
    return text.rfind("\n", 0, pos) + 1


def _region(text: str, start: int, error_pos: int, depth: int) -> tuple[int, int, frozenset[int]] | None:
    """Blank start..end of the logical line at error_pos, keeping stray `}` and
    swallowing a block a blanked `{` would have opened."""
    end = _logical_line_end(text, error_pos, depth)
    braces = 0
    kept: set[int] = set()
    for pos in _code_positions(text, start, end):
        if text[pos] == "{":
            braces += 1
        elif text[pos] == "}":
            if braces:
                braces -= 1
            else:
                kept.add(pos)
    if braces:
        end = _matching_brace_end(text, end, braces)
    if not any(not text[p].isspace() for p in range(start, end) if p not in kept):
        return None
    return (start, end, frozenset(kept))


def _code_positions(text: str, start: int, end: int) -> Iterable[int]:
    """Offsets in [start, end) outside strings and comments."""
    pos = start
    while pos < end:
        ch = text[pos]
        if ch == "#":
            newline = text.find("\n", pos)
            pos = end if newline < 0 else newline
            continue
        if ch == '"':
            close = text.find('"', pos + 1)
            newline = text.find("\n", pos + 1)
            pos = end if close < 0 or (0 <= newline < close) else close + 1
            continue
        yield pos
        pos += 1


def _logical_line_end(text: str, pos: int, depth: int) -> int:
    for p in _code_positions(text, pos, len(text)):
        ch = text[p]
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth = max(depth - 1, 0)
        elif ch == "\n" and depth == 0:
            return p
    return len(text)


def _matching_brace_end(text: str, pos: int, open_count: int) -> int:
    for p in _code_positions(text, pos, len(text)):
        if text[p] == "{":
            open_count += 1
        elif text[p] == "}":
            open_count -= 1
            if open_count == 0:
                newline = text.find("\n", p)
                return len(text) if newline < 0 else newline
    return len(text)


def _unclosed_brace(text: str, file: str) -> Diagnostic | None:
    stack: list[int] = []
    for p in _code_positions(text, 0, len(text)):
        if text[p] == "{":
            stack.append(p)
        elif text[p] == "}" and stack:
            stack.pop()
    if not stack:
        return None
    pos = stack[-1]
    line = text.count("\n", 0, pos) + 1
    column = pos - _line_start(text, pos) + 1
    return error(
        "E106",
        "this `{` is never closed",
        Span(file, line, column, line, column + 1),
        "add a `}` on its own line after the block's last line",
    )
