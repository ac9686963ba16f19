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


def test_the_legend_goes_to_the_corner_that_hides_fewest_points() -> None:
    """A 400 x 300 plot (box 0..400, 0..300 in pixels, y down) with a 100 x 50
    legend: with nothing drawn it sits top right, 6 px in; with points under
    the top right (the clip-light family's n = 1 line, high errors) it moves
    to the top left; with points in both top corners too, to the bottom right."""
    from fabhal.search.pictures import _emptiest_corner

    box, size = (0.0, 0.0, 400.0, 300.0), (100.0, 50.0)
    assert _emptiest_corner(box, size, []) == (294.0, 6.0)
    top_right = [(350.0, 20.0), (380.0, 30.0)]
    assert _emptiest_corner(box, size, top_right) == (6.0, 6.0)
    assert _emptiest_corner(box, size, [*top_right, (50.0, 30.0)]) == (294.0, 244.0)
