"""One member of a family, solved: what a worker sends back and the log keeps."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, cast

from fabhal import api
from fabhal.diagnostics import Diagnostic, render_text
from fabhal.inventory import Inventory, over_inventory, parts_used
from fabhal.load import LoadedProgram

if TYPE_CHECKING:
    from fabhal.solve import Solution

# api statuses for a member that never reached the solver: the check rejected it
REJECTED = "rejected"
CHECK_REJECTS = {"error", "infeasible"}


def member_key(bindings: Mapping[str, str]) -> str:
    """The member's name in the log and the tables: `n=2 extension=4.57`."""
    return " ".join(f"{name}={value}" for name, value in bindings.items())


@dataclass(frozen=True)
class MemberResult:
    key: str
    bindings: dict[str, str]
    status: str  # solved, not_at_rest, falls_apart, out_of_time, or rejected (never solved)
    position_mm: float | None = None  # settled target error
    rotation_deg: float | None = None
    parts: int | None = None  # parts used (environments and the target not counted)
    time_s: float = 0.0
    reason: str | None = None  # rejected: the first error's code (E421, E602, ...)
    example: str | None = None  # rejected: that error as `fabhal check` prints it
    notes: tuple[str, ...] = field(default=())  # codes of the solver's notes (N506 aimed, ...)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["notes"] = list(self.notes)
        return data

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> MemberResult:
        return cls(**{**data, "notes": tuple(data.get("notes", ()))})


@dataclass(frozen=True)
class Job:
    """A chunk of members for one worker: the program read once by the caller
    (pickled with the job, so workers on other machines need no copy of it)."""

    program: LoadedProgram
    members: tuple[dict[str, str], ...]
    seed: int = 0
    time_limit: float | None = None
    two_step: bool = False
    inventory: Inventory | None = None


def solve_job(job: Job) -> list[MemberResult]:
    """Check and solve each member of the chunk in turn (runs in a worker)."""
    return [solve_member(job, bindings) for bindings in job.members]


def solve_member(job: Job, bindings: dict[str, str]) -> MemberResult:
    started = time.perf_counter()
    checked = api.check(job.program, bindings, job.seed)
    first_error = next((d for d in checked.diagnostics if d.is_error), None)
    if first_error is None and job.inventory is not None and checked.flat is not None:
        first_error = over_inventory(job.inventory, checked.flat)
    if first_error is not None:
        return _rejected(job, bindings, first_error, time.perf_counter() - started)
    assert checked.flat is not None  # a program without errors has been elaborated
    result = api.solve(job.program, bindings, job.seed, job.time_limit, two_step=job.two_step)
    elapsed = time.perf_counter() - started
    if result.status in CHECK_REJECTS:  # the loops' closure can still reject it (E420, E421)
        return _rejected(job, bindings, next(d for d in result.diagnostics if d.is_error), elapsed)
    parts = sum(parts_used(checked.flat).values())
    if result.solution is None:
        return MemberResult(member_key(bindings), bindings, result.status, parts=parts, time_s=elapsed)
    position, rotation = cast("Solution", result.solution).target_errors()
    notes = tuple(sorted({d.code for d in result.diagnostics if not d.is_error}))
    return MemberResult(
        member_key(bindings), bindings, result.status, position, rotation, parts, elapsed, notes=notes
    )


def _rejected(job: Job, bindings: dict[str, str], problem: Diagnostic, elapsed: float) -> MemberResult:
    example = render_text(problem, job.program.sources)
    return MemberResult(
        member_key(bindings), bindings, REJECTED, time_s=elapsed, reason=problem.code, example=example
    )
