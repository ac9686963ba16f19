"""A lean (a flex angle: a hook or eye ring tilting on the rod it hangs on) has
no real end: a pose that only its range's end holds is not a state of rest,
unless the lean sits in the corner where its rod ends (a U-handle's bend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fabhal import api
from tests.conftest import REPO
from tests.solve.test_physics import solve_text


def no_flip_program(tmp_path: Path, written: str = "noflip") -> Path:
    """The gallery's soap bottle holder with the second eye hook's ring hung on
    the door rod the default way round (its hook then opens the other way):
    `written` after the connection (`noflip` pins that; "" leaves it open)."""
    text = (REPO / "programs" / "soap_bottle_holder.fhl").read_text()
    text = text.replace('import "lib/', f'import "{REPO}/programs/lib/')
    flipped = "connect hanger.ring2 -- door flip"
    assert flipped in text
    path = tmp_path / "no_flip.fhl"
    path.write_text(text.replace(flipped, f"connect hanger.ring2 -- door {written}".rstrip()))
    return path


@pytest.mark.parametrize("written", ["noflip", ""])
def test_a_basket_on_a_wrongly_turned_eye_hook_hangs_askew_on_its_jams(tmp_path: Path, written: str) -> None:
    """The basket on the wrongly turned eye hook (its ring on the door rod the
    default way round, pinned `noflip` or left open). The other eye hook then
    twists on the 10 mm door rod until its wire jams, twice: its ring tilts
    along the rod until the rod's section reaches across the ring's inside
    (cos b = r / p = 5 / 10.32: b = 61.02 degrees, primitives.tilt_jam_deg)
    and turns about the contact until its wire jams (90 - 44.11 = 45.89,
    primitives.yaw_jam_deg). Both are real stops: the wire presses on the
    rod. Before, the tilt stopped at the reference's 45 degrees, an end
    nothing real has, and the result was not at rest (E509); now it is
    solved, at rest, the basket askew 43.7 mm and 10 degrees from the request
    (out of reach this way round: W505), as the picture shows it. The
    default way round hangs, so an open alignment is not turned over (the
    gallery's `flip` hangs 1.5 mm from it; choosing between two ways that
    both hang is not done yet). Tolerances: 1e-6 degrees on the jams (the
    bounds themselves), 1 mm and 1 degree on where it hangs (the settle's
    rest, 1e-3 of the weight)."""
    import math

    path = no_flip_program(tmp_path, written)
    result = api.solve(path)
    assert result.status == "solved", [d.message for d in result.diagnostics]
    codes = [d.code for d in result.diagnostics]
    assert "W505" in codes and "N507" not in codes and "E509" not in codes
    solution = result.solution
    names = [v.name for v in solution.model.variables]
    ring = solution.model.variables[names.index("hanger.e1.ring.phi")].dof
    tilt_index = names.index("door.door.phi")  # the first: e1's ring on the door (e2's: not at a stop)
    assert (
        solution.model.variables[tilt_index].joint
        == solution.model.variables[names.index("hanger.e1.ring.phi")].joint
    )
    tilt = solution.model.variables[tilt_index].dof
    at_bound = {names[i]: float(solution.x[i]) for i in solution.at_bound}
    assert 90.0 - tilt.low == pytest.approx(math.degrees(math.acos(5.0 / 10.32)), abs=0.01)
    assert at_bound["door.door.phi"] == pytest.approx(tilt.low, abs=1e-6) and tilt.ends_hold
    assert at_bound["hanger.e1.ring.phi"] == pytest.approx(ring.low, abs=1e-6) and ring.ends_hold
    position, rotation = solution.target_errors()
    assert position == pytest.approx(43.7, abs=1.0) and rotation == pytest.approx(10.0, abs=1.0)


TOTE = """\
environment rod = Rod(length: 800, radius: 12) at (0, 0, 1500) rot (90, 0, 90)
s = DoubleHookMedium()
basket = HandleBasket()
connect s.hook2 -- rod
connect basket.rod -- s.hook1
target basket.surface at (0, 0, 1300)
"""


def test_a_hook_in_the_corner_of_a_handle_may_lean_on_it(tmp_path: Path) -> None:
    """Step 1 hangs the basket by the very end of its handle (t = 0, to bring
    its floor nearest the request); under gravity the basket tips until its
    centre of mass is below the hook, the hook leaning on the handle to the
    end of its range. There the handle bends down into the basket's side: the
    bend stops the lean as a real end does, so it is at rest, not E509."""
    result = solve_text(tmp_path, TOTE)
    assert result.status == "solved", [d.message for d in result.diagnostics]
    assert "E509" not in [d.code for d in result.diagnostics]


SLOPING_CLOSED_ROD = """\
environment rod = Rod(length: 300, radius: 5, slide_off: false) at (0, 0, 300) rot ({roll}, 0, 90)
s = DoubleHook()
connect s.hook2 -- rod
target s.hook1 at (0, 0, 260)
"""


@pytest.mark.parametrize(("slope", "tilt", "jammed"), [(50.0, 50.0, False), (65.0, 58.61, True)])
def test_a_hook_tilts_along_a_steep_rod_until_its_wire_jams(
    tmp_path: Path, slope: float, tilt: float, jammed: bool
) -> None:
    """An S-hook (arc radius 11.6, wire 2: 9.6 mm inside) on a closed 5 mm rod
    sloping `slope` degrees slides to the lower end (tan 50 = 1.19 > 0.3) and
    hangs there. Its plane, square to the rod, must tilt along the rod by the
    slope to hang plumb (the plane square to a rod sloping a is a from the
    vertical). The wire jams at cos b = r / p = 5 / 9.6: b = 58.61 degrees
    (primitives.tilt_jam_deg), beyond the reference's 45, which the model now
    takes as the range: at 50 degrees the hook hangs plumb, its centre of
    mass (its origin: the S is symmetric) under the contact and the tilt 50
    free of its stops (before, the tilt stopped at the model's 45 and the
    hook hung 1.45 mm aside, held there by an end nothing real has); at 65
    it stops at the jam, 58.61, a real stop that carries load (solved, no
    E509). Tolerances: 0.5 degrees on the tilt and 0.5 mm under the contact
    (the settle stops at 1e-4 of the weight per mm)."""
    path = tmp_path / "steep.fhl"
    path.write_text(SLOPING_CLOSED_ROD.format(roll=90 + slope))
    result = api.solve(path)
    solution = result.solution
    assert solution is not None and result.status == "solved", result.diagnostics
    assert "E509" not in [d.code for d in result.diagnostics]
    names = [v.name for v in solution.model.variables]
    phi, t = names.index("rod.rod.phi"), names.index("rod.rod.t")
    assert t in solution.at_bound  # at the closed lower end
    assert abs(solution.x[phi] - 90.0) == pytest.approx(tilt, abs=0.5)
    assert (phi in solution.at_bound) == jammed
    if not jammed:
        model = solution.model
        hook = solution.frames[model.part_index("s")][:3, 3]
        joint = model.joints[0]
        contact = model.connector_frame(joint.b, solution.x, solution.frames)[:3, 3]
        assert float(np.linalg.norm(hook[:2] - contact[:2])) < 0.5
