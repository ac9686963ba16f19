"""Aiming (fabhal/solve/aim.py): what the builder sets once (where a part is
placed on a rod that friction holds, a clip's grip) is chosen so that the
settled hack hangs nearest the request, never worse than the paper's two steps.

Tolerances: positions to a few millimetres (the settle stops at 1e-4 of the
weight per mm; the effects asserted are tens of millimetres); the aimed
placement to 3 % of the bar (a few mm of a 390 mm bar move the ring less than 1 mm).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fabhal import api
from fabhal.solve import Solution, _mass_table
from tests.conftest import REPO, written_in_reverse


def solution_of(path: Path, two_step: bool = False) -> tuple[str, Solution, tuple[str, ...]]:
    result = api.solve(path, two_step=two_step)
    assert isinstance(result.solution, Solution)
    return result.status, result.solution, tuple(d.code for d in result.diagnostics)


def dof(solution: Solution, name: str) -> float:
    names = [variable.name for variable in solution.model.variables]
    return float(solution.x[names.index(name)])


def test_the_demo_places_the_s_hook_where_the_ring_hangs_at_the_request() -> None:
    """Demo: a wire hanger on a rod, an S-hook on its bar, a curtain ring on the
    S-hook. The hanger is symmetric about its hook: with the S-hook at the
    middle of its bar (t = 0.5, 195 mm of 390) its bar hangs level and the ring
    hangs straight below the hanger's hook, at the request (0, 2.1, 142): the
    issue measured 2.3 mm there. Step 1 left the S-hook at 86 % of the bar, and
    the hanger, tilting under it, put the ring 117 mm away (--two-step keeps
    that). Aimed: within the issue's 15 mm, the S-hook within 3 % of the middle,
    and N506 says where to place it."""
    status, aimed, codes = solution_of(REPO / "programs" / "demo.fhl")
    assert status == "solved" and "N506" in codes
    assert aimed.target_errors()[0] < 15.0
    assert dof(aimed, "hanger.rod.t") == pytest.approx(0.5, abs=0.03)
    status, paper, codes = solution_of(REPO / "programs" / "demo.fhl", two_step=True)
    assert status == "solved" and "N506" not in codes
    assert paper.target_errors()[0] > 100.0


def test_the_note_says_which_end_a_place_on_a_bar_is_measured_from() -> None:
    """A builder measures along the hanger's bar from one end: N506 names it by
    what lies there. The wire hanger's bar runs along y in its frame, t = 0 at
    y = -195; its corner bend hook3 is at y = -194.1 (0.9 mm from that end, 389
    from the other), so the demo's S-hook is "192 mm along hanger.rod (of 390)
    from its end by `hanger.hook3`". The tension rod of the demo, the only
    primitive of its part, is measured as before, with no end named."""
    result = api.solve(REPO / "programs" / "demo.fhl")
    (note,) = [d for d in result.diagnostics if d.code == "N506"]
    assert "192 mm along hanger.rod (of 390) from its end by `hanger.hook3`" in note.message
    assert "mm along rod.rod (of 500);" in note.message or note.message.endswith("mm along rod.rod (of 500)")


def test_a_turn_reads_within_one_turn() -> None:
    """A DoF that turns freely (the demo's ring round its own wire) settles
    wherever its path leaves it, two turns and 70 degrees on (790) as well as
    at 70: a builder sets 70 degrees, and that is what the setting says."""
    from fabhal.solve.aim import setting_text

    model = api.check(REPO / "programs" / "demo.fhl").model
    assert model is not None
    i = next(i for i, v in enumerate(model.variables) if v.dof.periodic)
    assert setting_text(model, i, 790.0, 1.0) == setting_text(model, i, 70.0, 1.0)
    assert "70 degrees" in setting_text(model, i, 790.0, 1.0)


def test_the_clip_light_is_aimed_as_near_as_its_own_balance_allows() -> None:
    """Clip light M: the light (200 g) grips the hanger's bar with a `fixed`
    clip; the clip's place on the bar and its grip angles are chosen. Aimed, it
    hangs nearer than step 1's choices left it (32.3 mm, 7.8 degrees).

    Why not within 10 mm and 5 degrees (the issue's hope): held at the
    requested frame, the clip has the light's centre of mass 39 mm to one side
    of it (measured below). Everything hangs from one ceiling hook, so the
    hanger (83 g) would have to hold its own centre of mass 39 x 200 / 83 =
    94 mm to the other side of the line below the hook, tilting its bar, and
    the clip with it, by tens of degrees: a tilt within 5 degrees moves the
    hanger's centre of mass (about 100 mm below its hook) by at most
    100 sin 5 = 9 mm, the light by 9 x 83 / 200 = 4 mm of the 39. The aimed
    answer balances the two errors: under 28 mm and 5 degrees. N506 says how
    the clip is turned about the bar and where it grips (along the bar, or
    along its own jaws: those that moved from step 1's choice).

    Nor within 10 mm at any tilt under 5 degrees: the chain hangs straight
    below the ceiling hook, so the hanger's hook P is there. With the clip
    within 10 mm of P's vertical the light's centre of mass is at least 29 mm
    to one side, so the hanger's, 146.6 mm below P (its bar 200 mm below),
    would have to be 29 x 200 / 83 = 70 mm to the other: swung out of its
    plane it moves 146.6 / 200 as far as the clip (at most 7.3 mm), tilted in
    its plane within 5 degrees at most 146.6 sin 5 = 12.8 mm more."""
    result = api.solve(REPO / "programs" / "clip_light_m.fhl")
    status, aimed = result.status, result.solution
    assert status == "solved" and isinstance(aimed, Solution)
    (note,) = [d for d in result.diagnostics if d.code == "N506"]
    # as a builder sets it: where it grips, how the clip is turned about the bar
    assert "mm along hanger.rod (of 385)" in note.message or "mm along light.clip (of 30)" in note.message
    assert "degrees about hanger.rod" in note.message
    position, rotation = aimed.target_errors()
    assert position < 28.0 and rotation < 5.0
    model = aimed.model
    light = model.part_index("light")
    masses, centres = _mass_table(model)
    assert masses[light] == pytest.approx(200.0)
    achieved = aimed.target_frame()
    relative = np.linalg.inv(achieved) @ aimed.frames[light]
    at_request = aimed.goal.requested @ relative
    centre = at_request[:3, :3] @ centres[light] + at_request[:3, 3]
    sideways = np.linalg.norm(centre[:2] - aimed.goal.requested[:2, 3])
    assert sideways == pytest.approx(39.0, abs=2.0)


def test_aiming_keeps_an_answer_it_cannot_better(tmp_path: Path) -> None:
    """The mug hanger's only choice is where the top S-hook sits on the rod,
    and the mug already hangs 0.3 mm from its request: aiming finds nothing
    nearer (its answer ranks no better), so the result is the two steps' own,
    to the settle's precision, and no N506."""
    _, aimed, codes = solution_of(REPO / "programs" / "mug_hanger.fhl")
    _, paper, _ = solution_of(REPO / "programs" / "mug_hanger.fhl", two_step=True)
    assert "N506" not in codes
    assert np.abs(aimed.x - paper.x).max() < 1e-9


def test_the_aimed_demo_is_the_same_in_any_order_of_lines(tmp_path: Path) -> None:
    """The demo's connections written in reverse: the same aimed answer (the
    model orders connections canonically; 0.01 mm is far below the 117 mm the
    aim gains)."""
    (tmp_path / "demo.fhl").write_text(written_in_reverse((REPO / "programs" / "demo.fhl").read_text()))
    _, forwards, _ = solution_of(REPO / "programs" / "demo.fhl")
    _, backwards, _ = solution_of(tmp_path / "demo.fhl")
    assert np.linalg.norm(forwards.target_frame()[:3, 3] - backwards.target_frame()[:3, 3]) < 0.01


def test_an_aimed_settle_that_falls_is_not_refined(monkeypatch: pytest.MonkeyPatch) -> None:
    """A settle made to be compared with a result in hand that does not fall
    (the aim's) ends after a round of contact whose result falls (here a
    lean on its stop): that result ranks behind any that holds (`_rank`), and
    the finer rounds, which only add contact, are the slow ones (the reading
    nook once spent 1.2 s on two more rounds that fell again). Rounds are
    stood in for: each settle falls and the check always finds a missed
    contact, so without a rival all CONTACT_ROUNDS run, and one settle more
    from the last one's result with the contact it missed."""
    import fabhal.solve as solve_module
    from fabhal.solve import CONTACT_ROUNDS, Lean, Settled, _settle

    program = api.check(REPO / "programs" / "mug_hanger.fhl")
    assert program.model is not None
    step1, _ = solve_module.step_one(program.model, 0, None, float("inf"))
    x = step1.x_base.copy()
    falling = Settled(x, 1e-5, (), (Lean(0, 0, "max", 0.02, "s1"),))
    rounds: list[int] = []

    def settle_with(*_: object) -> Settled:
        rounds.append(1)
        return falling

    class Pairs:
        def __init__(self, size: int = 0) -> None:
            self.points = size

        def refined(self, _: object) -> Pairs:
            return Pairs(self.points + 1)  # always more contact to add

        def dense(self, _: object) -> Pairs:
            return self

        def size(self) -> int:
            return self.points

    monkeypatch.setattr(solve_module, "_settle_with", settle_with)
    monkeypatch.setattr(solve_module, "_first_settle", lambda *_: None)  # every round settled whole
    monkeypatch.setattr(solve_module, "_springs", lambda *_: None)
    monkeypatch.setattr(solve_module, "passing_through", lambda *_: frozenset())
    monkeypatch.setattr(solve_module, "_parts_inside", lambda *_: frozenset())
    monkeypatch.setattr(solve_module, "_missed", lambda *_: {})
    masses, centres = _mass_table(program.model)
    goal = solve_module.target_mod.goal_of(program.model)
    alone = _settle(step1, x, masses, centres, goal, Pairs())  # type: ignore[arg-type]
    assert len(rounds) == CONTACT_ROUNDS + 1 and alone.falls
    rounds.clear()
    holding = Settled(x, 1e-5, (), ())
    _settle(step1, x, masses, centres, goal, Pairs(), rival=holding)  # type: ignore[arg-type]
    assert len(rounds) == 1
    rounds.clear()
    _settle(step1, x, masses, centres, goal, Pairs(), rival=falling)  # type: ignore[arg-type]
    assert len(rounds) == CONTACT_ROUNDS + 1  # both fall: the finer rounds may tell them apart
