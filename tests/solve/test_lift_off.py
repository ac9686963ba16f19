"""A hook, ring or rod contact only presses: a result that needs one to pull
is not a state of rest (E512), and the solver looks for one that is."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal import api
from fabhal.solve.forces import weight_newtons
from tests.conftest import REPO
from tests.solve.test_physics import solve_text

# the S-hook's contact written at theta 300, the top of the ceiling hook's ring
# (its arc runs from the tip at 0 down to its bottom near 120 and up to the shank):
# there the ring's wire lies above the S-hook's wire
INSIDE_THE_TOP = """\
environment ceiling = CeilingHook() at (0, 0, 2000)
s = DoubleHook()
connect s.hook2 -- ceiling.hook set (ceiling.hook.theta: 300)
target s at (0, 0, 1900)
"""


def test_a_hook_hung_from_the_inside_of_a_rings_top_lifts_off(tmp_path: Path) -> None:
    """The S-hook (10.85 g: its mesh's volume in steel) hangs from the
    inside of the ceiling hook's ring at its top, where the ring's wire is
    above its own: to hold it there the ring would have to pull it up with
    its whole weight, 10.85 g x 9.81 m/s^2 = 0.1064 N (the statics' force
    along the contact's normal, to 1e-6 N: a least-squares solve of a
    determinate balance). A contact only presses, so the S-hook drops off:
    falls_apart, E512 at the connection's line, naming the pull."""
    result = solve_text(tmp_path, INSIDE_THE_TOP)
    solution = result.solution
    assert result.status == "falls_apart"
    (mass,) = [m for m in solution.masses if m > 0]
    assert mass == pytest.approx(10.85, abs=0.01)
    weight = float(weight_newtons(solution.masses).sum())
    assert weight == pytest.approx(0.1064, abs=1e-4)
    (lift,) = solution.falls
    assert lift.pull == pytest.approx(weight, abs=1e-6)
    (error,) = [d for d in result.diagnostics if d.code == "E512"]
    assert error.span is not None and error.span.line == 3
    assert "`ceiling.hook` would have to pull `s.hook2` with 0.11 N" in error.message


def test_the_same_hook_at_the_bottom_of_the_ring_hangs(tmp_path: Path) -> None:
    """The same S-hook with its contact at the ring's bottom (theta 120):
    the ring's wire lies beneath it and pushes it up with its weight,
    0.1064 N along the contact's normal: solved, nothing lifts off."""
    result = solve_text(tmp_path, INSIDE_THE_TOP.replace("theta: 300", "theta: 120"))
    assert result.status == "solved", result.diagnostics
    assert not [d for d in result.diagnostics if d.code == "E512"]


def test_a_start_that_lifts_off_is_left_for_one_that_hangs(monkeypatch: pytest.MonkeyPatch) -> None:
    """The policy, with the attempts stood in for: from the first start a
    contact would have to pull (E512, as a bird feeder on two S-hooks once
    settled, its upper hook inside the top of the ceiling hook's ring); the
    next start hangs at rest. As for a fall: the retry is the answer, and
    N504 at the connection says the first start lifted off there. A retry
    whose loops are open holds nothing (E506) and is not taken."""
    import dataclasses

    import fabhal.solve as solver

    real = api.solve(REPO / "programs" / "mug_hanger.fhl").solution
    assert real is not None and real.status == "solved"
    lift = solver.LiftOff(joint=0, holder="rod.rod", held="chain.s[1].hook2", part="chain.s[1]", pull=0.1)
    seeds: list[int] = []

    def attempt(model, options, loop_start):  # type: ignore[no-untyped-def]
        seeds.append(options.seed)
        if options.seed == 0:
            return dataclasses.replace(real, status="falls_apart", falls=(lift,))
        if options.seed == 1:  # nothing falls, but a loop is open: not holding
            return dataclasses.replace(real, status="not_at_rest", residual=1.0)
        return real

    monkeypatch.setattr(solver, "_solve_once", attempt)
    result = solver.solve(real.model, solver.SolveOptions(seed=0))
    assert seeds == [0, 1, 2] and result.status == "solved"
    (note,) = [d for d in result.diagnostics if d.code == "N504"]
    assert "`chain.s[1]` lifted off its contact" in note.message and "seed 2" in note.message
