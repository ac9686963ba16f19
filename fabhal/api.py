"""The stages as plain functions: what the CLI, the tests and the benchmarks call."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fabhal.diagnostics import Diagnostic, has_errors, sort_diagnostics
from fabhal.load import LoadedProgram, load_program
from fabhal.source import SourceFile


@dataclass(frozen=True)
class CheckResult:
    program: LoadedProgram
    diagnostics: tuple[Diagnostic, ...]

    @property
    def ok(self) -> bool:
        return not has_errors(self.diagnostics)

    @property
    def sources(self) -> dict[str, SourceFile]:
        return self.program.sources


def check(path: Path) -> CheckResult:
    """Everything before solving: read, parse, resolve imports (later: elaborate, check).

    Raises `load.InputError` when the file itself cannot be read.
    """
    program = load_program(path)
    return CheckResult(program, tuple(sort_diagnostics(program.diagnostics)))
