"""The numpy rasteriser: coverage by pixel centres, nearest surface wins."""

from __future__ import annotations

import numpy as np

from fabhal.render.raster import rasterize


def test_a_right_triangle_covers_the_pixel_centres_inside_it() -> None:
    # legs of 8 px from (1, 1): centres (x + .5, y + .5) with x + y <= 8, x, y >= 1
    screen = np.array([[1.0, 1.0, 5.0], [9.0, 1.0, 5.0], [1.0, 9.0, 5.0]])
    raster = rasterize(screen, np.array([[0, 1, 2]]), 12, 12)
    covered = {(x, y) for y, x in zip(*np.nonzero(raster.face == 0), strict=True)}
    expected = {(x, y) for x in range(12) for y in range(12) if x >= 1 and y >= 1 and x + y <= 9}
    assert covered == expected
    assert np.all(raster.depth[raster.face == 0] == 5.0)  # a flat triangle: its depth everywhere


def test_the_nearer_of_two_overlapping_triangles_is_seen() -> None:
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    far = np.c_[square, np.full(4, 9.0)]
    tilted = np.c_[square, [1.0, 1.0, 20.0, 20.0]]  # nearer at the top rows, farther at the bottom
    screen = np.vstack([far, tilted])
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    raster = rasterize(screen, faces, 10, 10)
    seen_near = raster.face >= 2
    # the tilted square's depth is 1 + 19 * (y + 0.5) / 10: nearer than 9 while y + 0.5 < 80/19
    assert np.all(seen_near[:4]) and not np.any(seen_near[4:])


def test_triangles_off_the_image_or_edge_on_draw_nothing() -> None:
    screen = np.array(
        [[-50.0, -50.0, 1.0], [-40.0, -50.0, 1.0], [-50.0, -40.0, 1.0], [0, 0, 1], [5, 5, 1], [9, 9, 1]]
    )
    raster = rasterize(screen, np.array([[0, 1, 2], [3, 4, 5]]), 10, 10)
    assert np.all(raster.face == -1) and np.all(np.isinf(raster.depth))


def test_a_long_thin_triangle_across_the_image_is_drawn_where_it_is() -> None:
    # a rod seen from the side: a sliver 2 px high from far left to far right of the image
    screen = np.array([[-1000.0, 49.0, 1.0], [1000.0, 49.0, 1.0], [-1000.0, 51.0, 1.0]])
    raster = rasterize(screen, np.array([[0, 1, 2]]), 100, 100)
    rows = np.nonzero(raster.face == 0)[0]
    assert set(rows) <= {49, 50} and len(rows) >= 100
