"""`--smooth`'s sweeps along a row (fabhal/search/members.py `solve_row`), on
a row whose solves are stood in for: the order of continuations is the
subject, not the solver (tests/search/test_search.py runs the real one)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from fabhal.search import members
from fabhal.search.members import Job, MemberResult, solve_row

# member -> its own settled error (mm); (member, error of the neighbour it continues
# from) -> the error continued from there. B continued from C lands nearer than C
# itself (a neighbour's settings can suit a member better than their own): only a
# sweep back up then offers B's result to C.
OWN = {"A": 50.0, "B": 60.0, "C": 40.0}
CONTINUED = {("B", 50.0): 58.0, ("B", 40.0): 20.0, ("A", 20.0): 25.0, ("C", 20.0): 25.0}


def stand_in(job: Job, bindings: dict[str, str], start: Any = None, reached_from: Any = None) -> Any:
    name = bindings["m"]
    error = OWN[name] if start is None else CONTINUED.get((name, float(start[0])), 99.0)
    result = MemberResult(name, bindings, "solved", error, 0.0, 1, reached_from=reached_from)
    return result, np.array([error])


def test_a_result_found_sweeping_down_is_offered_back_up(monkeypatch: pytest.MonkeyPatch) -> None:
    """Up: B from A (50 < 60) lands at 58; C (40) is nearer than B and keeps
    its own. Down: B from C lands at 20, A from B at 25. One sweep each way
    would stop there with C at 40 beside B at 20; the next sweep up continues
    C from B's new result: 25 (B is not continued from A's 25 again: it hangs
    nearer). Then nothing changes and the sweeps end: 4 continuations (B from
    A and from C, A from B, C from B), each solved twice (aimed and kept)."""
    calls: list[tuple[str, float | None]] = []

    def counted(job: Job, bindings: dict[str, str], start: Any = None, reached_from: Any = None) -> Any:
        calls.append((bindings["m"], None if start is None else float(start[0])))
        return stand_in(job, bindings, start, reached_from)

    monkeypatch.setattr(members, "solve_member", counted)
    job = Job(program=None, members=({"m": "A"}, {"m": "B"}, {"m": "C"}), smooth=True)  # type: ignore[arg-type]
    row = solve_row(job)
    assert [m.position_mm for m in row] == [25.0, 20.0, 25.0]
    assert [m.reached_from for m in row] == ["B", "C", "B"]
    continued = [call for call in calls if call[1] is not None]
    assert sorted(set(continued)) == [("A", 20.0), ("B", 40.0), ("B", 50.0), ("C", 20.0)]
    assert len(continued) == 2 * 4  # aimed and kept, once each
