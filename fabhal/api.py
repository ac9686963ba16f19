"""The stages as plain functions: what the CLI, the tests and the benchmarks call."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from fabhal.check import CheckContext, CheckReport, check_program
from fabhal.diagnostics import Diagnostic, has_errors, sort_diagnostics
from fabhal.elaborate import FlatProgram, elaborate
from fabhal.library import Library, build_library
from fabhal.load import LoadedProgram, load_program
from fabhal.model import Model, build_model
from fabhal.source import SourceFile


@dataclass(frozen=True)
class CheckResult:
    program: LoadedProgram
    library: Library
    flat: FlatProgram | None
    model: Model | None
    report: CheckReport | None
    diagnostics: tuple[Diagnostic, ...]

    @property
    def ok(self) -> bool:
        return not has_errors(self.diagnostics)

    @property
    def sources(self) -> dict[str, SourceFile]:
        return self.program.sources


def check(path: Path, bindings: Mapping[str, str] | None = None, seed: int = 0) -> CheckResult:
    """Everything before solving: read, parse, resolve imports, check the part
    definitions, elaborate the program (bind `param`s, unroll loops, resolve
    names), then check every rule of connecting (fabhal.check).

    Raises `load.InputError` when the file itself cannot be read.
    """
    program = load_program(path)
    library, problems = build_library(program)
    flat, elaboration_problems = elaborate(program, library, bindings)
    found = [*program.diagnostics, *problems, *elaboration_problems]
    model = report = None
    if flat is not None and not has_errors([*program.diagnostics, *problems]):
        model = build_model(flat)
        report = check_program(CheckContext(flat, model, library, seed), complete=not has_errors(found))
        found.extend(report.diagnostics)
    return CheckResult(program, library, flat, model, report, tuple(sort_diagnostics(found)))


def part_library() -> CheckResult:
    """The standard library alone (for `fabhal parts`)."""
    program = load_program(None)
    library, problems = build_library(program)
    diagnostics = tuple(sort_diagnostics([*program.diagnostics, *problems]))
    return CheckResult(program, library, None, None, None, diagnostics)
