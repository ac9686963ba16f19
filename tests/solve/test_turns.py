"""Two loops hooked into each other (S-hook on S-hook) each turn about the one
line of their contact: their turns add, and together they turn only until a
wire jams (fabhal/model.py `TurnLimit`): folded into one DoF without loops,
two linear rows with them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fabhal import api
from fabhal.model import Model
from tests.conftest import REPO
from tests.solve.test_physics import solve_text

# the upper S-hook's own turn on the rod is set square, so every turn of the lower one
# about the vertical is the two hooks turning on each other
TWO_S_HOOKS = """\
environment rod = Rod(length: 400, radius: 2) at (0, 0, 300) rot (90, 0, 90)
top = DoubleHook()
low = DoubleHook()
connect top.hook2 -- rod set (top.hook2.phi: 90)
connect low.hook2 -- top.hook1
target low at (0, 0, 230) rot (0, 0, 0)
"""

# DoubleHook: arc radius 11.6 mm, wire 2 mm thick, so 9.6 mm inside; the other's wire
# is 2 mm across its radius. The wire jams at cos^2 b = 2 / 9.6 (primitives.yaw_jam_deg)
JAM_DEG = math.degrees(math.acos(math.sqrt(2.0 / 9.6)))


def turned_on_each_other(model: Model, x: np.ndarray) -> float:
    """Degrees the lower hook is turned on the upper one from square, read off
    the parts' frames (not off the flex angles): the rotation between their
    relative orientation at x and at x with both flex angles square (90)."""
    names = {v.name: i for i, v in enumerate(model.variables)}
    square = x.copy()
    square[[names["low.hook2.phi"], names["top.hook1.phi"]]] = 90.0

    def relative(at: np.ndarray) -> np.ndarray:
        frames = model.part_frames(at)
        return frames[model.part_index("top")][:3, :3].T @ frames[model.part_index("low")][:3, :3]

    turn = relative(square).T @ relative(x)
    return math.degrees(math.acos(np.clip((np.trace(turn) - 1.0) / 2.0, -1.0, 1.0)))


def test_the_jam_of_two_small_s_hooks_is_the_hand_value() -> None:
    """acos(sqrt(2 / 9.6)) = 62.84 degrees: the value the tests below use."""
    assert pytest.approx(62.84, abs=0.01) == JAM_DEG


def test_two_s_hooks_turn_on_each_other_only_until_the_wire_jams(tmp_path: Path) -> None:
    """The request asks for the lower S-hook turned about the vertical further
    than the wires allow. Each hook's flex angle alone has the model's range,
    45 degrees either way (its jam, 62.84, lies beyond), so before the turns
    were bounded together the two hooks turned 45 + 45 = 90 degrees on each
    other, a wire through a wire. Now they stop together at the jam. Step 1
    (gravity off), which the request pulls onto the stop, turns the lower
    hook by the jam on the upper, read off the frames (0.01 degree: a bound
    the optimiser keeps exactly); without loops the pair is folded into one
    DoF, the other side stays square (90 exactly). Hanging, the hack comes to
    rest within the jam."""
    placed = solve_text(tmp_path, TWO_S_HOOKS, gravity=False).solution
    model = placed.model
    (limit,) = model.turn_limits
    assert limit.jam == pytest.approx(JAM_DEG, abs=1e-9) and limit.folded
    assert turned_on_each_other(model, placed.x) == pytest.approx(JAM_DEG, abs=0.01)
    assert placed.x[limit.second] == 90.0 and limit.second in model.pinned
    hanging = solve_text(tmp_path, TWO_S_HOOKS)
    assert hanging.status == "solved", hanging.diagnostics
    assert turned_on_each_other(model, hanging.solution.x) <= JAM_DEG + 0.01


def test_in_a_loop_both_turn_and_stay_within_the_jam_together() -> None:
    """The bird feeder hangs by a loop (two wall hooks, two S-hooks, the
    hanger): there both flex angles of each S-hook-on-eye-hook connection
    turn, and two linear rows keep their sum within the jam. The eye hook's
    wire is 5 mm across its radius, the S-hook 9.6 mm inside: acos(sqrt(5 /
    9.6)) = 43.81 degrees. Each alone, the right pair once turned 23.4 + 21.5
    = 44.9; now within 43.81 (1e-6: the rows are kept to the optimiser's
    activity tolerance) and at rest."""
    result = api.solve(REPO / "programs" / "bird_feeder.fhl")
    assert result.status == "solved"
    solution = result.solution
    limits = solution.model.turn_limits
    assert len(limits) == 2 and not any(limit.folded for limit in limits)
    for limit in limits:
        assert limit.jam == pytest.approx(math.degrees(math.acos(math.sqrt(5.0 / 9.6))), abs=1e-9)
        together = solution.x[limit.first] - 90.0 + limit.sign * (solution.x[limit.second] - 90.0)
        assert abs(together) <= limit.jam + 1e-6


def test_the_two_turns_add_as_the_limit_says(tmp_path: Path) -> None:
    """The limit's sign: turning either hook's flex angle by the same 10
    degrees turns the lower hook on the upper the same way (both S-hooks face
    each other: the alignment flips the contact's z), so their turns add and
    the limit bounds the sum. Checked on the frames: 10 degrees on one side
    and 10 on the other give 20 together, and 10 against -10 give 0."""
    model = solve_text(tmp_path, TWO_S_HOOKS, gravity=False).solution.model
    (limit,) = model.turn_limits
    assert limit.sign == 1.0
    x = model.x_default()
    both, against = x.copy(), x.copy()
    both[[limit.first, limit.second]] += 10.0
    against[limit.first] += 10.0
    against[limit.second] -= 10.0
    assert turned_on_each_other(model, both) == pytest.approx(20.0, abs=1e-6)
    # 0 by an arccos near 1, which keeps half the digits: 1e-5 degrees (1.2e-6 seen under Sandybridge)
    assert turned_on_each_other(model, against) == pytest.approx(0.0, abs=1e-5)
