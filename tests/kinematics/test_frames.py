"""The Euler convention and frame algebra."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fabhal.kinematics.frames import euler_matrix, frame_matrix, invert, matrix_euler, rotation_angle_deg

angles = st.tuples(*[st.floats(-360, 360, allow_nan=False)] * 3)


@settings(max_examples=200, deadline=None)
@given(angles)
def test_euler_matrix_is_scipy_extrinsic_xyz(rot: tuple[float, float, float]) -> None:
    expected = Rotation.from_euler("xyz", rot, degrees=True).as_matrix()
    np.testing.assert_allclose(euler_matrix(rot)[:3, :3], expected, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(angles)
def test_matrix_to_angles_rebuilds_the_same_rotation(rot: tuple[float, float, float]) -> None:
    matrix = euler_matrix(rot)
    back = matrix_euler(matrix)
    assert np.all(back > -180.0) and np.all(back <= 180.0)
    np.testing.assert_allclose(euler_matrix(back), matrix, atol=1e-9)


def test_gimbal_lock_still_rebuilds_the_rotation() -> None:
    # pitch 90: the clip-light target; only a - c is defined there
    for rot in [(180.0, 90.0, 0.0), (30.0, -90.0, 40.0), (0.0, 90.0, 0.0)]:
        matrix = euler_matrix(rot)
        np.testing.assert_allclose(euler_matrix(matrix_euler(matrix)), matrix, atol=1e-9)


def test_documented_examples() -> None:
    # R(90, 0, 90) lays a rod's z axis along world x: columns (0,1,0), (0,0,1), (1,0,0)
    np.testing.assert_allclose(
        euler_matrix((90, 0, 90))[:3, :3], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15
    )
    np.testing.assert_allclose(euler_matrix((0, 90, 0))[:3, :3] @ [0, 0, 1], [1, 0, 0], atol=1e-15)


def test_invert_and_geodesic_angle() -> None:
    frame = frame_matrix((1.0, -2.0, 3.0), (10.0, 20.0, 30.0))
    np.testing.assert_allclose(invert(frame) @ frame, np.eye(4), atol=1e-12)
    turned = frame @ euler_matrix((0.0, 0.0, 25.0))
    assert abs(rotation_angle_deg(frame, turned) - 25.0) < 1e-9


def test_batched_shapes() -> None:
    rots = np.zeros((5, 2, 3))
    assert euler_matrix(rots).shape == (5, 2, 4, 4)
    assert matrix_euler(euler_matrix(rots)).shape == (5, 2, 3)
