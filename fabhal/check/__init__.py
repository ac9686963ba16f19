"""Every rule of connecting, checked before any solving; see docs/errors.md (E4xx).

The pipeline is the list below, in order; each rule returns diagnostics at
the `connect` (or declaration) that causes them. The loop check runs last,
and only when the rules before it found no error (a loop with a forbidden
connection in it is not worth solving).
"""

from __future__ import annotations

from dataclasses import dataclass

from fabhal.check import connectivity, cycles, dimensions, graph
from fabhal.check.context import CheckContext
from fabhal.diagnostics import Diagnostic, has_errors

# rules about one connection at a time: they run even when other lines have errors
LOCAL_RULES = (
    connectivity.check,
    dimensions.check,
)
RULES = (*LOCAL_RULES, graph.check)


@dataclass(frozen=True)
class CheckReport:
    diagnostics: tuple[Diagnostic, ...]
    loops: cycles.LoopReport | None  # DoFs that close the loops, to start the solver from


def check_program(ctx: CheckContext, complete: bool = True) -> CheckReport:
    """Run the rules; with `complete` False (some lines failed to elaborate, so the
    program is partial) only the rules about single connections."""
    problems: list[Diagnostic] = []
    for rule in RULES if complete else LOCAL_RULES:
        problems.extend(rule(ctx))
    if not complete:
        return CheckReport(tuple(problems), None)
    loops = None
    if not has_errors(problems):
        cycle_problems, loops = cycles.check(ctx)
        problems.extend(cycle_problems)
    return CheckReport(tuple(problems), loops)


__all__ = ["LOCAL_RULES", "RULES", "CheckContext", "CheckReport", "check_program"]
