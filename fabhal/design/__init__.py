"""`fabhal design`: hacks made from what the user owns.

The spec is a program with environments and a target (and perhaps some
parts already connected); the inventory says which parts the user owns.
space.py enumerates the designs those parts allow (chains from one support,
two-point hangs through a hub), dropping partial designs by the checker's
rules as they grow; the most promising (by an estimate of where each would
hang) are written as programs (program.py) and solved in parallel by the
executors of `fabhal search`; the results are ranked by settled target
error, then by number of parts."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from fabhal import api
from fabhal.design.program import design_text, summary
from fabhal.design.space import (
    Design,
    Point,
    Pruned,
    anchors,
    held_two_point,
    links,
    one_point,
    supports,
    two_point,
)
from fabhal.diagnostics import Diagnostic, error
from fabhal.elaborate import FlatProgram, PartInstance
from fabhal.inventory import Inventory
from fabhal.library import Library
from fabhal.load import load_program
from fabhal.search import stream
from fabhal.search.executors import default_jobs
from fabhal.search.members import Job, MemberResult, solve_member
from fabhal.source import SourceFile

CHUNK = 4  # designs per task
# what the checker says of a spec because it is not connected yet: not a problem here
INCOMPLETE = {"E302", "E406", "E408", "E409", "E410", "W411", "W413"}


@dataclass(frozen=True)
class DesignOptions:
    max_parts: int = 4
    budget: int = 60  # designs solved at most, the most promising first
    tolerance_mm: float = 10.0  # a design "reaches" the target when it settles this near
    seed: int = 0
    time_limit: float | None = None  # seconds for the whole search
    jobs: int = field(default_factory=default_jobs)
    executor: str | None = None


@dataclass(frozen=True)
class Candidate:
    key: str  # the design in one line, bottom up
    text: str  # the program
    parts: int
    estimate: float


@dataclass(frozen=True)
class DesignPlan:
    spec: Path
    generated: int  # designs the inventory allows that passed every rule
    pruned: dict[str, int]  # partial designs dropped, by rule
    candidates: tuple[Candidate, ...]  # those to solve, most promising first
    diagnostics: tuple[Diagnostic, ...]  # why there is nothing to design, if so
    reaching: bool = True  # False: no design is long enough; the candidates are the nearest of them
    sources: Mapping[str, SourceFile] = field(default_factory=dict)  # to quote the spec's lines


def plan(spec: Path, inventory: Inventory, options: DesignOptions) -> DesignPlan:
    """Read the spec and enumerate its designs; raises load.InputError for an unreadable file."""
    program = load_program(spec)
    checked = api.check(program)
    problems = [d for d in checked.diagnostics if d.is_error and d.code not in INCOMPLETE]
    flat = checked.flat
    if problems or flat is None or not flat.targets:
        found = problems or [error("E603", "the spec has no target", None, "add `target PART at (...)`")]
        return DesignPlan(spec, 0, {}, (), tuple(found), sources=checked.sources)
    text = checked.sources[program.main.file].text if program.main is not None else ""
    pruned = Pruned()
    every = list(_designs(flat, checked.library, inventory, options, pruned))
    reaching = [d for d in every if not d.short]
    designs = reaching or every  # nothing reaches: the nearest of those too short, to say by how much
    designs.sort(key=lambda d: (d.estimate, sum(d.parts.values())))
    unique: dict[str, Candidate] = {}
    for design in designs:
        key = summary(design)
        if key not in unique:
            title = f"designed by `fabhal design` from {spec.name}: {key}"
            unique[key] = Candidate(
                key, design_text(text, design, title), sum(design.parts.values()), design.estimate
            )
    chosen = tuple(list(unique.values())[: options.budget])
    return DesignPlan(spec, len(unique), dict(pruned.counts), chosen, (), bool(reaching), checked.sources)


def _designs(
    flat: FlatProgram, library: Library, inventory: Inventory, options: DesignOptions, pruned: Pruned
) -> Iterator[Design]:
    target = flat.targets[0]
    part = next(p for p in flat.parts if p.name == target.part)
    goal = np.array(target.position, dtype=float)
    tops = supports(flat)
    owned = dict(inventory.counts)
    options_links = links(library, owned)
    goal_z = _goal_height(part, target.primitive)
    starts = anchors(flat)
    below = {a.written: _below(a, target.part, goal_z) for a in starts}
    for anchor in starts:
        yield from one_point(
            anchor, below[anchor.written], goal, tops, options_links, owned, options.max_parts, pruned
        )
        yield from two_point(
            anchor, below[anchor.written], goal, tops, options_links, owned, options.max_parts, pruned
        )
    yield from held_two_point(starts, below, goal, tops, options_links, owned, options.max_parts, pruned)


def _below(anchor: Point, target: str, goal_z: float) -> float | None:
    """How far under the anchor the requested frame is; None, unknown, on a part
    that holds the target (a basket the target stands in tilts as it hangs from
    one handle, and what stands in it slides: a level guess set aside a design
    that reached)."""
    on_target = anchor.written.split(".")[0] == target
    return float(anchor.primitive.position[2]) - goal_z if on_target else None


def _goal_height(part: PartInstance, primitive: str | None) -> float:
    """The requested frame's height in the target part's own frame."""
    if primitive is None:
        return 0.0
    return float(next(p for p in part.spec.primitives if p.name == primitive).position[2])


@dataclass(frozen=True)
class DesignJob:
    spec: Path
    candidates: tuple[Candidate, ...]
    seed: int = 0


def solve_designs(job: DesignJob) -> list[MemberResult]:
    """Check and solve each design of the chunk (runs in a worker)."""
    results = []
    for candidate in job.candidates:
        program = load_program(job.spec, candidate.text)
        member, _ = solve_member(Job(program, ({},), job.seed), {})
        # the parts the design adds: what the spec brings (a basket the target stands in) is not counted
        results.append(
            replace(member, key=candidate.key, bindings={"design": candidate.key}, parts=candidate.parts)
        )
    return results


@dataclass(frozen=True)
class DesignOutcome:
    members: tuple[MemberResult, ...]
    elapsed_s: float
    complete: bool  # False: the time limit or Ctrl-C ended it


def run(
    search: DesignPlan,
    options: DesignOptions,
    progress: Callable[[MemberResult, int, int], None] | None = None,
) -> DesignOutcome:
    """Solve the plan's candidates in parallel, each result as it comes (to
    `progress`); the time limit or Ctrl-C ends it with what was solved."""
    started = time.perf_counter()
    deadline = started + options.time_limit if options.time_limit is not None else float("inf")
    candidates = search.candidates
    jobs = [
        DesignJob(search.spec, candidates[i : i + CHUNK], options.seed)
        for i in range(0, len(candidates), CHUNK)
    ]
    found: list[MemberResult] = []
    complete = True
    try:
        for member in stream(solve_designs, jobs, options.executor, options.jobs):
            found.append(member)
            if progress is not None:
                progress(member, len(found), len(candidates))
            if time.perf_counter() > deadline:
                complete = False
                break
    except KeyboardInterrupt:
        complete = False
    return DesignOutcome(tuple(found), time.perf_counter() - started, complete)


def text_of(search: DesignPlan, key: str) -> str:
    return next(c.text for c in search.candidates if c.key == key)
