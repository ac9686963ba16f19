"""Two loops hooked into each other (S-hook on S-hook) each turn about the one
line of their contact: their turns add, and together they turn only until a
wire jams (fabhal/model.py `TurnLimit`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fabhal.model import Model
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
    other, a wire through a wire. Now they stop together at the jam: the
    frames show the lower hook turned at most 62.84 degrees on the upper
    (0.01 degree: the stop is an inequality the optimiser keeps to 1e-6),
    and close to it (over 60: the request pulls it onto the stop). Each
    hook takes a share (neither alone reaches the whole turn) and the hack
    hangs at rest."""
    result = solve_text(tmp_path, TWO_S_HOOKS)
    solution = result.solution
    assert result.status == "solved", result.diagnostics
    model = solution.model
    (limit,) = model.turn_limits
    assert limit.jam == pytest.approx(JAM_DEG, abs=1e-9)
    turned = turned_on_each_other(model, solution.x)
    assert 60.0 < turned <= JAM_DEG + 0.01
    shares = [abs(solution.x[i] - 90.0) for i in (limit.first, limit.second)]
    assert max(shares) < turned - 1.0


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
    assert turned_on_each_other(model, against) == pytest.approx(0.0, abs=1e-6)
