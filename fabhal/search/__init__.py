"""`fabhal search`: every member of a program's family, checked, solved in
parallel and ranked by where its target settles.

A family is every combination of the program's `param` values
(elaborate.family). Members go to workers in chunks (local processes, a Dask
cluster, or this process), each result is appended to a log as it arrives
(so an interrupted search resumes), and the finished set is ranked: members
that hang at rest by settled target error (position, then rotation), then by
number of parts; members the check rejects are counted by reason.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Future, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np

from fabhal.diagnostics import Diagnostic
from fabhal.elaborate import family
from fabhal.inventory import Inventory
from fabhal.load import LoadedProgram, load_program
from fabhal.search.executors import default_jobs, open_executor
from fabhal.search.log import LogWriter, fingerprint, read_log
from fabhal.search.members import REJECTED, Job, MemberResult, member_key, rank_key, solve_job

J = TypeVar("J")  # a chunk of work for one task

# members per task: enough that handing out a task (pickling the program, ~5 ms)
# is small beside solving them (0.2-0.5 s each), few enough that the work
# stays spread over every worker to the end and the progress bar moves
MAX_CHUNK = 8
CHUNKS_PER_WORKER = 6


@dataclass(frozen=True)
class SearchOptions:
    pinned: Mapping[str, str] = field(default_factory=dict)  # -D: params held at one value
    sample: int | None = None  # solve a random subset of this many members
    seed: int = 0  # the solver's seed, and the sample's
    time_limit: float | None = None  # per member
    two_step: bool = False
    inventory: Inventory | None = None
    smooth: bool = False  # each member also continued from its neighbours' results (members.solve_row)
    jobs: int = field(default_factory=default_jobs)
    executor: str | None = None  # dask://HOST:PORT; None: local processes


@dataclass(frozen=True)
class SearchPlan:
    program: LoadedProgram
    params: tuple[str, ...]
    members: tuple[dict[str, str], ...]  # those to solve (after --sample), in family order
    family_size: int
    diagnostics: tuple[Diagnostic, ...]  # why there are no members, if there are none

    def fingerprint(self, options: SearchOptions) -> str:
        settings = {
            "seed": options.seed,
            "time_limit": options.time_limit,
            "two_step": options.two_step,
            "inventory": dict(options.inventory.counts) if options.inventory else None,
            "smooth": options.smooth,
        }
        return fingerprint((s.text for s in self.program.sources.values()), settings)


@dataclass(frozen=True)
class SearchOutcome:
    members: tuple[MemberResult, ...]  # every member of the plan that has a result, in family order
    resumed: int  # of them, read back from the log
    elapsed_s: float
    complete: bool  # False: interrupted (the log has what was done)


def plan(path: Path, options: SearchOptions) -> SearchPlan:
    """Read the program and list its members; raises load.InputError for an unreadable file."""
    program = load_program(path)
    members, problems = family(program, options.pinned)
    params = tuple(members[0]) if members else ()
    chosen = members
    if options.sample is not None and options.sample < len(members):
        picks = np.random.default_rng(options.seed).choice(len(members), options.sample, replace=False)
        chosen = [members[i] for i in sorted(picks)]
    return SearchPlan(program, params, tuple(chosen), len(members), (*program.diagnostics, *problems))


Progress = Callable[[MemberResult, int, int], None]  # a member, how many done, how many in all


def run(
    search: SearchPlan,
    options: SearchOptions,
    log: Path,
    resume: bool = False,
    progress: Progress | None = None,
) -> SearchOutcome:
    """Solve every member of the plan not already in the log (with `resume`),
    appending each to the log as it finishes. Ctrl-C ends it early: the outcome
    then has what was finished, and the log lets `resume` go on from there."""
    started = time.perf_counter()
    stamp = search.fingerprint(options)
    keys = [member_key(m) for m in search.members]
    logged = read_log(log, stamp) if resume and log.is_file() else {}
    done = {key: logged[key] for key in keys if key in logged}
    todo = [m for m, key in zip(search.members, keys, strict=True) if key not in done]
    writer = LogWriter(log, search.program.main.file if search.program.main else "", stamp, resume)
    results = dict(done)
    complete = True
    try:
        for member in _solved(search.program, todo, options):
            writer.add(member)
            results[member.key] = member
            if progress is not None:
                progress(member, len(results), len(search.members))
    except (KeyboardInterrupt, BrokenProcessPool):
        complete = False
    finally:
        writer.close()
    ordered = tuple(results[key] for key in keys if key in results)
    return SearchOutcome(ordered, len(done), time.perf_counter() - started, complete)


def _solved(
    program: LoadedProgram, todo: Sequence[dict[str, str]], options: SearchOptions
) -> Iterator[MemberResult]:
    """The members' results as they finish, from whichever executor was asked for."""
    if not todo:
        return
    chunks = _rows(todo) if options.smooth else _chunks(todo, options.jobs)
    settings = (options.seed, options.time_limit, options.two_step, options.inventory, options.smooth)
    jobs = [Job(program, tuple(chunk), *settings) for chunk in chunks]
    yield from stream(solve_job, jobs, options.executor, options.jobs)


