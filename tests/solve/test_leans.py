"""A lean (a flex angle: a hook or eye ring tilting on the rod it hangs on) has
no real end: a pose that only its range's end holds is not a state of rest."""

from __future__ import annotations

from pathlib import Path

from fabhal.solve import Lean
from tests.conftest import REPO
from tests.solve.test_physics import solve_text


def test_a_basket_on_an_eye_hook_turned_the_wrong_way_is_not_at_rest(tmp_path: Path) -> None:
    """The gallery's soap bottle holder with the second eye hook's ring hung
    on the door rod without `flip`: its hook then opens the other way, and the
    basket can only hang tilted with that hook and the first one's ring
    leaning to the ends of their ranges (45 and 135 degrees), which carry 52 %
    and 11 % of the assembly's weight per mm of tilt (a degree counts as a
    mm): nothing real holds that (the gallery's leans carry at most 0.09 %,
    and every gallery hack is `solved`: tests/test_gallery.py).
    Not at rest, E509 at both connections; turned over, the design is the
    gallery's, which hangs 2.2 mm from the request: the help says so for the
    connection whose flip was tried first and hangs (within 10 mm)."""
    text = (REPO / "programs" / "soap_bottle_holder.fhl").read_text()
    text = text.replace('import "lib/', f'import "{REPO}/programs/lib/')
    assert "connect hanger.ring2 -- door flip" in text
    result = solve_text(
        tmp_path, text.replace("connect hanger.ring2 -- door flip", "connect hanger.ring2 -- door")
    )
    assert result.status == "not_at_rest"
    leans = [fall for fall in result.solution.falls if isinstance(fall, Lean)]
    assert leans and all(lean.push > 0.01 for lean in leans)
    e509 = [d for d in result.diagnostics if d.code == "E509"]
    assert e509 and all(d.span is not None for d in e509)
    lines = {d.span.line for d in e509 if d.span is not None}
    source = text.splitlines()
    assert all("connect" in source[line - 1] for line in lines)
    advised = [d for d in e509 if "hangs the hack at rest" in (d.help or "")]
    assert len(advised) == 1
    distance = float(advised[0].help.split("at rest, ")[1].split(" mm")[0])
    assert distance < 10.0
