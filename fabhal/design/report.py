"""What `fabhal design` prints and writes: the counts of the search, the ranked
designs, the best per number of parts, whether the inventory reaches the
target (and if not, how far off the closest design hangs), the designs as
programs and pictures."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.table import Table

from fabhal.design import DesignOptions, DesignOutcome, DesignPlan, text_of
from fabhal.design.space import RULES
from fabhal.search import rank
from fabhal.search.members import MemberResult
from fabhal.search.report import describe


def reaches(outcome: DesignOutcome, options: DesignOptions) -> bool:
    best = _best(outcome)
    return best is not None and best.status == "solved" and (best.position_mm or 0.0) <= options.tolerance_mm


def _best(outcome: DesignOutcome) -> MemberResult | None:
    ranked = rank(outcome.members)
    return ranked[0] if ranked else None


def count_lines(search: DesignPlan, outcome: DesignOutcome, options: DesignOptions) -> list[str]:
    pruned = ", ".join(
        f"{n:,} by {RULES.get(rule, rule)}" for rule, n in sorted(search.pruned.items(), key=lambda r: -r[1])
    )
    on_the_way = f" (partial designs dropped or set aside on the way: {pruned})" if pruned else ""
    if not search.generated:  # nothing to solve: say which rules ended every partial design
        connects = "connects the target to the environment"
        return [f"no design with at most {options.max_parts} parts {connects}{on_the_way}"]
    solved = sum(1 for m in outcome.members if m.status == "solved")
    rejected = sum(1 for m in outcome.members if m.status == "rejected")
    passed = "passed every rule" if search.reaching else "look too short to reach the target, every one"
    return [
        f"{search.generated:,} designs with at most {options.max_parts} parts {passed}{on_the_way}",
        f"solved {len(outcome.members)} of them, the most promising first, in {outcome.elapsed_s:.1f} s: "
        f"{solved} hang at rest, {rejected} rejected by the full check"
        + ("" if outcome.complete else " (stopped at the time limit)"),
    ]


def table(outcome: DesignOutcome, top: int) -> Table:
    result = Table(title=f"the best {min(top, len(rank(outcome.members)))} designs by settled target error")
    for heading in ("#", "design (bottom up)", "parts", "status", "mm", "deg"):
        result.add_column(heading, justify="right" if heading in ("#", "parts", "mm", "deg") else "left")
    for place, member in enumerate(rank(outcome.members)[:top], start=1):
        result.add_row(
            str(place), member.key, str(member.parts), member.status.replace("_", " "),
            f"{member.position_mm:.1f}", f"{member.rotation_deg:.1f}",
        )  # fmt: skip
    return result


def best_per_size(outcome: DesignOutcome) -> dict[int, MemberResult]:
    best: dict[int, MemberResult] = {}
    for member in rank(outcome.members):
        if member.parts is not None and member.status == "solved":
            best.setdefault(member.parts, member)
    return dict(sorted(best.items()))


def verdict(search: DesignPlan, outcome: DesignOutcome, options: DesignOptions) -> str:
    best = _best(outcome)
    if best is None and not search.generated:
        return "nothing to solve: the inventory's parts do not connect the target to the environment"
    if best is None:
        return "no design could be solved: each was rejected by the full check or not reached in time"
    error = best.position_mm or 0.0
    if reaches(outcome, options):
        within = f"within {options.tolerance_mm:g} mm"
        return f"reached: the best design settles {error:.1f} mm from the request ({within})"
    beside = all("W506" in m.notes for m in outcome.members if m.status == "solved")
    why = (
        "; every design hangs the target under the support it hangs from, and the request is beside it "
        "(W506: `fabhal solve` one, from --emit, says by how much): ask for a place under the support"
        if beside and best.status == "solved"
        else ""
    )
    return (
        f"cannot reach within {options.tolerance_mm:g} mm with this inventory: the closest design hangs the "
        f"target {error:.1f} mm from the request, {error - options.tolerance_mm:.1f} mm more than asked "
        f"({best.key}){why}"
    )


def print_summary(
    search: DesignPlan, outcome: DesignOutcome, options: DesignOptions, top: int, console: Any
) -> None:
    console.print(f"{search.spec}: " + "\n".join(count_lines(search, outcome, options)), highlight=False)
    if rank(outcome.members):
        console.print(table(outcome, top))
    for size, member in best_per_size(outcome).items():
        console.print(
            f"best with {size} part{'s' if size != 1 else ''}: {member.key}: {describe(member)}",
            highlight=False,
        )
    console.print(verdict(search, outcome, options), highlight=False)


def to_json(search: DesignPlan, outcome: DesignOutcome, options: DesignOptions) -> dict[str, Any]:
    return {
        "spec": str(search.spec),
        "generated": search.generated,
        "pruned": search.pruned,
        "solved": len(outcome.members),
        "complete": outcome.complete,
        "elapsed_s": outcome.elapsed_s,
        "reaches": reaches(outcome, options),
        "ranking": [m.key for m in rank(outcome.members)],
        "best_per_parts": {str(size): m.key for size, m in best_per_size(outcome).items()},
        "designs": [{**m.to_json(), "program": text_of(search, m.key)} for m in outcome.members],
    }


def write_outputs(
    search: DesignPlan, outcome: DesignOutcome, top: int, emit: Path | None, render: Path | None,
    options: DesignOptions,
) -> None:  # fmt: skip
    best = rank(outcome.members)[:top]
    for directory in (d for d in (emit, render) if d is not None):
        directory.mkdir(parents=True, exist_ok=True)
        for place, member in enumerate(best, start=1):
            (directory / _file_name(search, place)).write_text(text_of(search, member.key))
    if render is not None:
        _draw(search, best, render, options)


def _file_name(search: DesignPlan, place: int) -> str:
    return f"{place:02d}_{search.spec.stem}_design.fhl"


def _draw(search: DesignPlan, best: list[MemberResult], directory: Path, options: DesignOptions) -> None:
    from fabhal import api
    from fabhal.search.pictures import contact_sheet, draw_tile

    pictures = []
    for place, member in enumerate(best, start=1):
        program = directory / _file_name(search, place)
        picture = program.with_suffix(".png")
        if draw_tile(api.solve(program, seed=options.seed), f"#{place} {member.key}", picture):
            pictures.append((picture, f"#{place}  {member.parts} parts", describe(member)))
    contact_sheet(pictures, directory / "contact_sheet.png")
