"""The same answer when only the rounding changes (issue 51).

Every gallery program is solved as written and as two twins whose numbers
differ in their 9th significant digit (tests/perturbation.py): a change a
millionth of what a builder can measure, of the size another CPU's BLAS
kernel makes in the last bits of a sum after a few thousand operations. The
twins must come back with the same status, the same diagnostics, the same
parts resting on the same things, and the target within 0.5 mm and 0.5
degree of the program's own (the issue's bar: far under the millimetre a
hand calculation of these hacks is good to, far over the 1e-6 mm to which
the solver closes loops).

Programs whose answer the solver does not yet keep under such a change are
listed with what was measured; they run, and are expected to fail
(non-strict: which twin differs depends on the machine). bench/kernels.py
compares the BLAS kernels themselves (a test cannot choose its kernel).
"""

from __future__ import annotations

import re
from functools import cache
from typing import Any

import pytest

from fabhal import api
from fabhal.load import load_program
from tests.conftest import REPO, gallery_programs
from tests.perturbation import APART_DEG, APART_MM, apart, fingerprint, perturbed
from tests.test_gallery import solved as solved_as_written

TWINS = (1, 2)  # fixed perturbations: each seed decides every number's direction

# measured with bench/kernels.py --perturb 2 (bench/README.md item 99): what moves
_AIMED = "the aim's two rounds end where they end, from a step 1 its budget stopped"
NOT_YET_ROBUST: dict[str, str] = {
    **{
        name: f"{name}: twins 0.2-2.8 mm and 0.3-3.0 degrees apart ({_AIMED})"
        for name in ("clip_light_family", "clip_light_l", "clip_light_m", "clip_light_s", "clip_light_xs")
    },
    "demo": f"demo: its ring turned 3.3-8.5 degrees otherwise ({_AIMED})",
    "diaper_caddy": "diaper_caddy: 10.0 or 42.3 mm from its request, resting on 3 or 4 places: two rests "
    "0.003 J apart in a valley its contact points make rough, and its settles end on their iteration limit",
    "reading_nook": "reading_nook: not at rest (E513) and 14-32 mm from its request, with or without N506",
    "soap_bottle_one_eyehook": f"soap_bottle_one_eyehook: 2.2 mm and 3.5 degrees apart ({_AIMED})",
    "paper_towel_holder": "paper_towel_holder: 3.7 or 4.4 mm from its request (where step 1 left the hooks "
    "on the broom, which friction then holds)",
}


@cache
def solved(program: str, twin: int) -> Any:
    """The program's twin solved; twin 0, as written, is tests/test_gallery.py's
    solve, shared (the caddy's takes 18 s under some kernels)."""
    if twin == 0:
        return solved_as_written(program)
    path = REPO / "programs" / f"{program}.fhl"
    return api.solve(load_program(path, perturbed(path.read_text(), twin)))


def test_a_twin_differs_only_in_the_ninth_digit() -> None:
    """The perturbation itself: every placed number moves by one unit of its
    9th significant digit (a zero to +-1e-9), the family's `param`s and the
    counts stay as written."""
    text = (
        "param n in 1 .. 4 = 3\nenvironment r = Rod(length: 500, radius: 2) at (0, 12.5, 200)\nc = C(n: 2)\n"
    )
    first, placed, counted = perturbed(text, 1).splitlines()
    assert (first, counted) == ("param n in 1 .. 4 = 3", "c = C(n: 2)")
    moved = [float(v) for v in re.findall(r"-?[0-9.]+(?:e-?[0-9]+)?", placed.split("Rod")[1])]
    for value, written in zip(moved, (500.0, 2.0, 0.0, 12.5, 200.0), strict=True):
        if written:
            assert value != written and abs(value - written) / written < 2e-8
        else:
            assert abs(value) == pytest.approx(1e-9)
    assert perturbed(text, 1) == perturbed(text, 1) != perturbed(text, 2)


@pytest.mark.parametrize("program", gallery_programs(NOT_YET_ROBUST, strict=False))
def test_an_answer_survives_rounding(program: str) -> None:
    written = solved(program, 0)
    expected = fingerprint(written)
    for twin in TWINS:
        result = solved(program, twin)
        found = fingerprint(result)
        assert (found.status, found.codes, found.contacts) == (
            expected.status,
            expected.codes,
            expected.contacts,
        ), f"twin {twin}"
        if expected.target is not None:
            mm, deg = apart(written.solution.goal, found.target, expected.target)
            assert mm <= APART_MM and deg <= APART_DEG, f"twin {twin}: {mm:.3f} mm, {deg:.3f} degrees apart"
