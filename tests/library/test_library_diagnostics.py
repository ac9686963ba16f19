"""Defects in part and material definitions: located, explained, golden-tested."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal import api
from fabhal.diagnostics import render_all
from tests.conftest import assert_golden

GOLDEN = Path(__file__).parent / "golden"
CASES = sorted(GOLDEN.glob("*.fhl"))
EXPECTED_CODES = {
    "unknown_kind": "E201",
    "missing_parameter": "E202",
    "negative_parameter": "E203",
    "arc_angle_out_of_range": "E203",
    "wire_thicker_than_hook": "E203",
    "duplicate_primitive": "E204",
    "missing_mesh": "E205",
    "unknown_material": "E206",
    "duplicate_part": "E207",
    "unknown_primitive_parameter": "E208",
    "flag_given_a_number": "E209",
    "bad_density": "E210",
    "no_material": "E212",
    "empty_parameter_range": "E213",
    "no_primitives": "E214",
    "unknown_name_in_expression": "E220",
    "division_by_zero": "E221",
}


def test_every_case_has_an_expected_code() -> None:
    assert {c.stem for c in CASES} == set(EXPECTED_CODES)


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_bad_definition(case: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(GOLDEN)  # file names in the output are relative to here
    result = api.check(Path(case.name))
    assert not result.ok
    codes = [d.code for d in result.diagnostics]
    assert codes == [EXPECTED_CODES[case.stem]], codes
    (diagnostic,) = result.diagnostics
    assert diagnostic.span is not None and diagnostic.span.file == case.name
    assert_golden(render_all(result.diagnostics, result.sources) + "\n", case.with_suffix(".txt"))


def test_the_standard_library_is_clean() -> None:
    result = api.part_library()
    assert result.diagnostics == ()
    assert len(result.library.parts) == 57  # the reference's 56 and LevelHulaHoop (a hoop hung level)
