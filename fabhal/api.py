"""The stages as plain functions: what the CLI, the tests and the benchmarks call."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from fabhal.check import CheckContext, CheckReport, check_program
from fabhal.diagnostics import Diagnostic, error, has_errors, merge_repeats, sort_diagnostics
from fabhal.elaborate import FlatProgram, elaborate
from fabhal.library import Library, build_library
from fabhal.load import LoadedProgram, load_program
from fabhal.model import Model, build_model
from fabhal.source import SourceFile

if TYPE_CHECKING:
    from fabhal.kinematics.frames import Array


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


def check(
    path: str | Path | LoadedProgram, bindings: Mapping[str, str] | None = None, seed: int = 0
) -> CheckResult:
    """Everything before solving: read, parse, resolve imports, check the part
    definitions, elaborate the program (bind `param`s, unroll loops, resolve
    names), then check every rule of connecting (fabhal.check).

    `path` may be a program already read (a family's members share one).
    Raises `load.InputError` when the file itself cannot be read.
    """
    return _checked(_loaded(path), bindings, seed, float("inf"))


def _loaded(path: str | Path | LoadedProgram) -> LoadedProgram:
    return path if isinstance(path, LoadedProgram) else load_program(Path(path))


def part_library() -> CheckResult:
    """The standard library alone (for `fabhal parts`)."""
    program = load_program(None)
    library, problems = build_library(program)
    diagnostics = tuple(sort_diagnostics([*program.diagnostics, *problems]))
    return CheckResult(program, library, None, None, None, diagnostics)


@dataclass(frozen=True)
class SolveResult:
    """What `fabhal solve` reports: a status, the check, and the solution if there is one."""

    status: str  # solved, falls_apart, not_at_rest, infeasible, out_of_time, error
    check: CheckResult
    solution: object | None  # fabhal.solve.Solution (imported lazily: `fabhal check` starts faster)
    seed: int
    timing: dict[str, float]

    @property
    def diagnostics(self) -> tuple[Diagnostic, ...]:
        extra = getattr(self.solution, "diagnostics", ())
        return tuple(sort_diagnostics([*self.check.diagnostics, *extra]))


def solve(
    path: str | Path | LoadedProgram,
    bindings: Mapping[str, str] | None = None,
    seed: int = 0,
    time_limit: float | None = None,
    gravity: bool = True,
    progress: Callable[[str], None] | None = None,
    two_step: bool = False,
    start: Array | None = None,
) -> SolveResult:
    """Check, then (if the design can be built) solve. Raises load.InputError for an unreadable file.

    `time_limit` (seconds) counts from here and bounds every stage: reading,
    checking (the loops' closure solve) and solving. `two_step`: the paper's
    two steps only, without aiming the builder's choices (fabhal/solve/aim.py).
    `path` may be a program already read, as for `check`. `start`: a solved
    configuration (`Solution.x`) of the same design to continue from instead
    of fitting the target (a neighbouring member of a family)."""
    started = time.perf_counter()
    deadline = time.monotonic() + time_limit if time_limit is not None else float("inf")
    program = _loaded(path)
    parsed = time.perf_counter()
    result = _checked(program, bindings, seed, deadline)
    timing = {"parse_s": parsed - started, "check_s": time.perf_counter() - parsed}
    return _solve(result, seed, time_limit, deadline, gravity, progress, two_step, start, timing)


def solve_checked(
    result: CheckResult,
    seed: int = 0,
    time_limit: float | None = None,
    gravity: bool = True,
    progress: Callable[[str], None] | None = None,
    two_step: bool = False,
    start: Array | None = None,
    explain: bool = True,
) -> SolveResult:
    """`solve` for a program `check` has already checked (with the same `seed`):
    a family's members and designs are checked first, to reject some without
    solving, and are then solved without checking them again. `time_limit`
    counts from here. Not `explain`: a target out of reach is said (W505)
    without the fit that finds what limits it."""
    deadline = time.monotonic() + time_limit if time_limit is not None else float("inf")
    timing = {"parse_s": 0.0, "check_s": 0.0}
    return _solve(result, seed, time_limit, deadline, gravity, progress, two_step, start, timing, explain)


def _solve(
    result: CheckResult,
    seed: int,
    time_limit: float | None,
    deadline: float,
    gravity: bool,
    progress: Callable[[str], None] | None,
    two_step: bool,
    start: Array | None,
    timing: dict[str, float],
    explain: bool = True,
) -> SolveResult:
    from fabhal.solve import NumericFailure, SolveOptions
    from fabhal.solve import solve as run_solver

    checked = time.perf_counter()
    timing = {**timing, "solve_s": 0.0}
    codes = {d.code for d in result.diagnostics if d.is_error}
    if codes & {"E420", "E421"}:
        return SolveResult("infeasible", result, None, seed, timing)
    if not result.ok or result.model is None:
        return SolveResult("error", result, None, seed, timing)
    loops = result.report.loops if result.report is not None else None
    if loops is not None and not loops.closed:  # the time limit ended the check first
        return SolveResult("out_of_time", result, None, seed, timing)
    options = SolveOptions(
        seed=seed,
        time_limit=time_limit,
        deadline=deadline,
        gravity=gravity,
        aim=not two_step,
        progress=progress,
        start=start,
        explain=explain,
    )
    try:
        solution = run_solver(result.model, options, loops.x if loops is not None else None)
    except NumericFailure as failure:
        timing["solve_s"] = time.perf_counter() - checked
        broken = error(
            "E505",
            f"the solver failed: its numbers stopped being numbers in {failure.step}, at part "
            f"`{failure.part}`",
            result.model.program.targets[0].span,
            f"check `{failure.part}`'s definition (its mesh, mass and dimensions); if they are sound, "
            "this is a bug in FabHaL: please report it with the program",
        )
        failed = replace(result, diagnostics=tuple(sort_diagnostics([*result.diagnostics, broken])))
        return SolveResult("error", failed, None, seed, timing)
    timing["solve_s"] = time.perf_counter() - checked
    return SolveResult(solution.status, result, solution, seed, timing)


# `_library`'s last answer: the program it was built for (kept alive, so `is` is safe), and it
_last_library: tuple[LoadedProgram, Library, tuple[Diagnostic, ...]] | None = None


def _library(program: LoadedProgram) -> tuple[Library, tuple[Diagnostic, ...]]:
    """`build_library` of the program, kept for the program last asked about: a
    family's members (one program read once, other params) share its library,
    whose building cost each member 10 ms (a clip light's whole solve: 0.2 s)."""
    global _last_library
    last = _last_library
    if last is None or last[0] is not program:
        library, problems = build_library(program)
        last = _last_library = (program, library, tuple(problems))
    return last[1], last[2]


def _checked(
    program: LoadedProgram, bindings: Mapping[str, str] | None, seed: int, deadline: float
) -> CheckResult:
    library, problems = _library(program)
    flat, elaboration_problems = elaborate(program, library, bindings)
    found = [*program.diagnostics, *problems, *elaboration_problems]
    model = report = None
    if flat is not None and not has_errors([*program.diagnostics, *problems]):
        model = build_model(flat)
        report = check_program(
            CheckContext(flat, model, library, seed, deadline), complete=not has_errors(found)
        )
        found.extend(report.diagnostics)
        if report.loops is not None and report.loops.play_mm:
            model = model.with_play(report.loops.x)  # the loops close with play: the solver keeps it
    return CheckResult(program, library, flat, model, report, tuple(sort_diagnostics(merge_repeats(found))))
