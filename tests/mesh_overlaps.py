"""How deep solved parts lie inside each other and inside the world, measured
on their meshes at the solved frames with exact distances (fabhal/kinematics/
exact.py), not with the solver's distance grids: issue 52's acceptance.

Every pair of bodies is measured, the two parts of a connection included: a
hook's wire lying in a ring touches it, it does not cross it. How deep one
part's surface reaches into another body is found by a branch and bound over
the surface (`deepest_inside`), read at points SPACING_MM apart: on the
smooth contacts of wires and tubes short of the truth by about SPACING_MM^2
over twice the wire's radius (0.08 mm on a 1.5 mm wire), by at most
SPACING_MM at a sharp corner.

A watertight body's inside is told by the pseudonormal where a point is
nearest to it; a body whose pieces are closed or tile a closed surface without
sharing edges (a scan's shells, a soup of triangles) by its winding number. A
scanned room is an open surface (its walls have one side): a point is inside
it where it lies behind the face nearest to it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from fabhal.kinematics.exact import (
    TriangleMesh,
    deepest_inside,
    nearest_on_mesh,
    signed_by_winding,
    signed_distance,
    triangle_mesh,
    winding_number,
)
from fabhal.meshes import part_mesh

SPACING_MM = 0.5  # on a 1.5 mm wire a smooth contact's depth read is short by under 0.1 mm
SLIVER_MM2 = 1.0  # an open piece smaller than this bounds nothing (a scan's stray triangles)
OPEN_SIDE_DEG = 60.0  # a point off a scan's open edge, beside the face rather than behind it, is outside
CLOSED_PROBES = 64  # points near a mesh where its winding number must come out whole


@dataclass(frozen=True)
class Piece:
    mesh: TriangleMesh  # in the body's frame
    side: str  # "manifold" (pseudonormals), "closed" (winding number), "open" (a scan's walls)
    box: tuple[np.ndarray, np.ndarray]  # its vertices' low and high corners


@dataclass(frozen=True)
class Body:
    pieces: tuple[Piece, ...]
    triangles: np.ndarray  # (m, 3, 3) in the body's frame: its whole surface


@dataclass(frozen=True)
class Overlap:
    inside: str  # the part whose surface reaches inside
    of: str  # the body it reaches into
    depth_mm: float


_BODIES: dict[str, Body] = {}  # by the spec's text (a spec holds mappings: not hashable)


def _body(spec: Any) -> Body:
    key = repr(spec)
    if key not in _BODIES:
        import trimesh

        mesh = part_mesh(spec)
        merged = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces), process=True)
        pieces = merged.split(only_watertight=False)
        closed = [
            _piece(_ready(p), "manifold") for p in pieces if p.is_watertight and p.is_winding_consistent
        ]
        rest = [piece for piece in pieces if not piece.is_watertight and piece.area >= SLIVER_MM2]
        if rest:  # a soup of triangles, or a scan's walls: measured as one
            soup = trimesh.util.concatenate(rest)
            if _signed_volume(soup) < 0.0:  # faces turned inwards: the winding number is -1 inside
                soup.invert()
            ready = _ready(soup)
            closed.append(_piece(ready, "closed" if _winds_whole(ready) else "open"))
        _BODIES[key] = Body(tuple(closed), np.asarray(merged.triangles, dtype=float))
    return _BODIES[key]


def _ready(mesh: Any) -> TriangleMesh:
    return triangle_mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))


def _piece(mesh: TriangleMesh, side: str) -> Piece:
    return Piece(mesh, side, (mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)))


def _signed_volume(mesh: Any) -> float:
    """The volume the faces enclose by the divergence theorem: negative when
    they face inwards (trimesh's own `volume` is made positive)."""
    triangles = np.asarray(mesh.triangles)
    volumes = np.einsum("ij,ij->i", triangles[:, 0], np.cross(triangles[:, 1], triangles[:, 2]))
    return float(volumes.sum() / 6.0)


def _winds_whole(mesh: TriangleMesh) -> bool:
    """Whether the mesh winds a whole number of times round points near it: so
    for a closed surface however its pieces are stitched, not for a scan's walls."""
    rng = np.random.default_rng(7)
    low, high = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    probes = low + (high - low) * rng.random((CLOSED_PROBES, 3))
    winding = winding_number(probes, mesh)
    return bool(np.all(np.abs(winding - np.round(winding)) < 1e-3))


def _signed(piece: Piece) -> Callable[[np.ndarray], np.ndarray]:
    """The piece's signed distance (negative inside), by its kind of surface."""
    measure = {"manifold": signed_distance, "closed": signed_by_winding, "open": _behind_open_surface}
    return lambda points: measure[piece.side](points, piece.mesh)


def _behind_open_surface(points: np.ndarray, mesh: TriangleMesh) -> np.ndarray:
    """The distance to an open surface, negative where the point lies behind
    the face nearest to it, within OPEN_SIDE_DEG of its normal."""
    distance, nearest, closest = nearest_on_mesh(points, mesh)
    along = np.einsum("ij,ij->i", points - closest, mesh.face_normals[nearest])
    behind = along < -np.cos(np.radians(OPEN_SIDE_DEG)) * distance
    return np.where(behind, -distance, distance)


def _depth(triangles: np.ndarray, body: Body, frame: np.ndarray, bar: float) -> float:
    """How deep the world `triangles` reach into `body` placed at `frame` (into
    any of its pieces: where pieces overlap, the depth read is the deepest into
    one of them, not into their union)."""
    local = (triangles - frame[:3, 3]) @ frame[:3, :3]
    return max(
        (deepest_inside(local, _signed(piece), piece.box, SPACING_MM, bar) for piece in body.pieces),
        default=0.0,
    )


def overlaps(solution: Any, bar: float) -> list[Overlap]:
    """Every pair of bodies of a solved result where one's surface reaches
    deeper than `bar` into the other, deepest first (a depth is where the
    search stopped past the bar: a lower bound)."""
    model = solution.model
    bodies = [_body(part.spec) for part in model.parts]
    found = []
    for i, part in enumerate(model.parts):
        if part.environment:
            continue
        frame = solution.frames[i]
        triangles = bodies[i].triangles @ frame[:3, :3].T + frame[:3, 3]
        for j, other in enumerate(model.parts):
            if j != i:
                depth = _depth(triangles, bodies[j], solution.frames[j], bar)
                if depth > bar:
                    found.append(Overlap(part.name, other.name, depth))
    return sorted(found, key=lambda o: -o.depth_mm)
