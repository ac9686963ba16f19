"""The same program with its numbers rounded differently, and what of a result
must not change under that (issue 51): shared by tests/solve/test_perturbation.py
and bench/kernels.py.

A difference in the last bits of a sum (another CPU's BLAS kernel) and a change
in the 9th significant digit of a program's numbers pose the same hack; a
robust answer does not tell them apart. `perturbed` writes such a twin of a
program, `fingerprint` reads off a result what the two must share (status,
the diagnostics' codes, which parts rest on what) and `apart` how far the two
targets hang from each other.
"""

from __future__ import annotations

import math
import random
import re
from dataclasses import dataclass, replace
from typing import Any

import pytest

from fabhal.syntax.parser import parser_kit

# a number in the text that a perturbation may move: not on a `param` line (its
# default must stay one of its values) and not a count (`n: 3`, `0 .. 4`)
_PARAM_LINE = re.compile(r"[ \t]*param\b")
SIGNIFICANT = 9  # the digit changed: a change of one unit in the 9th significant digit
# how far apart a twin's target may hang from the program's own (issue 51's bar)
APART_MM, APART_DEG = 0.5, 0.5


def perturbed(text: str, seed: int) -> str:
    """`text` with every real number changed by one unit in its 9th significant
    digit, up or down as `seed` decides (a zero becomes +-1e-9); integers that
    count (a part's `n`, a range's ends) and `param` lines are left as written."""
    chooser = random.Random(seed)
    pieces, last = [], 0
    for token in parser_kit().lark.lex(text):
        if token.type != "NUMBER" or not _movable(text, token.start_pos, token.end_pos):
            continue
        value = float(token.value)
        sign = chooser.choice((-1.0, 1.0))
        unit = 10.0 ** (math.floor(math.log10(abs(value))) - (SIGNIFICANT - 1)) if value else 1e-9
        pieces.append(text[last : token.start_pos] + repr(value + sign * unit))
        last = token.end_pos
    return "".join(pieces) + text[last:]


def _movable(text: str, start: int, end: int) -> bool:
    if _PARAM_LINE.match(text, text.rfind("\n", 0, start) + 1):  # the number's line
        return False
    before = text[max(0, start - 8) : start].rstrip()
    after = text[end : end + 4].lstrip()
    counted = re.search(r"\bn\s*:$", before) is not None
    in_range = before.endswith("..") or after.startswith("..")
    return not (counted or in_range)


def rounding_decides(measured: str) -> pytest.MarkDecorator:
    """A scenario test whose outcome the last bits of a sum decide (issue 51):
    it runs, and its failure is expected where the machine's rounding takes
    the other path (`measured`: where that was seen, and how). Not strict: on
    the machines where it was written it passes. The mark comes off when the
    solver's answer no longer depends on the path (tests/solve/test_perturbation.py)."""
    return pytest.mark.xfail(strict=False, reason=f"issue 51, rounding decides: {measured}")


@dataclass(frozen=True)
class Fingerprint:
    """What must not change when only the rounding does."""

    status: str
    codes: tuple[str, ...]  # the diagnostics' codes, sorted
    contacts: tuple[tuple[str, str], ...]  # (part, what it rests on), sorted and without repeats
    target: Any  # (4, 4) world frame the target reached


def fingerprint(result: Any) -> Fingerprint:
    """`result`: an api.SolveResult."""
    solution = result.solution
    codes = tuple(sorted(d.code for d in result.diagnostics))
    if solution is None:
        return Fingerprint(result.status, codes, (), None)
    names = [part.name for part in solution.model.parts]
    contacts = tuple(sorted({(names[c.part], names[c.rests_on]) for c in solution.contacts}))
    return Fingerprint(result.status, codes, contacts, solution.target_frame())


def apart(goal: Any, first: Any, second: Any) -> tuple[float, float]:
    """How far two target frames are from each other (mm, degrees), measured as
    the solver measures the target's error (`goal`: the solution's, whose
    primitive's symmetry counts)."""
    from fabhal.solve import target as target_mod

    return target_mod.errors(replace(goal, requested=second), first)
