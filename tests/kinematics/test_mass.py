"""Mesh volume and centre of mass (the reference's formula, checked on shapes with known answers)."""

from __future__ import annotations

import numpy as np
import trimesh

from fabhal.kinematics.mass import volume_and_centroid


def test_box_volume_and_centroid() -> None:
    box = trimesh.creation.box(extents=(10, 20, 30))
    box.apply_translation((1, 2, 3))
    volume, centroid = volume_and_centroid(box.vertices, box.faces)
    assert abs(volume - 6000.0) < 1e-9  # exact for a polyhedron
    np.testing.assert_allclose(centroid, (1, 2, 3), atol=1e-9)


def test_inside_out_mesh_keeps_a_positive_volume_and_the_same_centroid() -> None:
    box = trimesh.creation.box(extents=(2, 2, 2))
    box.apply_translation((5, 0, 0))
    flipped = box.faces[:, ::-1]
    volume, centroid = volume_and_centroid(box.vertices, flipped)
    assert abs(volume - 8.0) < 1e-9
    np.testing.assert_allclose(centroid, (5, 0, 0), atol=1e-9)


def test_agrees_with_trimesh_on_a_sphere() -> None:
    ball = trimesh.creation.icosphere(subdivisions=3, radius=7)
    volume, centroid = volume_and_centroid(ball.vertices, ball.faces)
    assert abs(volume - ball.volume) < 1e-6 * ball.volume
    np.testing.assert_allclose(centroid, ball.center_mass, atol=1e-9)
