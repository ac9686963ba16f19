"""A solver step whose numbers break says which step and which part (E505), with
status `error` and nothing of the broken result in the output."""

from __future__ import annotations

import json

import numpy as np
import pytest

import fabhal.solve as solve_module
from fabhal import api
from fabhal.report.solution import to_dict
from tests.conftest import REPO


def test_a_part_whose_centre_of_mass_is_not_a_number_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    """The mug's centre of mass made NaN (as a broken mesh could): settling needs
    it, so step 2 fails, at the mug."""
    program = REPO / "programs" / "mug_hanger.fhl"
    table = solve_module._mass_table

    def broken(model):  # type: ignore[no-untyped-def]
        masses, centres = table(model)
        centres[model.part_index("mug")] = np.nan
        return masses, centres

    monkeypatch.setattr(solve_module, "_mass_table", broken)
    result = api.solve(program)
    assert result.status == "error" and result.solution is None
    (failure,) = [d for d in result.diagnostics if d.code == "E505"]
    assert "step 2 (settling under gravity), at part `mug`" in failure.message
    assert failure.span is not None and failure.span.line == 24  # the target line
    data = to_dict(result, "mug_hanger")
    json.dumps(data, allow_nan=False)  # nothing non-finite reaches the output
