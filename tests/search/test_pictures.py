"""The plot's axes (fabhal/search/pictures.py): round tick values."""

from __future__ import annotations

import pytest

from fabhal.search.pictures import _ticks


def test_ticks_are_round_steps_that_cover_the_values() -> None:
    assert _ticks(0.0, 83.7) == [0.0, 20.0, 40.0, 60.0, 80.0, 100.0]  # step 20 = 2 x 10: 83.7 / 5 = 16.7 up
    assert _ticks(0.0, 45.7) == [0.0, 10.0, 20.0, 30.0, 40.0, 50.0]
    assert _ticks(1.0, 4.0, whole=True) == [1.0, 2.0, 3.0, 4.0]  # n = 1 .. 4: no tick at 1.5
    # one value: a unit wide (approx: k x 0.2 in floating point)
    assert _ticks(5.0, 5.0) == pytest.approx([5.0, 5.2, 5.4, 5.6, 5.8, 6.0], abs=1e-12)
