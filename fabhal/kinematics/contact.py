"""Contact with the world: signed distance grids of meshes and the penalty
that keeps points out of them (pure numpy, plus scipy's k-d tree).

A mesh's signed distance (mm; negative inside) is sampled once on a regular
grid and interpolated trilinearly: smooth enough for gradient methods (its
gradient is the outward normal), vectorised over thousands of points, and
cheap to keep (fabhal/meshes.py caches the grids on disk). It is measured
from points sampled on the surface with their normals, so a scan that is not
closed still has an inside wherever its normals face away.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from fabhal.kinematics.frames import Array

# the grid has at most this many points (2 MB as float32)
GRID_POINTS = 500_000
FINEST_CELL_MM = 2.0
BAND_CELLS = 4.0  # see signed_distance_grid
NEAREST_SAMPLES = 4  # of which the one facing the point gives its side


# mm: the side of the cubes a part's contact points are gathered in (`PointCells`)
CELL_MM = 16.0
# mm: how much a cube's ball is widened against rounding in `PointCells.near_box`
CELL_ROUNDING_MM = 1e-6


@dataclass(frozen=True, eq=False)
class PointCells:
    """A part's points gathered into cubes CELL_MM a side, each with the ball
    round its points: a cube whose ball misses a box has no point in the box,
    so only the points of the cubes whose balls reach it need moving into the
    box's frame and testing (two mugs side by side: a tenth of their 8,500
    points; moving them all was most of a settle's time)."""

    order: NDArray[np.intp]  # (N,) the points' indices, cube after cube
    counts: NDArray[np.intp]  # (K,) how many points each cube holds
    centres: Array  # (K, 3) the middle of each cube's points
    radii: Array  # (K,) the ball round them

    @staticmethod
    def of(points: Array) -> PointCells:
        cube = np.floor(points / CELL_MM).astype(np.int64)
        cube -= cube.min(axis=0, initial=0)
        span = cube.max(axis=0, initial=0) + 1
        key = (cube[:, 0] * span[1] + cube[:, 1]) * span[2] + cube[:, 2]  # one number per cube
        _, which, counts = np.unique(key, return_inverse=True, return_counts=True)
        centres = np.zeros((len(counts), 3))
        np.add.at(centres, which, points)
        centres /= counts[:, None]
        radii = np.zeros(len(counts))
        np.maximum.at(radii, which, np.linalg.norm(points - centres[which], axis=1))
        return PointCells(np.argsort(which, kind="stable"), counts, centres, radii)

    def near_box(self, to_box: Array, low: Array, high: Array) -> Array:
        """(G, N) whether each point may lie in the box [low, high] after each
        of G rigid motions (G, 4, 4) into the box's frame: True for every
        point of a cube whose ball reaches the box (a superset of those in it)."""
        centres = self.centres @ to_box[:, :3, :3].transpose(0, 2, 1) + to_box[:, None, :3, 3]
        reach = self.radii[None, :, None] + CELL_ROUNDING_MM
        cubes = ((centres >= low - reach) & (centres <= high + reach)).all(axis=2)
        near = np.zeros(cubes.shape[:1] + self.order.shape, dtype=bool)
        near[:, self.order] = np.repeat(cubes, self.counts, axis=1)
        return near


