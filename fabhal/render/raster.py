"""A z-buffer triangle rasteriser in pure numpy: the headless picture's 3D kernel.

No window system, no GPU. Scanline rasterisation, vectorised over all
triangles at once: every (triangle, pixel row) pair gets the span between the
triangle's edges at the row's pixel centre, the spans expand into pixels, and
the nearest surface wins each pixel. Work is the covered area plus one entry
per row, so fine meshes and long thin rods are both cheap.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fabhal.kinematics.frames import Array

_PIXELS_PER_BATCH = 4_000_000  # bounds the memory of one batch (~150 MB)


@dataclass(frozen=True)
class Raster:
    face: np.ndarray  # (height, width) int: the face seen at each pixel, -1 for none
    depth: Array  # (height, width): its depth (larger is farther), inf for none


def rasterize(screen: Array, faces: np.ndarray, width: int, height: int) -> Raster:
    """screen: (n, 3) vertices as (pixel x, pixel y, depth), y down; faces: (m, 3).
    A pixel belongs to a triangle when its centre (x + 0.5, y + 0.5) is inside."""
    triangles = screen[faces]  # (m, 3, 3)
    edge1, edge2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    normal = np.cross(edge1, edge2)
    first_row = np.maximum(np.ceil(triangles[:, :, 1].min(axis=1) - 0.5), 0).astype(int)
    last_row = np.minimum(np.floor(triangles[:, :, 1].max(axis=1) - 0.5), height - 1).astype(int)
    on_screen = (
        (np.abs(normal[:, 2]) > 1e-12)
        & (last_row >= first_row)
        & (triangles[:, :, 0].max(axis=1) >= 0)
        & (triangles[:, :, 0].min(axis=1) < width)
    )
    visible = np.flatnonzero(on_screen)
    # estimate each triangle's pixels to cut the work into batches of bounded memory
    cost = np.cumsum((last_row - first_row + 1)[visible] * (1 + np.ptp(triangles[visible, :, 0], axis=1)))
    batches: list[int] = []
    if len(visible):
        bounds = np.arange(_PIXELS_PER_BATCH, cost[-1] + _PIXELS_PER_BATCH, _PIXELS_PER_BATCH)
        batches = [int(b) for b in np.searchsorted(cost, bounds)]
    face = np.full(width * height, -1, dtype=int)
    depth = np.full(width * height, np.inf)
    start = 0
    for stop in [*batches, len(visible)]:
        members = visible[start : stop + 1]
        start = stop + 1
        if len(members) == 0:
            continue
        pixel, z, face_id = _spans(triangles, normal, first_row, last_row, members, width)
        _keep_nearest(face, depth, pixel, z, face_id)
    return Raster(face.reshape(height, width), depth.reshape(height, width))


def _spans(
    triangles: Array,
    normal: Array,
    first_row: np.ndarray,
    last_row: np.ndarray,
    members: np.ndarray,
    width: int,
) -> tuple[np.ndarray, Array, np.ndarray]:
    """Pixels (flat index), depths and face ids covered by `members`."""
    rows_per = last_row[members] - first_row[members] + 1
    owner = np.repeat(members, rows_per)  # one entry per (triangle, row)
    row = first_row[owner] + _ranges(rows_per)
    centre_y = row + 0.5
    tri = triangles[owner]
    left = np.full(len(owner), np.inf)
    right = np.full(len(owner), -np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        y0, y1 = tri[:, i, 1], tri[:, j, 1]
        crosses = (np.minimum(y0, y1) <= centre_y) & (centre_y <= np.maximum(y0, y1)) & (y0 != y1)
        fraction = np.where(crosses, (centre_y - y0) / np.where(y0 != y1, y1 - y0, 1.0), 0.0)
        x = tri[:, i, 0] + fraction * (tri[:, j, 0] - tri[:, i, 0])
        left = np.where(crosses, np.minimum(left, x), left)
        right = np.where(crosses, np.maximum(right, x), right)
    first_col = np.maximum(np.ceil(left - 0.5), 0)
    last_col = np.minimum(np.floor(right - 0.5), width - 1)
    cols_per = np.maximum(last_col - first_col + 1, 0).astype(int)
    span = np.repeat(np.arange(len(owner)), cols_per)
    col = first_col[span].astype(int) + _ranges(cols_per)
    face_id = owner[span]
    n = normal[face_id]
    origin = triangles[face_id, 0]
    # the triangle's plane: depth at the pixel centre
    z = (
        origin[:, 2]
        - (n[:, 0] * (col + 0.5 - origin[:, 0]) + n[:, 1] * (row[span] + 0.5 - origin[:, 1])) / n[:, 2]
    )
    return row[span] * width + col, z, face_id


def _ranges(counts: np.ndarray) -> np.ndarray:
    """Concatenated aranges: [0..counts[0]), [0..counts[1]), ..."""
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=int)
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total) - starts


def _keep_nearest(face: np.ndarray, depth: Array, pixel: np.ndarray, z: Array, face_id: np.ndarray) -> None:
    if len(pixel) == 0:
        return
    order = np.lexsort((z, pixel))  # by pixel, nearest first
    pixel, z, face_id = pixel[order], z[order], face_id[order]
    first = np.flatnonzero(np.r_[True, pixel[1:] != pixel[:-1]])
    pixel, z, face_id = pixel[first], z[first], face_id[first]
    nearer = z < depth[pixel]
    face[pixel[nearer]] = face_id[nearer]
    depth[pixel[nearer]] = z[nearer]
