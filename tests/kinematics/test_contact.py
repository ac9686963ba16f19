"""Signed distance grids and their sampling, trilinear and smooth (fabhal/kinematics/contact.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import trimesh

from fabhal.kinematics.contact import (
    DistanceGrid,
    grid_spacing,
    penalty,
    rectangles_overlap,
    signed_distance_grid,
)


def sampled(mesh: trimesh.Trimesh, count: int = 60_000) -> tuple[np.ndarray, np.ndarray]:
    points, faces = trimesh.sample.sample_surface(mesh, count, seed=0)
    return np.asarray(points), np.asarray(mesh.face_normals[faces])


def test_trilinear_sampling_is_exact_on_a_linear_field() -> None:
    """d(p) = a . p + 1 is reproduced exactly by trilinear interpolation, and its
    gradient is a: 1e-12 is rounding."""
    a = np.array([0.3, -0.2, 0.5])
    axes = [2.0 * np.arange(n) for n in (5, 6, 7)]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    grid = DistanceGrid(np.zeros(3), 2.0, nodes @ a + 1.0)
    points = np.random.default_rng(1).uniform(0.0, 8.0, (50, 3))
    distance, gradient = grid.sample(points)
    assert np.abs(distance - (points @ a + 1.0)).max() < 1e-12
    assert np.abs(gradient - a).max() < 1e-12
    far, none = grid.sample(np.array([[100.0, 0.0, 0.0]]))
    assert far[0] == np.inf and not none.any()


def test_smooth_sampling_is_exact_on_a_linear_field() -> None:
    """Read smooth, d(p) = a . p + 1 is reproduced exactly too (the spline's
    weights sum to 1 and are centred on the point) with gradient a: 1e-12 is
    rounding. The spline reads a node's 3 x 3 x 3 neighbourhood, so within
    half a cell of the grid's edge (and beyond it) nothing is read."""
    a = np.array([0.3, -0.2, 0.5])
    axes = [2.0 * np.arange(n) for n in (5, 6, 7)]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    grid = DistanceGrid(np.zeros(3), 2.0, nodes @ a + 1.0, smooth=True)
    points = np.random.default_rng(1).uniform(1.0, 6.99, (50, 3))
    distance, gradient = grid.sample(points)
    assert np.abs(distance - (points @ a + 1.0)).max() < 1e-12
    assert np.abs(gradient - a).max() < 1e-12
    far, none = grid.sample(np.array([[100.0, 0.0, 0.0], [0.5, 3.0, 3.0]]))
    assert np.all(far == np.inf) and not none.any()


@pytest.mark.parametrize("smooth", [False, True])
def test_sampling_only_the_inside_keeps_every_distance_to_the_bit(smooth: bool) -> None:
    """`sample_inside` is `sample` with the gradients of the points outside left
    out: over random samples (about half of them negative), each distance is
    the same float (== : contact decisions and depths must not move by a
    rounding), each gradient of a point inside too, and outside it is zero."""
    values = np.random.default_rng(0).normal(size=(9, 10, 11))
    grid = DistanceGrid(np.zeros(3), 2.0, values, smooth=smooth)
    points = np.random.default_rng(1).uniform(-1.0, 21.0, (400, 3))
    distance, gradient = grid.sample(points)
    only, inside_gradient = grid.sample_inside(points)
    inside = distance < 0.0
    assert 100 < inside.sum() < 300
    assert np.array_equal(only, distance) and np.array_equal(grid.distance(points), distance)
    assert np.array_equal(inside_gradient[inside], gradient[inside])
    assert not inside_gradient[~inside].any()


def test_the_smooth_gradient_is_the_distances_derivative_across_faces() -> None:
    """Over random samples (no smooth field behind them, the hardest case), at
    points on the faces where the smooth reading's pieces meet (x = 2 i + 1 mm
    on 2 mm cells), the gradient equals central differences of the distance
    to 1e-6 (h = 1e-6 mm: the differences' own error is rounding, 1e-9 of
    values of order 1). Trilinear reading's x-derivative jumps at its cell
    faces (x = 2 i): the differences there are the mean of the two sides, and
    differ from either side's gradient by far more (at least 0.01 at some
    point): a settle resting on such a face finds no gradient that holds."""
    values = np.random.default_rng(0).normal(size=(9, 10, 11))
    rng = np.random.default_rng(1)
    points = rng.uniform(2.0, 14.0, (200, 3))
    h = 1e-6

    def off_differences(grid: DistanceGrid, at: np.ndarray) -> float:
        _, gradient = grid.sample(at)
        differences = np.stack(
            [(grid.sample(at + h * e)[0] - grid.sample(at - h * e)[0]) / (2 * h) for e in np.eye(3)], axis=1
        )
        return float(np.abs(differences - gradient).max())

    on_spline_faces = points.copy()
    on_spline_faces[:, 0] = 2.0 * rng.integers(1, 7, 200) + 1.0
    assert off_differences(DistanceGrid(np.zeros(3), 2.0, values, smooth=True), on_spline_faces) < 1e-6
    on_cell_faces = points.copy()
    on_cell_faces[:, 0] = 2.0 * rng.integers(1, 7, 200)
    assert off_differences(DistanceGrid(np.zeros(3), 2.0, values), on_cell_faces) > 0.01


