"""Rigid frames as 4x4 homogeneous matrices; the one implementation of the Euler convention.

A frame is (pos, rot): pos = (x, y, z) in mm, rot = (a, b, c) in degrees with
R = Rz(c) @ Ry(b) @ Rx(a) (intrinsic yaw c, pitch b, roll a; equivalently
scipy's `from_euler("xyz", [a, b, c], degrees=True)`). Matrices map local
coordinates to the parent's; composing is the matrix product.

All functions are pure numpy and broadcast over leading axes:
angles (..., ) -> (..., 4, 4).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def rot_x(deg: ArrayLike) -> Array:
    """(...,) degrees -> (..., 4, 4) rotation about x."""
    t = np.radians(np.asarray(deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    out = np.zeros((*t.shape, 4, 4))
    out[..., 0, 0] = out[..., 3, 3] = 1.0
    out[..., 1, 1], out[..., 1, 2] = c, -s
    out[..., 2, 1], out[..., 2, 2] = s, c
    return out


def rot_y(deg: ArrayLike) -> Array:
    """(...,) degrees -> (..., 4, 4) rotation about y."""
    t = np.radians(np.asarray(deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    out = np.zeros((*t.shape, 4, 4))
    out[..., 1, 1] = out[..., 3, 3] = 1.0
    out[..., 0, 0], out[..., 0, 2] = c, s
    out[..., 2, 0], out[..., 2, 2] = -s, c
    return out


def rot_z(deg: ArrayLike) -> Array:
    """(...,) degrees -> (..., 4, 4) rotation about z."""
    t = np.radians(np.asarray(deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    out = np.zeros((*t.shape, 4, 4))
    out[..., 2, 2] = out[..., 3, 3] = 1.0
    out[..., 0, 0], out[..., 0, 1] = c, -s
    out[..., 1, 0], out[..., 1, 1] = s, c
    return out


def translation(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> Array:
    """Broadcast (...,) coordinates -> (..., 4, 4) translations."""
    # assignment broadcasts; np.broadcast_arrays costs more than the rest (hot in the solver)
    out = np.zeros((*np.broadcast_shapes(_shape(x), _shape(y), _shape(z)), 4, 4))
    out[..., 0, 0] = out[..., 1, 1] = out[..., 2, 2] = out[..., 3, 3] = 1.0
    out[..., 0, 3], out[..., 1, 3], out[..., 2, 3] = x, y, z
    return out


def _shape(value: ArrayLike) -> tuple[int, ...]:
    """np.shape without its dispatch (a few microseconds, ~40,000 times a family member)."""
    return value.shape if isinstance(value, np.ndarray) else np.shape(value)


def euler_matrix(rot: ArrayLike) -> Array:
    """(..., 3) angles (a, b, c) in degrees -> (..., 4, 4) with R = Rz(c) Ry(b) Rx(a)."""
    angles = np.asarray(rot, dtype=float)
    return rot_z(angles[..., 2]) @ rot_y(angles[..., 1]) @ rot_x(angles[..., 0])


def frame_matrix(pos: ArrayLike, rot: ArrayLike) -> Array:
    """(..., 3) position and (..., 3) angles -> (..., 4, 4)."""
    position = np.asarray(pos, dtype=float)
    out = euler_matrix(rot)
    out[..., :3, 3] = position
    return out


def matrix_euler(matrix: ArrayLike) -> Array:
    """(..., 4, 4) -> (..., 3) angles (a, b, c) in degrees, each in (-180, 180].

    Pitch b is taken in [-90, 90]. At pitch +-90 (gimbal lock) only a - c (or
    a + c) is defined; then c is set to 0 and a carries the whole rotation, so
    the angles still rebuild the same matrix.
    """
    m = np.asarray(matrix, dtype=float)
    r20 = np.clip(m[..., 2, 0], -1.0, 1.0)
    b = -np.arcsin(r20)
    locked = np.abs(r20) > 1.0 - 1e-12
    a = np.where(locked, np.arctan2(-m[..., 1, 2], m[..., 1, 1]), np.arctan2(m[..., 2, 1], m[..., 2, 2]))
    c = np.where(locked, 0.0, np.arctan2(m[..., 1, 0], m[..., 0, 0]))
    angles = np.degrees(np.stack([a, b, c], axis=-1))
    return np.where(angles <= -180.0, angles + 360.0, angles)


def invert(matrix: ArrayLike) -> Array:
    """(..., 4, 4) rigid transform -> its inverse (transpose the rotation)."""
    m = np.asarray(matrix, dtype=float)
    out = np.empty_like(m)
    rotation_t = m[..., :3, :3].swapaxes(-1, -2)
    out[..., :3, :3] = rotation_t
    out[..., :3, 3] = -(rotation_t @ m[..., :3, 3:4])[..., 0]
    out[..., 3, :] = (0.0, 0.0, 0.0, 1.0)
    return out


def angular_velocities(twists: ArrayLike) -> Array:
    """(..., 4, 4) twists [[W, v], [0, 0]] (W skew-symmetric) -> (..., 3) their
    angular velocities w, with W @ r = w x r."""
    t = np.asarray(twists, dtype=float)
    return np.stack([t[..., 2, 1], t[..., 0, 2], t[..., 1, 0]], axis=-1)


def rotation_angle_deg(a: ArrayLike, b: ArrayLike) -> Array:
    """Geodesic angle in degrees between the rotations of (..., 4, 4) frames a and b."""
    ra = np.asarray(a, dtype=float)[..., :3, :3]
    rb = np.asarray(b, dtype=float)[..., :3, :3]
    trace = np.einsum("...ij,...ij->...", ra, rb)
    return np.degrees(np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))