@dataclass(frozen=True)
class DistanceGrid:
    """A signed distance field sampled at origin + spacing * (i, j, k): read
    trilinearly (exact at the samples: a mug's 2.2 mm wall on 2 mm cells stays
    a wall), or `smooth`, by a quadratic B-spline over the samples (its
    gradient continuous: what parts rest on, `sample`)."""

    origin: Array  # (3,) mm
    spacing: float  # mm
    values: Array  # (nx, ny, nz) mm, negative inside
    smooth: bool = False

    def near(self, centre: Array, radius: float) -> bool:
        """Whether a ball (in the grid's frame) reaches into the grid's box."""
        high = self.origin + self.spacing * (np.array(self.values.shape) - 1)
        return bool(np.linalg.norm(centre - np.clip(centre, self.origin, high)) <= radius)

    def could_be_inside(self, points: Array) -> Array:
        """(N,) bool: False where a point is certainly outside: every sample it
        is read from (its cell's 8 corners; smooth, its nearest node's 27) is
        positive, and the weights are too, so its distance is. Exact, not an
        estimate: `sample` of the points it clears gives negative distances
        exactly where `sample` of all would; a contact needs only those (most
        points of a part lie far from any surface: a hoop in a room). Looking
        at a wider block (4 cells a side) let through points up to 4 cells
        from the surface, whose look-ups cost the caddy's solve 0.3 s of 4.8."""
        _, index, within = self._located(points)
        read = np.clip(index, 0, self._last_cell)  # any index where not `within`: cleared anyway
        return within & (self._least_read[read[:, 0], read[:, 1], read[:, 2]] <= 0.0)

    def _located(self, points: Array) -> tuple[Array, Array, Array]:
        """Points in cells of the grid (N, 3), the index each is read from (N,
        3): trilinearly its cell's least corner, smooth its nearest node; and
        (N,) whether all the samples it is read from lie in the grid."""
        cell = (points - self.origin) / self.spacing
        index = np.floor(cell + 0.5 if self.smooth else cell).astype(int)
        first, last = self._offsets[0], self._offsets[-1]
        return cell, index, np.all((index + first >= 0) & (index + last <= self._last_cell), axis=1)

    @cached_property
    def _last_cell(self) -> Array:
        """(3,) the cells along each axis: a cell's first corner lies below it."""
        return np.array(self.values.shape) - 1

    @cached_property
    def _flat(self) -> Array:
        # in double precision for the spline's einsums (over float32 they take a slow path)
        return self.values.ravel().astype(float) if self.smooth else self.values.ravel()

    @cached_property
    def _strides(self) -> Array:
        """(3,) a grid index's step in `_flat` along each axis."""
        ny, nz = self.values.shape[1:]
        return np.array([ny * nz, nz, 1])

    @cached_property
    def _offsets(self) -> tuple[int, ...]:
        """The samples a point is read from, along each axis, from its index
        (`_located`): trilinearly its cell's two corners, smooth its nearest
        node and the two beside it."""
        return (-1, 0, 1) if self.smooth else (0, 1)

    @cached_property
    def _read_steps(self) -> Array:
        """(8 or 27,) the samples a point is read from as steps in `_flat` from
        its index, [x][y][z]."""
        x, y, z = self._strides
        return np.array(
            [a * x + b * y + e * z for a in self._offsets for b in self._offsets for e in self._offsets]
        )

    @cached_property
    def _least_read(self) -> Array:
        """The least of the samples read from each index (`_offsets`; past the
        grid's last node, its last)."""
        least = self.values
        for axis in range(3):
            n = least.shape[axis]
            shifted = [np.take(least, np.clip(np.arange(n) + o, 0, n - 1), axis=axis) for o in self._offsets]
            least = np.minimum.reduce(shifted)
        return least

    def sample(self, points: Array) -> tuple[Array, Array]:
        """(N, 3) points in the grid's frame -> (N,) distances and (N, 3)
        gradients (trilinear, or `_spline`). Outside the grid (smooth: within
        half a cell of its edge too): +inf and zero."""
        cell, index, inside = self._located(points)
        distance = np.full(len(points), np.inf)
        gradient = np.zeros((len(points), 3))
        if not inside.any():
            return distance, gradient
        if self.smooth:
            distance[inside], gradient[inside] = self._spline(cell[inside], index[inside])
            return distance, gradient
        c = index[inside]
        u = cell[inside] - c
        corners = self._flat[(c @ self._strides)[:, None] + self._read_steps].reshape(-1, 2, 2, 2)
        ux, uy, uz = u[:, 0, None, None], u[:, 1, None], u[:, 2]
        along_x = corners[:, 0] * (1 - ux) + corners[:, 1] * ux  # (n, 2, 2) over y, z
        along_y = along_x[:, 0] * (1 - uy) + along_x[:, 1] * uy  # (n, 2) over z
        distance[inside] = along_y[:, 0] * (1 - uz) + along_y[:, 1] * uz
        d_x = corners[:, 1] - corners[:, 0]
        d_x = d_x[:, 0] * (1 - uy) + d_x[:, 1] * uy
        d_y = along_x[:, 1] - along_x[:, 0]
        gradient[inside, 0] = d_x[:, 0] * (1 - uz) + d_x[:, 1] * uz
        gradient[inside, 1] = d_y[:, 0] * (1 - uz) + d_y[:, 1] * uz
        gradient[inside, 2] = along_y[:, 1] - along_y[:, 0]
        gradient /= self.spacing
        return distance, gradient

    def sample_inside(self, points: Array) -> tuple[Array, Array]:
        """`sample`, but gradients only where the distance is negative (elsewhere
        zero): a contact needs the way out of the points inside only, and most
        points looked up lie just outside (the caddy's handles beside the seat
        backs: 8 of 494 inside), whose gradients were most of a look-up. Read
        trilinearly, the gradient costs little beside the distance: one `sample`."""
        if not self.smooth:
            distance, gradient = self.sample(points)
            gradient[~(distance < 0.0)] = 0.0
            return distance, gradient
        distance = self.distance(points)
        gradient = np.zeros((len(points), 3))
        inside = distance < 0.0
        if inside.any():
            gradient[inside] = self.sample(points[inside])[1]
        return distance, gradient

    def distance(self, points: Array) -> Array:
        """`sample`'s distances alone, by the same arithmetic (equal to the bit)."""
        if not self.smooth:
            return self.sample(points)[0]
        cell, index, inside = self._located(points)
        distance = np.full(len(points), np.inf)
        if inside.any():
            weight = _spline_weights(cell[inside] - index[inside])
            distance[inside] = _spline_distance(self._around(index[inside]), weight)[0]
        return distance

    def _around(self, node: Array) -> Array:
        """(n, 3, 3, 3) the samples around each node."""
        return self._flat[(node @ self._strides)[:, None] + self._read_steps].reshape(-1, 3, 3, 3)

    def _spline(self, cell: Array, node: Array) -> tuple[Array, Array]:
        """The quadratic B-spline over the nearest node's 3 x 3 x 3 samples:
        weights 1/2 (1/2 - t)^2, 3/4 - t^2, 1/2 (1/2 + t)^2 along each axis (t:
        the offset from the node, in cells). It reproduces a linear field (a
        flat face) exactly and smooths a curved one by about h^2 / 8 times its
        Laplacian, as trilinear reading errs between nodes (the seat backs' 9.6
        mm cells over a 50 mm round: 0.2 to 0.5 mm); its gradient is continuous."""
        t = cell - node  # (n, 3) in [-1/2, 1/2)
        weight = _spline_weights(t)
        slope = np.stack([t - 0.5, -2.0 * t, t + 0.5], axis=2)
        around = self._around(node)
        wx, wy, wz = weight[:, 0], weight[:, 1], weight[:, 2]
        # each axis's weights against the other two's sums (einsum over three operands
        # and more loops naively)
        distance, along_x = _spline_distance(around, weight)
        along_y = np.einsum("nabc,na,nc->nb", around, wx, wz)
        along_z = np.einsum("nabc,na,nb->nc", around, wx, wy)
        gradient = np.stack(
            [
                np.einsum("na,na->n", along_x, slope[:, 0]),
                np.einsum("nb,nb->n", along_y, slope[:, 1]),
                np.einsum("nc,nc->n", along_z, slope[:, 2]),
            ],
            axis=1,
        )
        return distance, gradient / self.spacing


