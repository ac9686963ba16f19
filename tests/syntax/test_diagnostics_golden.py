"""Rendered diagnostics for common syntax mistakes, compared with golden files.

Each `golden/NAME.fhl` holds one mistake (or several); `golden/NAME.txt` is
what `fabhal check` prints for it. Refresh with FABHAL_UPDATE_GOLDEN=1.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal.diagnostics import FabhalError, render_all
from fabhal.source import SourceFile
from fabhal.syntax.parser import parse_source
from tests.conftest import assert_golden

GOLDEN = Path(__file__).parent / "golden"
CASES = sorted(GOLDEN.glob("*.fhl"))


def render_errors(path: Path) -> tuple[str, FabhalError]:
    source = SourceFile(path.name, path.read_text())
    with pytest.raises(FabhalError) as caught:
        parse_source(source)
    return render_all(caught.value.diagnostics, {source.name: source}) + "\n", caught.value


def test_there_are_at_least_fifteen_distinct_mistakes() -> None:
    assert len(CASES) >= 15


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_syntax_error_rendering(case: Path) -> None:
    rendered, error = render_errors(case)
    assert all((d.span is not None and d.help) or d.code in {"E100", "E106"} for d in error.diagnostics)
    assert_golden(rendered, case.with_suffix(".txt"))


def test_several_errors_are_reported_in_one_run() -> None:
    _, error = render_errors(GOLDEN / "several_errors.fhl")
    assert [(d.code, d.span.line) for d in error.diagnostics if d.span] == [
        ("E103", 1),
        ("E111", 2),
        ("E101", 3),
        ("E110", 4),
    ]
