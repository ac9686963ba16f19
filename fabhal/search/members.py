"""One member of a family, solved: what a worker sends back and the log keeps."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any, cast

from fabhal import api
from fabhal.diagnostics import Diagnostic, render_text
from fabhal.inventory import Inventory, over_inventory, parts_used
from fabhal.load import LoadedProgram

if TYPE_CHECKING:
    from fabhal.kinematics.frames import Array
    from fabhal.solve import Solution

# a member that never reached the solver: the check (or the inventory) rejected it
REJECTED = "rejected"
# the order of statuses in the ranking, after the members that hang at rest
STATUS_ORDER = {"solved": 0, "not_at_rest": 1, "falls_apart": 2, "out_of_time": 3}


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
    # --smooth: the neighbour whose solved settings this result continued from (None: its own solve)
    reached_from: str | None = None
    aimed: str | None = None  # the solver's N506: the settings to build, in a builder's words
    # --smooth, a continued result: its configuration (Solution.x), to draw it as it was found
    x: tuple[float, ...] | None = None

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["notes"] = list(self.notes)
        data["x"] = list(self.x) if self.x is not None else None
        return data

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> MemberResult:
        x = data.get("x")
        return cls(
            **{**data, "notes": tuple(data.get("notes", ())), "x": tuple(x) if x is not None else None}
        )


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
    smooth: bool = False  # the members are one row of the family: see solve_row


def solve_job(job: Job) -> list[MemberResult]:
    """Check and solve each member of the chunk in turn (runs in a worker)."""
    if job.smooth:
        return solve_row(job)
    return [solve_member(job, bindings)[0] for bindings in job.members]


def rank_key(member: MemberResult) -> tuple[int, float, float, int]:
    """The search's order: at rest first, then settled position error, rotation, parts."""
    return (
        STATUS_ORDER.get(member.status, len(STATUS_ORDER)),
        member.position_mm if member.position_mm is not None else math.inf,
        member.rotation_deg if member.rotation_deg is not None else math.inf,
        member.parts or 0,
    )


def solve_row(job: Job) -> list[MemberResult]:
    """`--smooth`: the members of one row of the family (every param the same but
    the last), each solved on its own, then again from its neighbour's solved
    configuration where the neighbour hangs nearer: with the neighbour's
    settings aimed again, and kept as they are; each member keeps the best
    result (rank_key). Sweeps go up the row and down, and again (SMOOTH_SWEEPS
    at most) while a sweep changed a result: one found sweeping down is offered
    to the members above it only by the next sweep up. A neighbour's settings
    (where a clip grips, where a hook sits on a rod) are the builder's to reuse,
    so a member never lands far worse than the one beside it: the family's
    errors stop jumping. Each member tries each result of a neighbour once."""
    found = [solve_member(job, bindings) for bindings in job.members]
    versions = [0] * len(found)  # how often each member's result changed
    tried: set[tuple[int, int, int]] = set()  # (member, neighbour, the neighbour's version)
    for sweep in range(SMOOTH_SWEEPS):
        step = -1 if sweep % 2 == 0 else 1  # up the row: from the one below
        order = range(1, len(found)) if step == -1 else range(len(found) - 2, -1, -1)
        changed = False
        for k in order:
            attempt = (k, k + step, versions[k + step])
            if attempt in tried:
                continue
            tried.add(attempt)
            continued = _continued_from(job, k, found[k], found[k + step])
            if continued is not None:
                found[k], nearer = continued
                if nearer:
                    versions[k], changed = versions[k] + 1, True
        if sweep > 0 and not changed:
            break
    return [member for member, _ in found]


# sweeps of `solve_row` at most: up, down, and up and down again where the second
# found nearer results (a row's results stop changing within these on the clip lights)
SMOOTH_SWEEPS = 4
Solved = tuple[MemberResult, "Array | None"]


def _continued_from(job: Job, k: int, own: Solved, neighbour: Solved) -> tuple[Solved, bool] | None:
    """Member k solved again from its neighbour's configuration, if the neighbour
    hangs nearer: the best of its result and the continued ones, with the time
    spent on all of them, and whether a continued one was best (None: not tried)."""
    (result, _), (beside, start) = own, neighbour
    # only a neighbour that hangs nearer has settings worth trying here
    if start is None or result.status == REJECTED or rank_key(beside) >= rank_key(result):
        return None
    started = time.perf_counter()
    # the neighbour's settings aimed again for this member, and kept exactly as they are
    # (settled only): aiming weighs rotation with position, the search ranks position first
    tries = [solve_member(replace(job, two_step=kept), job.members[k], start, beside.key)
             for kept in (job.two_step, True)]  # fmt: skip
    spent = result.time_s + time.perf_counter() - started
    best = min([own, *tries], key=lambda tried: rank_key(tried[0]))
    # kept as they are, the settings to build are the neighbour's
    aimed = best[0].aimed or (beside.aimed if best[0].reached_from else None)
    return (replace(best[0], time_s=spent, aimed=aimed), best[1]), best is not own


def solve_member(
    job: Job, bindings: dict[str, str], start: Array | None = None, reached_from: str | None = None
) -> tuple[MemberResult, Array | None]:
    """One member checked and solved (from `start` if given); its result and,
    when it was solved, its configuration."""
    started = time.perf_counter()
    checked = api.check(job.program, bindings, job.seed)
    first_error = next((d for d in checked.diagnostics if d.is_error), None)
    if first_error is None and job.inventory is not None and checked.flat is not None:
        first_error = over_inventory(job.inventory, checked.flat)
    if first_error is not None:
        return _rejected(job, bindings, first_error, time.perf_counter() - started), None
    assert checked.flat is not None  # a program without errors has been elaborated
    # a member's notes are kept as codes: W505 without the fit that says what limits the reach
    result = api.solve_checked(
        checked, job.seed, job.time_limit, two_step=job.two_step, start=start, explain=False
    )
    elapsed = time.perf_counter() - started
    if result.status == "error":  # the solver failed (E505): counted with the rejected, by its code
        return _rejected(job, bindings, next(d for d in result.diagnostics if d.is_error), elapsed), None
    parts = sum(parts_used(checked.flat).values())
    key = member_key(bindings)
    if result.solution is None:
        return MemberResult(key, bindings, result.status, parts=parts, time_s=elapsed), None
    solution = cast("Solution", result.solution)
    position, rotation = solution.target_errors()
    notes = tuple(sorted({d.code for d in result.diagnostics if not d.is_error}))
    aimed = next((d.message for d in result.diagnostics if d.code == "N506"), None)
    x = tuple(float(v) for v in solution.x) if reached_from is not None else None
    member = MemberResult(
        key, bindings, result.status, position, rotation, parts, elapsed, notes=notes,
        reached_from=reached_from, aimed=aimed, x=x,
    )  # fmt: skip
    return member, solution.x


def _rejected(job: Job, bindings: dict[str, str], problem: Diagnostic, elapsed: float) -> MemberResult:
    example = render_text(problem, job.program.sources)
    return MemberResult(
        member_key(bindings), bindings, REJECTED, time_s=elapsed, reason=problem.code, example=example
    )
