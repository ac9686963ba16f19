"""Seeds 0-4 agree (issue 52's acceptance): the seed picks step 1's extra
random starts, and every gallery program comes to the same rest from each,
its target within 1 mm and 1 degree of seed 0's (the issue's bar: a builder
cannot hang a hack more exactly than that), or N505 says that starts rest
apart and which rule chose.

Measured on main at aab8651: seeds 1-4 land 0.00 mm and 0.00 degrees from
seed 0's on every program but two: the one-eye-hook soap basket 7.7-50 mm
and 13-58 degrees apart, with N505 saying so; the reading nook (listed, strict)
not at rest from any seed and 59-130 mm apart without a word. Runs with
`pytest -m acceptance` (four more solves of every program, two to three
minutes).
"""

from __future__ import annotations

import pytest

from fabhal import api
from tests.conftest import REPO, gallery_programs
from tests.perturbation import apart
from tests.test_gallery import solved

SEEDS = (1, 2, 3, 4)
APART_MM, APART_DEG = 1.0, 1.0
NOT_YET_AGREED = {
    "reading_nook": "not at rest (E513) from every seed, seeds 1-4 59-130 mm and 10-87 degrees from "
    "seed 0's, without N505",
}


@pytest.mark.acceptance
@pytest.mark.parametrize(
    "program", [p for p in gallery_programs(NOT_YET_AGREED, strict=True) if "family" not in str(p)]
)
def test_every_seed_comes_to_the_same_rest(program: str) -> None:
    first = solved(program)
    for seed in SEEDS:
        other = api.solve(REPO / "programs" / f"{program}.fhl", seed=seed)
        assert other.status == first.status, (seed, other.status, first.status)
        mm, deg = apart(first.solution.goal, other.solution.target_frame(), first.solution.target_frame())
        said = "N505" in [d.code for d in other.diagnostics]
        assert (mm <= APART_MM and deg <= APART_DEG) or said, (seed, mm, deg)
