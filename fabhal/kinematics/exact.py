"""Exact distances to triangle meshes: the independent measure of whether solved
parts lie inside each other (issue 52's acceptance). The solver reads distances
from grids (`contact.py`), interpolated and cut off a few cells out; this reads
them off the triangles themselves, so that what it finds is not the grid's error.

A point's distance to a mesh is the least of its distances to the triangles
(the closest point on each, by the regions of Ericson's Real-Time Collision
Detection, 5.1.5). Its side of a watertight mesh is the sign of its offset
from that closest point along the angle-weighted pseudonormal of the face,
edge or vertex it lies on (Baerentzen and Aanaes, 2005: exact for a closed
manifold). A mesh stitched of closed pieces that share no edges (a scan's
shells, a soup of triangles tiling one surface) is no manifold: there a point
is inside where the nearest face's normal says so, and, where the nearest
point lies on an edge or a corner (whose neighbours a soup does not know),
where the mesh's winding number about it is one (the sum of the triangles'
signed solid angles over 4 pi, van Oosterom and Strackee's formula: a pass
over every triangle for each such point).

`deepest_inside` reads how deep one surface reaches into such a body.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fabhal.kinematics.frames import Array

CHUNK_PAIRS = 1_000_000  # point-triangle pairs per numpy pass: some 300 MB of temporaries
NEAREST_CENTRES = 4  # pieces nearest by their centres that bound a point's distance
SMALLEST_SPHERE_MM = 0.25  # pieces are grouped by size from this up, doubling
SEARCH_SPHERE_MM = 8.0  # triangles are cut into pieces no larger for the search
POINTS_PER_PASS = 20_000  # points asked at once: bounds the memory of the neighbour queries


@dataclass(frozen=True)
class TriangleMesh:
    """A mesh made ready for distance queries, built once and asked many times:
    its triangles, cut into pieces no larger than SEARCH_SPHERE_MM (a long
    sliver's bounding sphere would bound nothing), the pieces' centres and
    bounding spheres, a k-d tree of the centres for each size class, and the
    normals its pseudonormals are made of."""

    vertices: Array
    faces: NDArray[np.int64]
    triangles: Array
    pieces: Array  # (k, 3, 3) the triangles cut until each piece's sphere is small: what is searched
    parent: NDArray[np.int64]  # (k,) the triangle each piece is cut from
    centres: Array  # (k, 3) of the pieces
    spheres: Array  # (k,) of the pieces
    all_centres: Any  # scipy cKDTree of every piece's centre
    size_classes: tuple[tuple[NDArray[np.int64], Any, float], ...]  # pieces, their tree, largest sphere
    face_normals: Array
    vertex_normals: Array
    edge_normals: Array
    edge_of: NDArray[np.int64]  # (m, 3): face edge k (corners k, k + 1) -> its row in edge_normals


def triangle_mesh(vertices: Array, faces: NDArray[np.int64]) -> TriangleMesh:
    from scipy.spatial import cKDTree

    vertices, faces = np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64)
    triangles = vertices[faces]
    pieces, parent = _bisected(triangles, SEARCH_SPHERE_MM)
    centres, spheres = _spheres(pieces)
    # pieces grouped by size, so that one large face does not widen every point's search
    size_class = np.floor(np.log2(np.maximum(spheres, SMALLEST_SPHERE_MM) / SMALLEST_SPHERE_MM)).astype(int)
    classes = []
    for size in np.unique(size_class):
        members = np.flatnonzero(size_class == size)
        classes.append((members, cKDTree(centres[members]), float(spheres[members].max())))
    face_normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    face_normals /= np.maximum(np.linalg.norm(face_normals, axis=1, keepdims=True), 1e-300)
    corner_angles = np.stack([_angle_at(triangles, k) for k in range(3)], axis=1)
    vertex_normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(vertex_normals, faces[:, k], corner_angles[:, k, None] * face_normals)
    edges = np.sort(
        np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1
    )
    unique, edge_of = np.unique(edges, axis=0, return_inverse=True)
    edge_normals = np.zeros((len(unique), 3))
    np.add.at(edge_normals, edge_of.ravel(), np.repeat(face_normals, 3, axis=0))
    return TriangleMesh(
        vertices, faces, triangles, pieces, parent, centres, spheres, cKDTree(centres), tuple(classes),
        face_normals, vertex_normals, edge_normals, edge_of.reshape(-1, 3),
    )  # fmt: skip


def _spheres(triangles: Array) -> tuple[Array, Array]:
    """(m, 3) each triangle's centre and (m,) the radius about it that holds it."""
    centres = triangles.mean(axis=1)
    return centres, np.linalg.norm(triangles - centres[:, None], axis=2).max(axis=1)


def _bisected(triangles: Array, largest: float) -> tuple[Array, NDArray[np.int64]]:
    """The triangles cut in halves until every piece's bounding sphere (about
    its centre) is at most `largest`, and each piece's triangle. The pieces are
    for the search only (they need share no edges)."""
    done, done_parent = [], []
    todo, parent = triangles, np.arange(len(triangles))
    while len(todo):
        small = _spheres(todo)[1] <= largest
        done.append(todo[small])
        done_parent.append(parent[small])
        todo, parent = _halved(todo[~small]), np.concatenate([parent[~small], parent[~small]])
    return np.concatenate(done), np.concatenate(done_parent)


def _halved(triangles: Array) -> Array:
    """Each triangle cut in two at its longest edge's midpoint: the first
    halves, then the second (a long sliver becomes short pieces, where cutting
    it in four at every edge would keep it a sliver)."""
    # corner k faces edge k, from corner k + 1 to k + 2
    edges = [np.linalg.norm(triangles[:, (k + 2) % 3] - triangles[:, (k + 1) % 3], axis=1) for k in range(3)]
    k = np.argmax(np.stack(edges, axis=1), axis=1)
    rows = np.arange(len(triangles))
    apex, left, right = triangles[rows, k], triangles[rows, (k + 1) % 3], triangles[rows, (k + 2) % 3]
    middle = (left + right) / 2.0
    return np.concatenate([np.stack([apex, left, middle], axis=1), np.stack([apex, middle, right], axis=1)])


def closest_on_triangles(points: Array, triangles: Array) -> Array:
    """(n, 3) points, (n, 3, 3) triangles (one per point) -> (n, 3) the closest
    point of each triangle to its point."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ab, ac, ap = b - a, c - a, points - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp = points - b
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    cp = points - c
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    # inside the face: barycentric weights from the three areas
    total = va + vb + vc
    safe = np.where(np.abs(total) > 0.0, total, 1.0)
    out = a + ab * (vb / safe)[:, None] + ac * (vc / safe)[:, None]
    # the edges, each where the point projects onto it beyond the face
    on_bc = (va <= 0.0) & (d4 - d3 >= 0.0) & (d5 - d6 >= 0.0)
    out = np.where(on_bc[:, None], b + (c - b) * _ratio(d4 - d3, (d4 - d3) + (d5 - d6))[:, None], out)
    on_ac = (vb <= 0.0) & (d2 >= 0.0) & (d6 <= 0.0)
    out = np.where(on_ac[:, None], a + ac * _ratio(d2, d2 - d6)[:, None], out)
    on_ab = (vc <= 0.0) & (d1 >= 0.0) & (d3 <= 0.0)
    out = np.where(on_ab[:, None], a + ab * _ratio(d1, d1 - d3)[:, None], out)
    # the corners, where the point lies beyond both edges that meet there
    out = np.where(((d6 >= 0.0) & (d5 <= d6))[:, None], c, out)
    out = np.where(((d3 >= 0.0) & (d4 <= d3))[:, None], b, out)
    return np.where(((d1 <= 0.0) & (d2 <= 0.0))[:, None], a, out)


def _dot(u: Array, v: Array) -> Array:
    return np.einsum("ij,ij->i", u, v)


def _ratio(top: Array, bottom: Array) -> Array:
    return np.clip(top / np.where(bottom != 0.0, bottom, 1.0), 0.0, 1.0)


def nearest_on_mesh(points: Array, mesh: TriangleMesh) -> tuple[Array, Array, Array]:
    """Each point's exact distance to the mesh's surface (n,), the nearest
    triangle (n,) and the nearest point on it (n, 3). The pieces nearest by
    their centres bound the distance; every piece whose bounding sphere and
    plane come nearer than that bound is then measured."""
    if len(points) > POINTS_PER_PASS:
        parts = [
            nearest_on_mesh(points[i : i + POINTS_PER_PASS], mesh)
            for i in range(0, len(points), POINTS_PER_PASS)
        ]
        return tuple(np.concatenate(column) for column in zip(*parts, strict=True))  # type: ignore[return-value]
    if not len(points):
        return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    pieces = mesh.pieces
    _, first = mesh.all_centres.query(points, k=min(NEAREST_CENTRES, len(pieces)))
    first = first.reshape(len(points), -1)
    pairs = np.repeat(points, first.shape[1], axis=0)
    near = np.linalg.norm(pairs - closest_on_triangles(pairs, pieces[first.ravel()]), axis=1)
    near = near.reshape(first.shape)
    pick = np.argmin(near, axis=1)
    rows = np.arange(len(points))
    distance, nearest = near[rows, pick], first[rows, pick].astype(np.int64)
    for members, tree, largest in mesh.size_classes:
        rows, columns = _within(tree, points, distance + largest)
        if not len(rows):
            continue
        columns = members[columns]
        # a piece is no nearer than its centre less its sphere, nor than its plane
        offset = points[rows] - mesh.centres[columns]
        bound = np.maximum(
            np.linalg.norm(offset, axis=1) - mesh.spheres[columns],
            np.abs(np.einsum("ij,ij->i", offset, mesh.face_normals[mesh.parent[columns]])),
        )
        rows, columns = rows[bound < distance[rows]], columns[bound < distance[rows]]
        for start in range(0, len(rows), CHUNK_PAIRS):
            r, t = rows[start : start + CHUNK_PAIRS], columns[start : start + CHUNK_PAIRS]
            d = np.linalg.norm(points[r] - closest_on_triangles(points[r], pieces[t]), axis=1)
            # each point's rows are contiguous: its nearest in this pass by a segmented minimum
            heads = np.flatnonzero(np.r_[True, r[1:] != r[:-1]])
            least = np.minimum.reduceat(d, heads)
            owner = r[heads]
            better = least < distance[owner]
            at_least = np.flatnonzero(d == np.repeat(least, np.diff(np.r_[heads, len(r)])))
            first_at_least = at_least[np.searchsorted(at_least, heads)]  # the first row reaching it
            distance[owner[better]] = least[better]
            nearest[owner[better]] = t[first_at_least[better]]
    triangle = mesh.parent[nearest]  # a piece's closest point is its triangle's
    return distance, triangle, closest_on_triangles(points, mesh.triangles[triangle])


FIRST_NEIGHBOURS = 16  # centres asked of the tree at once; doubled for a point with more in reach


def _within(tree: Any, points: Array, radius: Array) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The (point, centre) pairs closer than each point's radius, rows grouped
    by point in order: by k-nearest queries, doubling k where it was not enough
    (arrays throughout: a ball query's lists cost a Python object per point)."""
    rows, columns = [], []
    pending, k = np.arange(len(points)), FIRST_NEIGHBOURS
    while len(pending):
        k = min(k, tree.n)
        found, index = tree.query(points[pending], k=k, distance_upper_bound=float(radius[pending].max()))
        found, index = found.reshape(len(pending), -1), index.reshape(len(pending), -1)
        reach = radius[pending, None]
        complete = (found[:, -1] >= reach[:, 0]) | (k == tree.n)
        hit = (found < reach) & complete[:, None]
        rows.append(np.repeat(pending, hit.sum(axis=1)))
        columns.append(index[hit])
        pending, k = pending[~complete], 2 * k
    order = np.argsort(np.concatenate(rows), kind="stable")
    return np.concatenate(rows)[order], np.concatenate(columns)[order].astype(np.int64)


def signed_distance(points: Array, mesh: TriangleMesh) -> Array:
    """(n,) each point's exact signed distance to a watertight manifold mesh
    with outward faces (mm; negative inside)."""
    distance, nearest, closest = nearest_on_mesh(points, mesh)
    side = np.einsum("ij,ij->i", points - closest, _pseudonormals(mesh, nearest, closest))
    return np.where(side < 0.0, -distance, distance)


FEATURE_SHARE = 1e-9  # a barycentric weight below this puts the closest point on an edge or corner


def _pseudonormals(mesh: TriangleMesh, nearest: Array, closest: Array) -> Array:
    """The angle-weighted pseudonormal (unnormalised) where each closest point
    lies: its face's normal inside the face, the sum of the two faces' normals
    on an edge, the faces' normals weighted by their angles at a corner."""
    weights = _barycentric(mesh.triangles[nearest], closest)
    count = (weights > FEATURE_SHARE).sum(axis=1)
    out = mesh.face_normals[nearest].copy()
    corner = count == 1
    out[corner] = mesh.vertex_normals[mesh.faces[nearest[corner], np.argmax(weights[corner], axis=1)]]
    edge = count == 2
    # the edge between the two corners that carry weight: edge k joins corners k and k + 1
    missing = np.argmin(weights[edge], axis=1)
    out[edge] = mesh.edge_normals[mesh.edge_of[nearest[edge], (missing + 1) % 3]]
    return out


def _angle_at(triangles: Array, k: int) -> Array:
    u = triangles[:, (k + 1) % 3] - triangles[:, k]
    v = triangles[:, (k + 2) % 3] - triangles[:, k]
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v))


