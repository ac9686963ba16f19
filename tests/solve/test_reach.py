"""W505: a request the parts cannot reach is said so, with what limits it."""

from __future__ import annotations

import re
from pathlib import Path

from fabhal import api
from tests.conftest import REPO

FAR = """\
environment rod = Rod(length: 500, radius: 2) at (0, 0, 2000) rot (90, 0, 90)
s1  = DoubleHook()
mug = Mug()
connect s1.hook2 -- rod
connect mug.hook -- s1.hook1
target mug.hook at (0, 0, {z}) rot (-35, 0, -90)
"""


def reach_warnings(path: Path) -> list:
    return [d for d in api.solve(path).diagnostics if d.code == "W505"]


def test_a_chain_too_short_says_how_far_it_reaches(tmp_path: Path) -> None:
    """The mug's handle is asked for 1950 mm below the rod's axis (z 2000 -> 50).
    One S-hook (23.2 mm between its arc centres, 11.6 mm arcs) and the handle's
    own hook put the handle about 20-70 mm below the rod, so the request is out of
    reach by about 1.9 m, and the parts are too short (not too long)."""
    (tmp_path / "far.fhl").write_text(FAR.format(z=50))
    (problem,) = reach_warnings(tmp_path / "far.fhl")
    assert problem.span is not None and problem.span.line == 6
    assert "requested position is out of reach" in problem.message
    gap = float(re.search(r"at best the target is (\d+) mm", problem.message).group(1))
    assert 1850 <= gap <= 1950
    wanted, got = map(
        float, re.search(r"request is (\d+) mm from `rod`.*reach (\d+) mm", problem.help).groups()
    )
    assert (
        abs(wanted - 1950) <= 10
    )  # the handle's request to the rod's contact point, +- the contact's offset
    assert 10 <= got <= 80
    assert "add parts or use longer ones" in problem.help


def test_a_reachable_request_gets_no_warning() -> None:
    """The mug hanger's three S-hooks reach their request to 0.3 mm (step 1)."""
    assert reach_warnings(REPO / "programs" / "mug_hanger.fhl") == []


STANDING = """\
environment counter = Surface(width: 400, length: 400) at (0, 0, 0)
soap = SoapBottle()
connect soap.surface -- counter
target soap.rod at (0, 0, 71) rot (40, 0, 0)
"""


def test_a_rotation_the_holder_cannot_give_is_named(tmp_path: Path) -> None:
    """A bottle standing on a counter stands upright (surface on surface: only
    its turn about the vertical is free); its body's axis is asked to lean 40
    degrees. The position asked (its body's centre, 71 mm above the counter) is
    where it stands, so only the rotation is out of reach: 40 degrees."""
    (tmp_path / "standing.fhl").write_text(STANDING)
    (problem,) = reach_warnings(tmp_path / "standing.fhl")
    assert "requested rotation is out of reach" in problem.message
    assert "at best the target is 0 mm and 40 degrees" in problem.message
    assert "within 0 mm of the requested position" in problem.help
