"""A lean (a flex angle: a hook or eye ring tilting on the rod it hangs on) has
no real end: a pose that only its range's end holds is not a state of rest,
unless the lean sits in the corner where its rod ends (a U-handle's bend)."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal import api
from fabhal.solve import Lean, SolveOptions, _solve_once, _with_flip_advice
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


def test_a_basket_held_by_a_leans_limit_is_not_at_rest(tmp_path: Path) -> None:
    """From the first start the basket on the wrongly turned eye hook hangs
    tilted with that eye ring leaning along the door rod to the end of its range
    (phi = 135), in the middle of the rod (no corner), which carries 11 % of
    the assembly's weight per mm of tilt (a degree counts as a mm): nothing
    real holds that (the gallery's leans carry at most 0.09 %; every gallery
    hack is `solved`, tests/test_gallery.py). Not at rest, E509 at that
    connection. Turned over (`flip`), the design is the gallery's,
    which hangs 1.5 mm from the request: the program pins the default way
    round (`noflip`), so the result stays its own and the advice says so
    (within 10 mm)."""
    checked = api.check(no_flip_program(tmp_path))
    assert checked.model is not None
    options = SolveOptions(seed=0)
    first = _solve_once(checked.model, options, None)
    assert first.status == "not_at_rest"
    leans = [fall for fall in first.falls if isinstance(fall, Lean)]
    assert leans and all(lean.push > 0.01 for lean in leans)
    e509 = [d for d in first.diagnostics if d.code == "E509"]
    source = no_flip_program(tmp_path).read_text().splitlines()
    lines = [d.span.line for d in e509 if d.span is not None]
    assert [source[line - 1] for line in lines] == ["connect hanger.ring2 -- door noflip"]
    advised = _with_flip_advice(checked.model, options, first)
    (advice,) = [d.help for d in advised.diagnostics if d.code == "E509"]
    assert advice is not None and advice.startswith(
        "this connection written with `flip` hangs the hack at rest"
    )
    assert float(advice.split("at rest, ")[1].split(" mm")[0]) < 10.0


def test_an_alignment_the_program_leaves_open_is_chosen(tmp_path: Path) -> None:
    """The same connection written with neither `flip` nor `noflip`: the
    program leaves its alignment open, so the solver turns it over, as a
    builder whose basket hangs askew would: the result is the gallery's
    design (1.5 mm and 0 degrees from the request, within its 10 mm), solved,
    and N507 names the connection's line. Written with `flip`, the same
    answer without the note (the gallery's soap holder)."""
    path = no_flip_program(tmp_path, written="")
    result = api.solve(path)
    assert result.status == "solved"
    (note,) = [d for d in result.diagnostics if d.code == "N507"]
    assert note.span is not None
    assert path.read_text().splitlines()[note.span.line - 1] == "connect hanger.ring2 -- door"
    assert "turned over" in note.message
    position, rotation = result.solution.target_errors()
    gallery = api.solve(REPO / "programs" / "soap_bottle_holder.fhl")
    assert "N507" not in [d.code for d in gallery.diagnostics]
    assert position < 10.0 and rotation < 5.0
    assert position == pytest.approx(gallery.solution.target_errors()[0], abs=0.5)


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