def _barycentric(triangles: Array, points: Array) -> Array:
    """(n, 3) the weights of each triangle's corners that make its point."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    v0, v1, v2 = b - a, c - a, points - a
    d00, d01, d11 = _dot(v0, v0), _dot(v0, v1), _dot(v1, v1)
    d20, d21 = _dot(v2, v0), _dot(v2, v1)
    denominator = d00 * d11 - d01 * d01
    safe = np.where(denominator != 0.0, denominator, 1.0)
    v = (d11 * d20 - d01 * d21) / safe
    w = (d00 * d21 - d01 * d20) / safe
    return np.stack([1.0 - v - w, v, w], axis=1)


def winding_number(points: Array, mesh: TriangleMesh) -> Array:
    """(n,) the mesh's winding number about each point: 1 inside a closed,
    outward-facing surface, 0 outside (half on it)."""
    out = np.zeros(len(points))
    per_pass = max(1, CHUNK_PAIRS // max(1, len(mesh.triangles)))
    for start in range(0, len(points), per_pass):
        chunk = points[start : start + per_pass]
        rel = mesh.triangles[None, :, :, :] - chunk[:, None, None, :]  # (p, t, corner, 3)
        length = np.linalg.norm(rel, axis=3)
        a, b, c = rel[:, :, 0], rel[:, :, 1], rel[:, :, 2]
        la, lb, lc = length[:, :, 0], length[:, :, 1], length[:, :, 2]
        det = np.einsum("ptj,ptj->pt", a, np.cross(b, c))
        below = (
            la * lb * lc
            + np.einsum("ptj,ptj->pt", a, b) * lc
            + np.einsum("ptj,ptj->pt", b, c) * la
            + np.einsum("ptj,ptj->pt", c, a) * lb
        )
        out[start : start + per_pass] = 2.0 * np.arctan2(det, below).sum(axis=1) / (4.0 * np.pi)
    return out


def signed_by_winding(points: Array, mesh: TriangleMesh) -> Array:
    """(n,) the signed distance to a closed, outward-facing surface that need
    not be a manifold (negative inside). Where the nearest point lies inside a
    face, that face's normal tells the side; where it lies on an edge or a
    corner (whose neighbours a soup does not know), the winding number does."""
    distance, nearest, closest = nearest_on_mesh(points, mesh)
    weights = _barycentric(mesh.triangles[nearest], closest)
    side = np.einsum("ij,ij->i", points - closest, mesh.face_normals[nearest])
    inside = side < 0.0
    on_feature = (weights <= FEATURE_SHARE).any(axis=1) | (distance == 0.0)
    if on_feature.any():
        inside[on_feature] = winding_number(points[on_feature], mesh) > 0.5
    return np.where(inside, -distance, distance)


def deepest_inside(
    triangles: Array,
    signed: Callable[[Array], Array],
    box: tuple[Array, Array],
    spacing: float,
    enough: float = np.inf,
) -> float:
    """How deep the surface made of `triangles` ((m, 3, 3)) reaches into a body
    (mm; 0 where it stays outside), read at points of the surface no farther
    than `spacing` from every point of it; once a point deeper than `enough` is
    found, that point's depth (so "deeper than `enough`?" is answered without
    the rest). `signed` gives the body's signed distance at points (negative
    inside) and `box` (low, high corners) bounds the body.

    The truth is deeper than the depth read by at most `spacing` (the signed
    distance changes no faster than the point moves), and where the deepest
    point is one of a smooth contact (wires, tubes: the depth falls off with
    the square of the distance from it) by about spacing^2 / (2 r) for the
    contact's smaller radius of curvature r.

    A branch and bound over spheres that cover the surface: no point within r
    of a point c of the surface lies deeper than r - signed(c), while c itself
    lies -signed(c) deep. Spheres that cannot go deeper than the deepest point
    found (or than 0) are dropped; the rest are split: first by grouping the
    faces' centres on halving grids, then by cutting each face in halves, until
    the pieces' spheres are no larger than `spacing`."""
    centres, radii = _spheres(triangles)
    low, high = box
    deepest = 0.0
    alive = np.flatnonzero(_sphere_meets_box(centres, radii, low, high))
    if not len(alive):
        return 0.0
    cell = float(np.ptp(centres[alive], axis=0).max())
    while len(alive) and cell > spacing:
        cell /= 2.0
        group = np.unique(np.floor(centres[alive] / cell), axis=0, return_inverse=True)[1].ravel()
        if group.max() + 1 == len(alive):
            break  # one face to a group: the faces are cut from here
        # each group's sphere about its first face's centre, a point of the surface
        first = np.full(group.max() + 1, len(alive))
        np.minimum.at(first, group, np.arange(len(alive)))
        anchor = centres[alive[first]]
        reach = np.zeros(len(first))
        np.maximum.at(reach, group, np.linalg.norm(centres[alive] - anchor[group], axis=1) + radii[alive])
        distance = signed(anchor)
        deepest = max(deepest, float(-distance.min()))
        if deepest > enough:
            return deepest
        promising = (reach - distance > deepest) & _sphere_meets_box(anchor, reach, low, high)
        alive = alive[promising[group]]
    triangles, centres, radii = triangles[alive], centres[alive], radii[alive]
    while len(triangles):
        distance = signed(centres)
        deepest = max(deepest, float(-distance.min()))
        if deepest > enough:
            return deepest
        split = (radii - distance > deepest) & (radii > spacing)
        triangles = _halved(triangles[split])
        centres, radii = _spheres(triangles)
    return deepest


def _sphere_meets_box(centres: Array, radii: Array, low: Array, high: Array) -> NDArray[np.bool_]:
    outside = np.maximum(low - centres, 0.0) + np.maximum(centres - high, 0.0)
    return np.linalg.norm(outside, axis=1) <= radii