def stream(
    solve: Callable[[J], list[MemberResult]], jobs: Sequence[J], executor: str | None, workers: int
) -> Iterator[MemberResult]:
    """`solve` over `jobs` (each a chunk of work), the results as each chunk
    finishes: in this process for one local worker, else on `workers` local
    processes or the Dask cluster at `executor`. Used by `fabhal search` and
    `fabhal design`."""
    if executor is None and workers <= 1:  # this process, each result as it comes
        for job in jobs:
            yield from solve(job)
        return
    with open_executor(executor, workers) as pool:
        futures: list[Future[list[MemberResult]]] = [pool.submit(solve, job) for job in jobs]
        try:
            for future in as_completed(futures):
                yield from future.result()
        finally:
            for future in futures:
                future.cancel()


def _chunks(todo: Sequence[dict[str, str]], workers: int) -> list[Sequence[dict[str, str]]]:
    size = max(1, min(MAX_CHUNK, math.ceil(len(todo) / (workers * CHUNKS_PER_WORKER))))
    return [todo[i : i + size] for i in range(0, len(todo), size)]


def _rows(todo: Sequence[dict[str, str]]) -> list[list[dict[str, str]]]:
    """Runs of members that differ only in the last param (consecutive in family
    order): the neighbours `--smooth` continues from."""
    rows: list[list[dict[str, str]]] = []
    for member in todo:
        if rows and list(rows[-1][-1].values())[:-1] == list(member.values())[:-1]:
            rows[-1].append(member)
        else:
            rows.append([member])
    return rows


def rank(members: Sequence[MemberResult]) -> list[MemberResult]:
    """Members that were solved, best first: those at rest by settled target
    error (position, then rotation), then by number of parts; then the others
    by how far they got."""
    solved = [m for m in members if m.status != REJECTED and m.position_mm is not None]
    return sorted(solved, key=rank_key)


@dataclass(frozen=True)
class Rejection:
    reason: str  # a diagnostic code
    count: int
    example: str  # the first such member's diagnostic, as `fabhal check` prints it
    member: str


def rejections(members: Sequence[MemberResult]) -> list[Rejection]:
    """Members the check (or the inventory) rejected, counted by reason, most first."""
    found: dict[str, list[MemberResult]] = {}
    for member in members:
        if member.status == REJECTED:
            found.setdefault(member.reason or "?", []).append(member)
    counted = [
        Rejection(code, len(group), group[0].example or "", group[0].key) for code, group in found.items()
    ]
    return sorted(counted, key=lambda r: (-r.count, r.reason))


def best_by(members: Sequence[MemberResult], param: str) -> dict[str, MemberResult]:
    """The best member for each value of `param` (e.g. per ring size), in the order the values came."""
    best: dict[str, MemberResult] = {}
    for member in rank(members):
        best.setdefault(member.bindings[param], member)
    order = list(dict.fromkeys(m.bindings[param] for m in members))
    return {value: best[value] for value in order if value in best}
