"""A hook, ring or rod contact only presses: a result that needs one to pull
is not a state of rest (E512), and the solver looks for one that is (the
retries: tests/solve/test_physics.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal.solve.forces import weight_newtons
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


def test_no_lift_off_is_judged_under_a_part_deep_in_another(tmp_path: Path) -> None:
    """A paper towel roll hung by its core from a medium S-hook under a tension
    rod: its wall (29 mm from core to outside) reaches above the rod's
    underside, so the solver leaves it about 10 mm inside the rod. The
    contact springs carry the hack's whole weight at 0.2 mm of give: 10 mm in,
    they push some 50 times its weight, a load no real contact makes, and the
    statics under it had the rod "pull" the S-hook (E512, falls_apart) ahead
    of the E508 that says why; since the S-hook rests on the rod's top line
    (not its side), they pushed the roll off the S-hook's tip (E501, 217 N
    on a 3 N hack). Where a part is more than 1 mm inside another or the
    world, neither lift-offs nor its own falls are judged: E508 alone,
    not_at_rest."""
    result = solve_text(
        tmp_path,
        """\
environment rod = LongTensionRod() at (0, 0, 0)
s = DoubleHookMedium()
roll = PaperTowelRoll()
connect s.hook1 -- rod.rod
connect roll.tube -- s.hook2
target roll at (800, 127, 2000)
""",
    )
    assert result.status == "not_at_rest"
    errors = [d for d in result.diagnostics if d.is_error]
    assert [d.code for d in errors] == ["E508"]
    assert errors[0].message.startswith("`roll` is ") and "inside `rod`" in errors[0].message


# a broom handle (a tube 20 mm across) hung level from two small S-hooks, whose lower
# arcs are 19.2 mm inside: bent open round it, they grip it
BROOM_ON_TWO_SMALL_S_HOOKS = """\
environment c1 = CeilingHook() at (-150, 0, 1500)
environment c2 = CeilingHook() at (150, 0, 1500)
s1 = DoubleHook()
s2 = DoubleHook()
broom = BroomRod()
connect s1.hook2 -- c1.hook
connect s2.hook2 -- c2.hook
connect s1.hook1 -- broom.tube
connect s2.hook1 -- broom.tube
target broom.tube at (0, 0, 1383.2) rot (0, 90, 0)
"""


def test_a_hook_bent_open_round_a_handle_holds_it_all_round(tmp_path: Path) -> None:
    """Hand calculation (z up, centre lines, as the hoop's in test_ring_spin):
    each ceiling hook's arc centre is at 1500 - 61.5 = 1438.5, its wire's
    lowest point 25 below (1413.5); the S-hook's upper arc rests on it, its
    centre line 2.5 + 2 higher (1418.0), its centre 11.6 below that (1406.4),
    its lower arc's centre 23.2 lower (1383.2). The handle, 20 mm across,
    fills that arc (19.2 mm inside): its axis lies within 0.4 mm of the arc's
    centre wherever along the arc the solver puts the contact, and it hangs
    level there (1 mm: the 0.4 and the contacts' give; 0.5 degrees). Step 1
    leaves the contact at the arc's root (theta 0), where its normal points
    sideways: read as a contact that only presses, the S-hooks had to pull the
    handle (E512, falls_apart from every start). A hook bent open round what
    it holds grips it all round (`primitives.grips`), as a sleeve does: solved."""
    result = solve_text(tmp_path, BROOM_ON_TWO_SMALL_S_HOOKS)
    assert result.status == "solved", [d.message for d in result.diagnostics]
    position_mm, rotation_deg = result.solution.target_errors()
    assert position_mm < 1.0 and rotation_deg < 0.5
