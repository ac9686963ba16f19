"""Nothing inside anything (issue 52's acceptance): at the solved frames of
every gallery program, no part's surface reaches deeper than 0.5 mm into
another part or into the world, the two parts of a connection included (a
hook's wire lying in a ring touches the ring; it does not cross it).

Measured on the meshes with exact distances (tests/mesh_overlaps.py), not with
the solver's own distance grids, so that the grids' interpolation cannot hide
what the solver does. The depth is read at points 0.5 mm apart on each
surface, short of the truth by under 0.1 mm where wires or tubes touch (the
depth falls off with the square of the distance from the deepest point).
0.5 mm, the issue's bar, is a tenth of a typical wire's diameter, far above
the 1e-6 mm the solver closes loops to, and far below the millimetres a real
part pressed into another would show.

Programs the solver does not yet keep apart are listed with what was measured
(strict: one that comes out clear fails, so that the list stays true). The
whole gallery takes about 9 minutes on 2 cores (a broom lying in a towel
roll's bore, under a millimetre from it along 280 mm, is read at some 10^5
points), so it runs with `pytest -m acceptance`; the normal suite measures the
gallery's first example.
"""

from __future__ import annotations

import pytest

from tests.conftest import gallery_programs
from tests.mesh_overlaps import overlaps
from tests.test_gallery import solved

DEEPEST_MM = 0.5

# measured on main at 5955270 with tests/mesh_overlaps.py (lower bounds: the search stops past the bar)
NOT_YET_CLEAR: dict[str, str] = {
    "bird_feeder": "the eye hook's wire 1.8 mm into the S-hook it hangs from",
    "closet_basket": "the eye hooks 2.0 mm into the basket's wire and 0.6 mm into the rods",
    "demo": "the S-hook 1.3 mm into the ring it holds",
    "diaper_caddy": "the S-hooks 1.2-4.5 mm and the caddy 2.7 mm into the seats' backs, two S-hooks "
    "1.0 mm into each other",
    "reading_nook": "not at rest (E513): its S-hooks up to 17 mm into the room's scan, the turnbuckle 6.7 mm "
    "and rings 1.5 mm into their neighbours",
    "soap_bottle_one_eyehook": "the eye hook 1.1 mm into the basket's wire",
}


def _assert_clear(program: str) -> None:
    too_deep = overlaps(solved(program).solution, bar=DEEPEST_MM)
    assert too_deep == [], [f"{o.inside} {o.depth_mm:.2f} mm into {o.of}" for o in too_deep]


@pytest.mark.acceptance
@pytest.mark.parametrize(
    "program",
    [p for p in gallery_programs(NOT_YET_CLEAR, strict=True) if "family" not in str(p)],
)  # the clip-light family poses the four clip lights again
def test_no_part_lies_inside_another_or_the_world(program: str) -> None:
    _assert_clear(program)


def test_the_mug_hangs_clear_of_its_hooks() -> None:
    """The gallery's first example in the normal suite (a second): its mug's
    handle lies in the last S-hook 0.26 mm deep, within the bar."""
    _assert_clear("mug_hanger")