def _spline_weights(t: Array) -> Array:
    """(n, 3) offsets from the nearest nodes (cells, in [-1/2, 1/2)) -> (n, axis,
    3) the quadratic B-spline's weights of the node before, the node and the
    one after, along each axis."""
    return np.stack([0.5 * (0.5 - t) ** 2, 0.75 - t**2, 0.5 * (0.5 + t) ** 2], axis=2)


def _spline_distance(around: Array, weight: Array) -> tuple[Array, Array]:
    """The spline's (n,) distances from the samples `around` (n, 3, 3, 3) and the
    weights (`_spline_weights`), and (n, 3) the samples summed over y and z (what
    the x-derivative reads too): one arithmetic for `sample` and `distance`."""
    along_x = np.einsum("nabc,nb,nc->na", around, weight[:, 1], weight[:, 2])
    return np.einsum("na,na->n", along_x, weight[:, 0]), along_x


def signed_distance_grid(components: list[tuple[Array, Array]], low: Array, high: Array) -> DistanceGrid:
    """The signed distance of a union of closed surfaces on a grid over the box
    [low, high] (mm), with at most GRID_POINTS points (cells no finer than
    FINEST_CELL_MM). Each surface is given as points sampled on it (about half
    a cell apart) with their outward normals.

    A grid point's distance from one surface is measured from the nearest
    sample (of the NEAREST_SAMPLES nearest, the one facing the point most):
    along that sample's normal where the point lies over it (within
    1.5 cells sideways: exact over flat and gently curved surface), else
    straight to it (beyond an edge or corner); inside where it lies behind the
    normal. The union's is the least over the surfaces (surfaces that touch or
    overlap, like a hook's pad on a wall, are one solid), each measured only
    near its own bounds: farther than BAND_CELLS cells out, distances are cut
    to that, which is all a contact needs to know."""
    from scipy.spatial import cKDTree

    spacing = grid_spacing(low, high)
    counts = np.ceil((high - low) / spacing).astype(int) + 1
    band = BAND_CELLS * spacing
    values = np.full(tuple(counts), band)
    for samples, normals in components:
        first = np.clip(np.floor((samples.min(axis=0) - band - low) / spacing).astype(int), 0, counts - 1)
        last = np.clip(np.ceil((samples.max(axis=0) + band - low) / spacing).astype(int), 0, counts - 1)
        axes = [low[d] + spacing * np.arange(first[d], last[d] + 1) for d in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
        shape = grid.shape[:3]
        points = grid.reshape(-1, 3)
        straight, nearest = cKDTree(samples).query(points, k=min(NEAREST_SAMPLES, len(samples)))
        straight, nearest = straight.reshape(len(points), -1), nearest.reshape(len(points), -1)
        along = np.einsum("pkj,pkj->pk", points[:, None] - samples[nearest], normals[nearest])
        # of the nearest samples, the one facing the point most: a thin sheet's two
        # faces lie at the same place, and the point is on the side of the one facing it
        facing = along / np.maximum(straight, 1e-9)
        near = straight <= straight[:, :1] + spacing / 2
        pick = np.argmax(np.where(near, facing, -np.inf), axis=1)
        rows = np.arange(len(points))
        straight, along = straight[rows, pick], along[rows, pick]
        sideways = np.sqrt(np.maximum(straight**2 - along**2, 0.0))
        # the samples are random, about half a cell apart: a point over the face may
        # find its nearest one more than a cell aside (1.5 keeps a 400 mm slab's face
        # exact to 1e-6 mm), and the straight distance to it would be wrong
        distance = np.where(sideways <= 1.5 * spacing, along, np.copysign(straight, along)).reshape(shape)
        block = tuple(slice(first[d], last[d] + 1) for d in range(3))
        values[block] = np.minimum(values[block], distance)
    return DistanceGrid(low, spacing, np.minimum(values, band).astype(np.float32))


def grid_spacing(low: Array, high: Array) -> float:
    """The cell size (mm) of a grid over [low, high] with at most GRID_POINTS points."""
    return max(FINEST_CELL_MM, float(np.prod(high - low) / GRID_POINTS) ** (1 / 3))


def penalty(distance: Array, stiffness: float | Array) -> tuple[float, Array]:
    """Energy sum(stiffness / 2 x depth^2) over the points inside (depth =
    -distance where negative; stiffness one for all, or one per point), and its
    derivative by each distance."""
    depth = np.maximum(-distance, 0.0)
    return 0.5 * float(stiffness * depth @ depth), -stiffness * depth


def rectangles_overlap(centres: Array, axes: Array, halves: Array) -> float:
    """How deep two rectangles lying in one plane overlap (mm): of the four
    directions of their edges, the least by which their shadows on it overlap
    (the separating axis theorem: where the shadows on one are apart, so are
    the rectangles); 0 or less where they are apart. `centres` (2, 3), `axes`
    (2, 2, 3) each rectangle's two unit edge directions, `halves` (2, 2) its
    half extents along them."""
    edges = axes.reshape(4, 3)
    reach = halves.reshape(4, 1) * np.abs(edges @ edges.T)  # (edge, direction): its shadow's half
    shadows = reach.sum(axis=0) - np.abs(edges @ (centres[1] - centres[0]))
    return float(shadows.min())