def test_a_round_read_smooth_is_off_by_an_eighth_of_the_cell_squared_times_its_laplacian() -> None:
    """The spline smooths a field as a kernel of variance h^2 / 4 per axis
    does: by h^2 / 8 x its Laplacian. A 50 mm sphere's distance r - 50 has
    Laplacian 2 / r, so on 14 mm cells (coarser than the car's back seats' grid, 9.6 mm)
    the distance reads 196 / 8 x 2 / 50 = 0.98 mm more at its surface, 1.09 mm
    at r = 45, 0.89 at 55 (points on 2,000 random directions; 5 % allowed for
    the higher terms): a round seat back lets a part in by about a millimetre.
    Read trilinearly it is exact at the samples and errs up to about as much
    between them. The normal stays within 4 % of unit length."""
    h, radius = 14.0, 50.0
    axis = np.arange(-98.0, 98.1, h)
    nodes = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1)
    grid = DistanceGrid(np.full(3, axis[0]), h, np.linalg.norm(nodes, axis=-1) - radius, smooth=True)
    directions = np.random.default_rng(3).normal(size=(2000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    for r in (45.0, 50.0, 55.0):
        distance, gradient = grid.sample(directions * r)
        assert np.abs(distance - (r - radius) - h**2 / 8 * 2 / r).max() < 0.05 * h**2 / 8 * 2 / r
        assert np.abs(np.linalg.norm(gradient, axis=1) - 1.0).max() < 0.04


def test_a_boxes_distance_inside_and_out() -> None:
    """A 100 x 100 x 20 mm slab at the origin (a 2 mm grid): 15 mm above its
    middle the distance is 15 - 10 = 5 mm, 7 mm below its middle -3 (inside, 3
    from the bottom face), 15 below its bottom face 5. Near a flat face the
    distance is measured along its normal and interpolated linearly: 0.05 mm.
    Midway between the two faces the distance has a ridge that interpolation
    cuts: there it is only required to be inside, within a cell (2 mm) of -10.
    Beyond BAND_CELLS cells (8 mm) out the distance is cut to 8 mm."""
    slab = trimesh.creation.box(extents=(100.0, 100.0, 20.0))
    grid = signed_distance_grid([sampled(slab)], np.full(3, -80.0), np.full(3, 80.0))
    points = np.array(
        [[0.0, 0.0, 15.0], [3.0, -4.0, -7.0], [10.0, 10.0, -15.0], [0.0, 0.0, 0.0], [0, 0, 40.0]]
    )
    distance, gradient = grid.sample(points)
    assert np.allclose(distance[:3], [5.0, -3.0, 5.0], atol=0.05)
    assert -10.0 - 2.0 <= distance[3] <= -10.0 + 2.0
    assert distance[4] == np.float32(4 * grid.spacing)
    assert np.allclose(gradient[0], [0.0, 0.0, 1.0], atol=0.02)  # the way out: up
    assert np.allclose(gradient[1], [0.0, 0.0, -1.0], atol=0.02)  # nearest the bottom: out through it


def test_a_sheet_on_a_wall_does_not_turn_the_wall_inside_out() -> None:
    """A sheet whose two faces lie at one place (a decal, 0.05 mm) on a 40 mm
    wall: in front of both the distance is to the sheet (10 mm in front: +10),
    inside the wall it is the wall's (-20 at its middle): the union is the
    least of the two, and of the sheet's coincident faces the one facing the
    point says on which side it is."""
    wall = trimesh.creation.box(extents=(40.0, 200.0, 200.0))
    wall.apply_translation((-20.0, 0.0, 0.0))
    sheet = trimesh.creation.box(extents=(0.05, 100.0, 100.0))
    grid = signed_distance_grid(
        [sampled(wall), sampled(sheet, 20_000)], np.array([-90, -150, -150.0]), np.full(3, 150.0)
    )
    distance, _ = grid.sample(np.array([[10.0, 0.0, 0.0], [-20.0, 5.0, 5.0]]))
    assert distance[0] == pytest.approx(10.0, abs=0.05)
    assert distance[1] == pytest.approx(-20.0, abs=grid.spacing)


def test_the_penalty_pushes_only_what_is_inside() -> None:
    """k/2 x depth^2: with k = 4, depths 0.5 and 0 (outside) cost 0.5 and 0; the
    derivative by each distance is -k x depth."""
    energy, slope = penalty(np.array([-0.5, 2.0]), 4.0)
    assert energy == 0.5
    assert np.allclose(slope, [-2.0, 0.0])


def test_a_face_sampled_as_sparsely_as_the_library_grids_reads_exactly() -> None:
    """The library's grids sample each surface about half a cell apart, at
    random: a grid point over a face may find its nearest sample up to a cell
    aside. Over the face the distance must still be the height above it, not
    the straight line to that sample (once off by up to 3 mm on a wall): at 200
    random points within 10 mm of a 400 x 400 mm slab's top face, 3.1 mm cells,
    the error stays under 0.05 mm (the faces are flat: trilinear interpolation
    of exact node values is exact)."""
    slab = trimesh.creation.box(extents=(400.0, 400.0, 40.0))
    low, high = np.array([-220.0, -220.0, -40.0]), np.array([220.0, 220.0, 40.0])
    spacing = grid_spacing(low, high)  # 3.1 mm here
    count = int(slab.area / (spacing / 2) ** 2)  # as fabhal/meshes.py samples
    grid = signed_distance_grid([sampled(slab, count)], low, high)
    rng = np.random.default_rng(2)
    points = np.column_stack(
        [rng.uniform(-150, 150, 200), rng.uniform(-150, 150, 200), rng.uniform(10, 30, 200)]
    )
    distance, _ = grid.sample(points)
    assert np.abs(distance - (points[:, 2] - 20.0)).max() < 0.05


@pytest.mark.parametrize("smooth", [False, True], ids=["trilinear", "smooth"])
def test_the_cull_clears_only_points_that_are_outside(smooth: bool) -> None:
    """`could_be_inside` may clear a point only when its distance is positive
    (trilinear: the 8 corners of its cell are; smooth: the 27 samples the
    spline weighs with positive weights are): over a slab's grid (cells 2
    mm), of 20,000 random points every one `sample` finds inside is kept, and
    the cull clears most of the points that lie far from the slab (it is
    worth its cost)."""
    slab = trimesh.creation.box(extents=(100.0, 100.0, 20.0))
    grid = signed_distance_grid([sampled(slab)], np.full(3, -80.0), np.full(3, 80.0))
    grid = replace(grid, smooth=smooth)
    points = np.random.default_rng(2).uniform(-85.0, 85.0, (20_000, 3))
    distance, _ = grid.sample(points)
    kept = grid.could_be_inside(points)
    assert (distance < 0.0).sum() > 500  # the test sees inside points
    assert np.all(kept[distance < 0.0])
    far = distance >= 4 * grid.spacing  # beyond the band: the grid's own cut
    assert kept[far].mean() < 0.05


def test_two_rectangles_overlap_by_the_least_of_their_shadows() -> None:
    """Two 77 mm squares in one plane (a bottle's base): on one spot they
    overlap by 77 mm; 60 mm apart by 77 - 60 = 17; 80 mm apart they are 3 mm
    apart (-3). One turned 45 degrees reaches 38.5 sqrt 2 = 54.45 mm from its
    centre along the line between them, so placed 38.5 + 54.45 + 1 mm away
    they are 1 mm apart. Exact to rounding."""
    along, across = np.eye(3)[0], np.eye(3)[1]
    square = np.array([along, across])
    halves = np.full((2, 2), 38.5)

    def overlap(distance: float, turned: np.ndarray) -> float:
        centres = np.array([[0.0, 0.0, 0.0], [distance, 0.0, 0.0]])
        return rectangles_overlap(centres, np.array([square, turned]), halves)

    assert overlap(0.0, square) == pytest.approx(77.0)
    assert overlap(60.0, square) == pytest.approx(17.0)
    assert overlap(80.0, square) == pytest.approx(-3.0)
    c = np.sqrt(0.5)
    diamond = np.array([[c, c, 0.0], [-c, c, 0.0]])
    assert overlap(38.5 + 38.5 * np.sqrt(2.0) + 1.0, diamond) == pytest.approx(-1.0)


def test_point_cells_keep_every_point_that_lies_in_the_box() -> None:
    """Points gathered into cubes (`PointCells`), moved by random rigid
    motions against a box: every point that lands in the box belongs to a
    cube `near_box` keeps (its ball, the cube's points' centre and farthest
    distance, carried by the same motion, reaches the box), and the cubes
    kept are few where the box is small beside the points (the reason to
    have them). Each cube's ball holds its points."""
    from fabhal.kinematics.contact import PointCells
    from fabhal.kinematics.frames import frame_matrix

    rng = np.random.default_rng(7)
    points = rng.normal(scale=60.0, size=(5000, 3))
    cells = PointCells.of(points)
    which = np.repeat(np.arange(len(cells.counts)), cells.counts)
    owner = np.empty(len(points), dtype=int)
    owner[cells.order] = which
    assert np.all(np.linalg.norm(points - cells.centres[owner], axis=1) <= cells.radii[owner] + 1e-9)
    low, high = np.array([-20.0, -10.0, -15.0]), np.array([25.0, 30.0, 5.0])
    motions = np.array([frame_matrix(rng.uniform(-50, 50, 3), rng.uniform(-180, 180, 3)) for _ in range(20)])
    near = cells.near_box(motions, low, high)
    moved = points @ motions[:, :3, :3].transpose(0, 2, 1) + motions[:, None, :3, 3]
    inside = ((moved >= low) & (moved <= high)).all(axis=2)
    assert inside.any() and np.all(near[inside])
    assert near.mean() < 0.5
