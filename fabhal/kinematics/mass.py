"""Mass properties of closed triangle meshes (pure numpy)."""

from __future__ import annotations

import numpy as np

from fabhal.kinematics.frames import Array


def volume_and_centroid(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, Array]:
    """(n, 3) vertices, (m, 3) triangle indices -> (|volume| in mesh units^3, (3,) centroid).

    Sums signed tetrahedra from the origin, so the sign of an inside-out mesh
    cancels out of the centroid; the volume is returned as its absolute value.
    For a degenerate (zero-volume) mesh the centroid is the vertex mean.
    """
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    det = np.einsum("ij,ij->i", v0, np.cross(v1, v2))
    total = float(det.sum())
    if abs(total) < 1e-12:
        return 0.0, np.asarray(vertices, dtype=float).mean(axis=0)
    centroid = (det[:, None] * (v0 + v1 + v2)).sum(axis=0) / (4.0 * total)
    return abs(total) / 6.0, centroid
