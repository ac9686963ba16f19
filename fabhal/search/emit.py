"""A member of a family as a program of its own: the family's text with every
`param` bound to the member's value, so `fabhal solve` on it gives the answer
the search ranked (the same text, the same values, the same solver)."""

from __future__ import annotations

import os
import re
from collections import Counter
from collections.abc import Mapping
from pathlib import Path

from fabhal import api
from fabhal.load import LoadedProgram
from fabhal.resources import display_name
from fabhal.search.members import MemberResult
from fabhal.search.report import describe, short
from fabhal.solve.aim import builder_settings
from fabhal.source import Span
from fabhal.syntax import ast
from fabhal.syntax.format import format_ref


def emit_member(program: LoadedProgram, member: MemberResult, place: int, directory: Path) -> Path:
    """Write the member as `directory/NN_name_param-value....fhl`; returns its path."""
    assert program.main is not None  # a family has members only when its program parsed
    main_path = program.paths[program.main.file]
    text = program.sources[program.main.file].text
    settings, unwritten = _written_settings(program, member)
    edits = [
        *_bound_params(program.main, text, member.bindings),
        *_moved_imports(program.main, main_path, directory),
        *settings,
    ]
    for span, replacement in sorted(edits, key=lambda e: _offset(text, e[0].line, e[0].column), reverse=True):
        start = _offset(text, span.line, span.column)
        end = _offset(text, span.end_line, span.end_column)
        text = text[:start] + replacement + text[end:]
    header = (
        f"# Member {member.key} of {display_name(main_path)}, found by `fabhal search` "
        f"(#{place}: {describe(member)}).\n"
        "# Its params are bound below; solve it with `fabhal solve`.\n"
        + _continued_note(member, unwritten)
        + "\n"
    )
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / (member_file_name(program, member, place) + ".fhl")
    path.write_text(header + text)
    return path


def _continued_note(member: MemberResult, unwritten: bool) -> str:
    """What `--smooth` adds: this result came from a neighbour's settings, written
    below; where some could not be (`unwritten`), all of them in a builder's words."""
    if member.reached_from is None:
        return ""
    lines = [
        f"The search reached this result from the solved settings of its neighbour {member.reached_from}",
        "(--smooth). The settings a builder makes once are written on their connections (`set`);",
        "`fabhal solve` keeps them, but starts the rest afresh: the parts gravity moves may come to",
        "rest in another of their rest states than the search's (hang them as its picture shows).",
    ]
    if unwritten and member.aimed is not None:
        lines.append(f"Not all could be written (a `for` loop or an assembly makes them): {member.aimed}")
    return "".join(f"# {line}\n" for line in lines)


def _written_settings(program: LoadedProgram, member: MemberResult) -> tuple[list[tuple[Span, str]], bool]:
    """A continued member's settings (`--smooth`: the ones a builder makes once,
    as found from its neighbour) written on their connections as `set (...)`, so
    that solving the emitted program starts from them, and whether some could
    not be: only connections written once in the main file (not in a `for`
    loop or an assembly) can carry them; the rest are left to the solver."""
    if member.reached_from is None or member.x is None or program.main is None:
        return [], False
    model = api.check(program, member.bindings).model  # which DoF is which
    if model is None:
        return [], True
    statements = {s.span: s for s in program.main.statements if isinstance(s, ast.ConnectStmt)}
    uses = Counter(joint.connection.span for joint in model.joints)
    written: dict[Span, list[str]] = {}
    unwritten = False
    for i in sorted(builder_settings(model) - model.pinned):
        variable = model.variables[i]
        span = model.joints[variable.joint].connection.span
        statement = statements.get(span)
        if statement is None or uses[span] > 1:
            unwritten = True
            continue
        side = statement.a if variable.side == "a" else statement.b
        written.setdefault(span, []).append(f"{format_ref(side)}.{variable.dof.name}: {member.x[i]:.12g}")
    edits = []
    for span, settings in written.items():
        statement = statements[span]
        if statement.settings:  # add to the program's own `set (...)`, before its `)`
            at = Span(span.file, span.end_line, span.end_column - 1, span.end_line, span.end_column - 1)
            edits.append((at, ", " + ", ".join(settings)))
        else:
            at = Span(span.file, span.end_line, span.end_column, span.end_line, span.end_column)
            edits.append((at, f" set ({', '.join(settings)})"))
    return edits, unwritten


def member_file_name(program: LoadedProgram, member: MemberResult, place: int) -> str:
    """`03_clip_light_family_ring-RingM_n-3_extension-43.415`: its rank, family and values."""
    stem = Path(program.main.file).stem if program.main is not None else "member"
    return f"{place:02d}_{stem}_{_slug(member.bindings)}"


def _bound_params(module: ast.Module, text: str, bindings: Mapping[str, str]) -> list[tuple[Span, str]]:
    """Each top-level param's default replaced by (or given) the member's value."""
    edits = []
    for statement in module.statements:
        if isinstance(statement, ast.ParamDecl) and statement.name in bindings:
            value = bindings[statement.name]
            if statement.default is not None:
                edits.append((statement.default.span, value))
            else:
                end = statement.span
                edits.append(
                    (
                        Span(end.file, end.end_line, end.end_column, end.end_line, end.end_column),
                        f" = {value}",
                    )
                )
    return edits


def _moved_imports(module: ast.Module, main_path: Path, directory: Path) -> list[tuple[Span, str]]:
    """Imports found next to the family's file, rewritten relative to `directory`
    (those of the library or the gallery are found from anywhere)."""
    edits = []
    for statement in module.statements:
        if not isinstance(statement, ast.ImportStmt):
            continue
        beside = (main_path.parent / statement.path).resolve()
        if beside.is_file() and (directory / statement.path).resolve() != beside:
            relative = Path(os.path.relpath(beside, directory.resolve())).as_posix()
            edits.append((statement.span, f'import "{relative}"'))
    return edits


def _offset(text: str, line: int, column: int) -> int:
    starts = [0, *(m.end() for m in re.finditer("\n", text))]
    return starts[line - 1] + column - 1


def _slug(bindings: Mapping[str, str]) -> str:
    return "_".join(
        f"{name}-{re.sub(r'[^A-Za-z0-9.+-]', '', short(value))}" for name, value in bindings.items()
    )
