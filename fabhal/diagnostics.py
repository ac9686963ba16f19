"""The one diagnostic type every stage reports with, and its two renderings.

A stage never prints: it returns (or raises, inside `FabhalError`) `Diagnostic`
values. The CLI chooses the rendering: `render_text` for people, `to_json` for
tools. Every code is documented in docs/errors.md.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum

from fabhal.source import SourceFile, Span


class Severity(str, Enum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True)
class Diagnostic:
    severity: Severity
    code: str
    message: str
    span: Span | None
    help: str | None = None
    notes: tuple[str, ...] = field(default=())

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def sort_key(self) -> tuple[str, int, int, str]:
        if self.span is None:
            return ("", 0, 0, self.code)
        return (*self.span.sort_key(), self.code)


# Every diagnostic says how to fix what it reports: `help` is required.
def error(code: str, message: str, span: Span | None, help: str) -> Diagnostic:
    return Diagnostic(Severity.ERROR, code, message, span, help)


def warning(code: str, message: str, span: Span | None, help: str) -> Diagnostic:
    return Diagnostic(Severity.WARNING, code, message, span, help)


def note(code: str, message: str, span: Span | None, help: str) -> Diagnostic:
    return Diagnostic(Severity.NOTE, code, message, span, help)


def listed(names: Iterable[str]) -> str:
    """Names as a message lists them: `a`, `b` and `c`."""
    quoted = [f"`{name}`" for name in names]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " and " + quoted[-1]


def written_settings_hint(lines: Sequence[int]) -> str:
    """What a help adds where a loop that does not close holds settings the
    program writes (`set (...)` on these lines): those may be what keeps it
    open (a setting copied from a result whose hooks turned, N508, where the
    loop closes only with them turned); empty where it holds none."""
    if not lines:
        return ""
    where = f"line {lines[0]}" if len(lines) == 1 else "lines " + ", ".join(map(str, lines))
    return (
        f"; or leave out the `set (...)` on {where}: a written setting holds a part where it is, and "
        "the loop may close only with it elsewhere"
    )


class FabhalError(Exception):
    """Raised by a stage that cannot go on; carries what to tell the user."""

    def __init__(self, diagnostics: Iterable[Diagnostic]):
        self.diagnostics = tuple(diagnostics)
        super().__init__("; ".join(d.message for d in self.diagnostics))


def sort_diagnostics(diagnostics: Iterable[Diagnostic]) -> list[Diagnostic]:
    return sorted(diagnostics, key=Diagnostic.sort_key)


def merge_repeats(diagnostics: Iterable[Diagnostic]) -> list[Diagnostic]:
    """One diagnostic per place and code. A line inside a `for` loop (or in an
    assembly used several times) is elaborated and checked once per pass, and
    would report its problem each time; the first report stands for all, with a
    note saying how many passes it affects and what the others said."""
    groups: dict[tuple[Severity, str, Span | None, str], list[Diagnostic]] = {}
    for diagnostic in diagnostics:
        # without a place, only word-for-word repeats are the same problem
        words = diagnostic.message if diagnostic.span is None else ""
        groups.setdefault((diagnostic.severity, diagnostic.code, diagnostic.span, words), []).append(
            diagnostic
        )
    merged = []
    for first, *others in groups.values():
        if not others:
            merged.append(first)
            continue
        different = list(dict.fromkeys(d.message for d in others if d.message != first.message))
        note = (
            f"this line is reached {len(others) + 1} times (a `for` loop, or an assembly used more "
            "than once); reported once"
        )
        if different:
            shown = "; ".join(different[:3]) + ("; ..." if len(different) > 3 else "")
            note += f"; the other passes say: {shown}"
        merged.append(replace(first, notes=(*first.notes, note)))
    return merged


def has_errors(diagnostics: Iterable[Diagnostic]) -> bool:
    return any(d.is_error for d in diagnostics)


# ---------------------------------------------------------------- rendering


def _underline(line_text: str, span: Span) -> str:
    """Carets under the span on its first line; tabs kept so the carets line up."""
    start = max(span.column - 1, 0)
    end = span.end_column - 1 if span.end_line == span.line else len(line_text)
    end = max(end, start + 1)
    prefix = "".join("\t" if ch == "\t" else " " for ch in line_text[:start])
    return prefix + "^" * (end - start)


def render_text(diagnostic: Diagnostic, sources: Mapping[str, SourceFile]) -> str:
    """`file:line:col: error[code]: message`, the source line, carets, `help:`."""
    span = diagnostic.span
    head = f"{diagnostic.severity.value}[{diagnostic.code}]: {diagnostic.message}"
    if span is None:
        lines = [head]
    else:
        lines = [f"{span.file}:{span.line}:{span.column}: {head}"]
        source = sources.get(span.file)
        if source is not None:
            text = source.line_text(span.line)
            gutter = " " * len(str(span.line))
            lines.append(f"{span.line} | {text}")
            lines.append(f"{gutter} | {_underline(text, span)}")
    lines.extend(f"  note: {note}" for note in diagnostic.notes)
    if diagnostic.help:
        lines.append(f"  help: {diagnostic.help}")
    return "\n".join(lines)


def render_all(
    diagnostics: Iterable[Diagnostic], sources: Mapping[str, SourceFile], limit: int | None = 20
) -> str:
    """Every diagnostic in position order, the first `limit` of them in full."""
    ordered = sort_diagnostics(diagnostics)
    shown = ordered if limit is None else ordered[:limit]
    parts = [render_text(d, sources) for d in shown]
    if len(ordered) > len(shown):
        parts.append(f"... and {len(ordered) - len(shown)} more (use --json to see all)")
    return "\n\n".join(parts)


def to_json(diagnostic: Diagnostic) -> dict[str, object]:
    span = diagnostic.span
    return {
        "severity": diagnostic.severity.value,
        "code": diagnostic.code,
        "message": diagnostic.message,
        "file": span.file if span else None,
        "line": span.line if span else None,
        "column": span.column if span else None,
        "end_line": span.end_line if span else None,
        "end_column": span.end_column if span else None,
        "help": diagnostic.help,
        "notes": list(diagnostic.notes),
    }
