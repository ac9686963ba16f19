"""What `fabhal search` prints and writes: the ranked table, the rejections,
the best member per value of a named param, JSON and CSV of every member."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rich.table import Table
from rich.text import Text

from fabhal.search import SearchOutcome, SearchPlan, best_by, rank, rejections
from fabhal.search.members import REJECTED, STATUS_ORDER, MemberResult

CSV_FIELDS = ("status", "position_mm", "rotation_deg", "parts", "time_s", "reason")


def categorical_params(search: SearchPlan) -> list[str]:
    """Params whose values are names (a part type such as RingM): the study
    reports its best member for each of them."""
    return [p for p in search.params if not all(_is_number(m[p]) for m in search.members)]


def counts_line(search: SearchPlan, outcome: SearchOutcome) -> str:
    sizes = " x ".join(f"{p} {len({m[p] for m in search.members})}" for p in search.params)
    statuses: dict[str, int] = {}
    for member in outcome.members:
        statuses[member.status] = statuses.get(member.status, 0) + 1
    shown = ", ".join(
        f"{status.replace('_', ' ')} {n}" for status, n in sorted(statuses.items(), key=_by_order)
    )
    sampled = f" (a sample of {len(search.members)})" if len(search.members) < search.family_size else ""
    if not search.params:  # nothing to vary: say so, the answer is `fabhal solve`'s
        return f"1 member (the program declares no `param`: a family needs some): {shown or 'none solved'}"
    return f"{_count(search.family_size, 'member')} ({sizes}){sampled}: {shown or 'none solved'}"


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _by_order(item: tuple[str, int]) -> int:
    """The ranking's order of statuses (members.STATUS_ORDER), the rejected last."""
    return STATUS_ORDER.get(item[0], len(STATUS_ORDER))


def ranked_table(search: SearchPlan, outcome: SearchOutcome, top: int) -> Table:
    table = Table(title=f"the best {min(top, len(rank(outcome.members)))} by settled target error")
    table.add_column("#", justify="right")
    for param in search.params:
        table.add_column(param)
    table.add_column("status")
    for heading in ("mm", "deg", "parts", "s"):
        table.add_column(heading, justify="right")
    for place, member in enumerate(rank(outcome.members)[:top], start=1):
        status = Text(member.status.replace("_", " "), style="green" if member.status == "solved" else "red")
        table.add_row(
            str(place),
            *(short(member.bindings[p]) for p in search.params),
            status,
            _number(member.position_mm, 1),
            _number(member.rotation_deg, 1),
            str(member.parts),
            f"{member.time_s:.2f}",
        )
    return table


def rejection_lines(outcome: SearchOutcome) -> list[str]:
    lines = []
    for rejection in rejections(outcome.members):
        lines.append(f"rejected {rejection.count} by {rejection.reason}, e.g. {rejection.member}:")
        lines.extend("  " + line for line in rejection.example.splitlines())
    return lines


def best_per_lines(search: SearchPlan, outcome: SearchOutcome) -> list[str]:
    lines = []
    for param in categorical_params(search):
        for value, member in best_by(outcome.members, param).items():
            others = " ".join(f"{p}={short(v)}" for p, v in member.bindings.items() if p != param)
            lines.append(f"best with {param}={value}: {others}: {describe(member)}")
    return lines


def describe(member: MemberResult) -> str:
    if member.status == REJECTED:
        return f"rejected ({member.reason})"
    errors = (
        f"{member.position_mm:.1f} mm, {member.rotation_deg:.1f} deg"
        if member.position_mm is not None
        else ""
    )
    state = "" if member.status == "solved" else f" ({member.status.replace('_', ' ')})"
    return f"{errors}{state}, {member.parts} part{'' if member.parts == 1 else 's'}"


def to_json(search: SearchPlan, outcome: SearchOutcome, program: str, jobs: int) -> dict[str, Any]:
    return {
        "program": program,
        "params": list(search.params),
        "family_size": search.family_size,
        "solved_here": len(outcome.members) - outcome.resumed,
        "resumed": outcome.resumed,
        "complete": outcome.complete,
        "elapsed_s": outcome.elapsed_s,
        "workers": jobs,
        "ranking": [m.key for m in rank(outcome.members)],
        "best_per": {
            param: {value: m.key for value, m in best_by(outcome.members, param).items()}
            for param in categorical_params(search)
        },
        "rejections": [
            {"reason": r.reason, "count": r.count, "example_member": r.member, "example": r.example}
            for r in rejections(outcome.members)
        ],
        "members": [m.to_json() for m in outcome.members],
    }


def write_csv(path: Path, search: SearchPlan, members: Sequence[MemberResult]) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow([*search.params, *CSV_FIELDS])
        for member in members:
            row = [member.bindings[p] for p in search.params]
            writer.writerow([*row, *("" if (v := getattr(member, f)) is None else v for f in CSV_FIELDS)])


def short(value: str) -> str:
    """A param value for reading (the log and JSON keep it exact)."""
    return f"{float(value):.6g}" if _is_number(value) else value


def _number(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
