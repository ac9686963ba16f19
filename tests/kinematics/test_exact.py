"""Exact distances to meshes (fabhal/kinematics/exact.py), held against
independent answers: trimesh's own closest-point routine, a brute force over
every triangle, and boxes and spheres whose distances are known by hand.

Tolerances: 1e-9 mm where two exact computations of the same closest point
meet (they differ only by rounding, on coordinates of order 10 mm); 1e-3 for
a winding number (a sum of solid angles, exact up to rounding over some 1000
triangles); an icosphere's distances compare with its facets' sag (the
flat faces lie up to r (1 - cos(edge/2r)) inside the true sphere).
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from fabhal.kinematics.exact import (
    closest_on_triangles,
    deepest_inside,
    nearest_on_mesh,
    signed_by_winding,
    signed_distance,
    triangle_mesh,
    winding_number,
)


def _box(size: float = 10.0) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=(size, size, size))


def _brute_force_distance(points: np.ndarray, mesh: trimesh.Trimesh) -> np.ndarray:
    triangles = np.asarray(mesh.triangles)
    pairs_points = np.repeat(points, len(triangles), axis=0)
    pairs_triangles = np.tile(triangles, (len(points), 1, 1))
    closest = closest_on_triangles(pairs_points, pairs_triangles)
    return np.linalg.norm(pairs_points - closest, axis=1).reshape(len(points), -1).min(axis=1)


def test_the_closest_point_on_a_triangle_agrees_with_trimesh_in_every_region() -> None:
    rng = np.random.default_rng(0)
    triangles = rng.normal(size=(2000, 3, 3)) * 10.0
    # points around each triangle, so that every region (face, three edges, three corners) is met
    points = triangles.mean(axis=1) + rng.normal(size=(2000, 3)) * 15.0
    ours = closest_on_triangles(points, triangles)
    theirs = trimesh.triangles.closest_point(triangles, points)
    assert np.abs(ours - theirs).max() < 1e-9


def test_the_nearest_triangle_is_the_nearest_of_all() -> None:
    """Triangles of very different sizes (a box's two large faces and a fine
    sphere) in one mesh: the search by size classes misses none."""
    mesh = trimesh.util.concatenate(
        [trimesh.creation.box(extents=(200.0, 200.0, 1.0)), trimesh.creation.icosphere(3, radius=5.0)]
    )
    rng = np.random.default_rng(1)
    points = rng.uniform(-60.0, 60.0, size=(300, 3)) * np.array([1.0, 1.0, 0.3])
    distance, nearest, closest = nearest_on_mesh(points, triangle_mesh(mesh.vertices, mesh.faces))
    assert np.abs(distance - _brute_force_distance(points, mesh)).max() < 1e-9
    # the nearest point lies on the triangle named, at the distance given
    on_named = closest_on_triangles(points, np.asarray(mesh.triangles)[nearest])
    assert np.abs(on_named - closest).max() < 1e-9
    assert np.abs(np.linalg.norm(points - closest, axis=1) - distance).max() < 1e-9


def test_signed_distance_to_a_box_is_known_by_hand() -> None:
    box = _box(10.0)  # faces at +-5 mm
    points = np.array(
        [
            [0.0, 0.0, 0.0],  # the centre: 5 mm in
            [4.0, 0.0, 0.0],  # 1 mm in from a face
            [6.0, 0.0, 0.0],  # 1 mm out beyond a face
            [6.0, 6.0, 0.0],  # beyond an edge: sqrt 2 out
            [6.0, 6.0, 6.0],  # beyond a corner: sqrt 3 out
            [4.9, 4.9, 0.0],  # just in near an edge: 0.1 in (where the sign is read off the edge)
        ]
    )
    expected = np.array([-5.0, -1.0, 1.0, np.sqrt(2.0), np.sqrt(3.0), -0.1])
    found = signed_distance(points, triangle_mesh(box.vertices, box.faces))
    assert np.abs(found - expected).max() < 1e-9


def test_the_sign_is_right_beside_edges_and_corners_of_a_sphere() -> None:
    """Points on the rays through a sphere's vertices and its edges' midpoints,
    where the closest point is a corner or an edge and a face's normal alone
    could give the wrong side: 1 mm in is inside, 1 mm out outside."""
    sphere = trimesh.creation.icosphere(2, radius=20.0)
    vertices, faces = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    edges = np.asarray(sphere.edges_unique)
    directions = np.concatenate([vertices, 0.5 * (vertices[edges[:, 0]] + vertices[edges[:, 1]])])
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    radius_there = np.concatenate([np.full(len(vertices), 20.0), np.linalg.norm(
        0.5 * (vertices[edges[:, 0]] + vertices[edges[:, 1]]), axis=1)])  # fmt: skip
    inside = signed_distance(directions * (radius_there - 1.0)[:, None], triangle_mesh(vertices, faces))
    outside = signed_distance(directions * (radius_there + 1.0)[:, None], triangle_mesh(vertices, faces))
    assert np.all(inside < 0.0) and np.all(outside > 0.0)
    # 1 mm along the ray from a corner or an edge's midpoint is at most 1 mm from the surface
    assert np.abs(inside).max() <= 1.0 + 1e-9 and np.abs(outside).max() <= 1.0 + 1e-9


def test_signed_distance_to_a_convex_polyhedron_matches_its_planes() -> None:
    """For a convex mesh (an icosphere) the answer is known without a search:
    a point is inside when it is behind every face's plane, and then its depth
    is its distance to the nearest plane; outside it is the unsigned distance."""
    sphere = trimesh.creation.icosphere(3, radius=15.0)
    vertices, faces = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    rng = np.random.default_rng(2)
    points = rng.uniform(-20.0, 20.0, size=(400, 3))
    normals, origins = np.asarray(sphere.face_normals), np.asarray(sphere.triangles)[:, 0]
    heights = np.einsum("ptj,tj->pt", points[:, None] - origins[None], normals)  # (p, t), + outside
    inside = np.all(heights < 0.0, axis=1)
    expected = np.where(inside, heights.max(axis=1), _brute_force_distance(points, sphere))
    assert inside.any() and not inside.all()
    assert np.abs(signed_distance(points, triangle_mesh(vertices, faces)) - expected).max() < 1e-9


def test_the_winding_number_is_one_inside_and_zero_outside() -> None:
    box = _box(10.0)
    points = np.array([[0.0, 0.0, 0.0], [4.9, -4.9, 4.9], [5.1, 0.0, 0.0], [30.0, 1.0, 2.0]])
    winding = winding_number(points, triangle_mesh(box.vertices, box.faces))
    assert np.abs(winding - np.array([1.0, 1.0, 0.0, 0.0])).max() < 1e-3


def test_a_soup_of_triangles_winds_like_the_surface_it_tiles() -> None:
    """The sphere's triangles with no vertex shared (a scan's soup): no
    manifold for the pseudonormals, but the winding number still tells inside."""
    sphere = trimesh.creation.icosphere(3, radius=10.0)
    triangles = np.asarray(sphere.triangles)
    soup_vertices = triangles.reshape(-1, 3)
    soup_faces = np.arange(len(soup_vertices)).reshape(-1, 3)
    points = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 9.0], [0.0, 0.0, 11.0], [8.0, 8.0, 8.0]])
    soup = triangle_mesh(soup_vertices, soup_faces)
    winding = winding_number(points, soup)
    assert np.abs(winding - np.array([1.0, 1.0, 0.0, 0.0])).max() < 1e-3
    depth = np.maximum(-signed_by_winding(points, soup), 0.0)
    # a face's centre lies this far inside the sphere (its corners, edge / sqrt 3 from it, on the sphere)
    sag = 10.0 - np.sqrt(100.0 - np.asarray(sphere.edges_unique_length).max() ** 2 / 3.0)
    assert depth[0] == pytest.approx(10.0, abs=sag) and depth[1] == pytest.approx(1.0, abs=sag)
    assert depth[2] == 0.0 and depth[3] == 0.0


def _deepest(part: trimesh.Trimesh, body: trimesh.Trimesh, spacing: float) -> float:
    mesh = triangle_mesh(body.vertices, body.faces)
    box = (np.asarray(body.bounds[0]), np.asarray(body.bounds[1]))
    return deepest_inside(np.asarray(part.triangles), lambda p: signed_distance(p, mesh), box, spacing)


def test_the_deepest_point_of_a_sphere_in_a_box_is_its_farthest_corner() -> None:
    """A faceted sphere reaching into a box across one face: the deepest point
    is the vertex farthest along x, its depth that vertex's x beyond the face
    (read at points 0.01 mm apart: within that of the truth, never more)."""
    sphere = trimesh.creation.icosphere(3, radius=10.0)
    box = trimesh.creation.box(extents=(20.0, 40.0, 40.0))
    box.apply_translation((18.0, 0.0, 0.0))  # its near face at x = 8
    truth = float(np.asarray(sphere.vertices)[:, 0].max() - 8.0)
    found = _deepest(sphere, box, spacing=0.01)
    assert truth - 0.01 <= found <= truth + 1e-9
    box.apply_translation((3.0, 0.0, 0.0))  # now 1 mm clear
    assert _deepest(sphere, box, spacing=0.01) == 0.0


def test_a_large_face_is_cut_until_its_part_inside_is_found() -> None:
    """A box's face of two triangles 100 mm across crossing a small sphere: no
    corner of the face is near the sphere, the cut pieces find its inside."""
    plate = trimesh.creation.box(extents=(100.0, 100.0, 100.0))
    plate.apply_translation((-50.0, 0.0, 0.0))  # its face at x = 0
    ball = trimesh.creation.icosphere(3, radius=5.0)
    ball.apply_translation((4.0, 0.0, 0.0))  # the true sphere reaches 1 mm past the face
    found = _deepest(plate, ball, spacing=0.01)
    at_centre_line = -float(signed_distance(np.zeros((1, 3)), triangle_mesh(ball.vertices, ball.faces))[0])
    assert at_centre_line - 0.01 <= found <= 1.0 + 1e-9
