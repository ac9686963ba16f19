"""Part meshes (loaded, or built from the primitives) and mass properties.

Mass = mesh volume x material density (g/cm3 -> grams), unless the part has a
`mass` line; the centre of mass is the mesh's centroid (uniform density).
Meshes load lazily (trimesh is imported only here) and are cached per file.
A directory of meshes may carry `measures.json` (the library's does): each
file's volume, centroid and bounds with the file's SHA-256, so solving with
library parts never loads a mesh, even on a first run. Regenerate it with
`python -m fabhal.meshes DIRECTORY`; tests/test_meshes.py checks it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache, partial
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabhal.kinematics.contact import DistanceGrid, grid_spacing, signed_distance_grid
from fabhal.kinematics.frames import Array
from fabhal.kinematics.mass import volume_and_centroid
from fabhal.library import PartSpec
from fabhal.primitives import Primitive

if TYPE_CHECKING:
    import trimesh

MEASURES_FILE = "measures.json"
MESH_SUFFIXES = (".obj", ".stl", ".glb", ".ply", ".off")
_ARC_SEGMENTS_PER_TURN = 48
_WIRE_SEGMENTS = 12


# a part's own frame this far outside its bounding box (mm) is worth a word (N424, `fabhal
# parts`): a target on it places a point the user may think is on the part (the handle
# basket's origin lies 164 mm from its body; the library's movable parts are otherwise within 25)
FRAME_OUTSIDE_SAID_MM = 50.0


@dataclass(frozen=True)
class MassProperties:
    mass_g: float | None  # None: no material and no `mass` line (environments, bare primitives)
    center_of_mass: tuple[float, float, float]  # mm, in the part frame
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]]  # mm, part frame
    volume_mm3: float
    source: str  # "mesh", "primitives" or "mass line"

    @property
    def frame_outside_mm(self) -> float:
        """How far the part's own frame (its origin) lies outside its bounding
        box (0 inside): a target on the part's frame places that point."""
        low, high = self.bounds
        return sum(max(lo, -hi, 0.0) ** 2 for lo, hi in zip(low, high, strict=True)) ** 0.5


@lru_cache(maxsize=64)
def load_mesh(path: Path) -> trimesh.Trimesh:
    import trimesh

    mesh = trimesh.load(str(path), force="mesh")
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def _arc_mesh(radius: float, wire: float, sweep_deg: float) -> trimesh.Trimesh:
    """A wire of radius `wire` along an arc of radius `radius` in the y-z plane,
    from -z (0 deg) towards -y (90 deg); closed with end caps unless a full circle."""
    import trimesh

    full = sweep_deg >= 360.0
    n_u = max(int(_ARC_SEGMENTS_PER_TURN * sweep_deg / 360.0), 2)
    # a polygonal cross-section with the circle's area, so volumes (masses) come out right
    sides = _WIRE_SEGMENTS
    wire *= np.sqrt(np.pi / (sides / 2 * np.sin(2 * np.pi / sides)))
    u = np.radians(np.linspace(0.0, sweep_deg, n_u, endpoint=not full))
    v = np.linspace(0.0, 2 * np.pi, _WIRE_SEGMENTS, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    radial = np.stack([np.zeros_like(uu), -np.sin(uu), -np.cos(uu)], axis=-1)
    normal_x = np.array([1.0, 0.0, 0.0])
    points = radius * radial + wire * (np.cos(vv)[..., None] * radial + np.sin(vv)[..., None] * normal_x)
    vertices = points.reshape(-1, 3)
    faces = []
    rings = n_u if full else n_u - 1
    for i in range(rings):
        i2 = (i + 1) % n_u
        for j in range(_WIRE_SEGMENTS):
            j2 = (j + 1) % _WIRE_SEGMENTS
            a, b = i * _WIRE_SEGMENTS + j, i * _WIRE_SEGMENTS + j2
            c, d = i2 * _WIRE_SEGMENTS + j, i2 * _WIRE_SEGMENTS + j2
            faces += [[a, c, b], [b, c, d]]
    if not full:
        centers = radius * radial[[0, -1], 0]
        first, last = len(vertices), len(vertices) + 1
        vertices = np.vstack([vertices, centers])
        end = (n_u - 1) * _WIRE_SEGMENTS
        for j in range(_WIRE_SEGMENTS):
            j2 = (j + 1) % _WIRE_SEGMENTS
            faces.append([first, j, j2])
            faces.append([last, end + j2, end + j])
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=True)
    mesh.fix_normals()
    return mesh


def _lower_half_ball(radius: float, rings: int = 8, sectors: int = 24) -> trimesh.Trimesh:
    """The ball's lower half (z <= 0), closed by a flat cap at z = 0."""
    import trimesh

    polar = np.linspace(np.pi / 2, np.pi, rings + 1)[:-1]  # equator down to just above the pole
    around = np.linspace(0.0, 2 * np.pi, sectors, endpoint=False)
    pp, aa = np.meshgrid(polar, around, indexing="ij")
    rim = radius * np.stack([np.sin(pp) * np.cos(aa), np.sin(pp) * np.sin(aa), np.cos(pp)], axis=-1)
    vertices = np.vstack([rim.reshape(-1, 3), [[0.0, 0.0, -radius], [0.0, 0.0, 0.0]]])
    pole, centre = len(vertices) - 2, len(vertices) - 1
    faces = []
    for i in range(rings - 1):
        for j in range(sectors):
            j2 = (j + 1) % sectors
            a, b, c, d = i * sectors + j, i * sectors + j2, (i + 1) * sectors + j, (i + 1) * sectors + j2
            faces += [[a, b, c], [b, d, c]]
    last = (rings - 1) * sectors
    for j in range(sectors):
        j2 = (j + 1) % sectors
        faces.append([last + j, last + j2, pole])
        faces.append([j2, j, centre])
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=True)
    mesh.fix_normals()
    return mesh


def primitive_mesh(primitive: Primitive) -> trimesh.Trimesh:
    """The primitive's shape (reference section b.1) placed in its part's frame."""
    import trimesh

    p = primitive.params
    kind = primitive.kind
    if kind == "rod":
        mesh = trimesh.creation.cylinder(radius=p["radius"], height=p["length"], sections=24)
    elif kind == "tube":
        mesh = trimesh.creation.annulus(
            r_min=p["inner_radius"], r_max=p["inner_radius"] + p["thickness"], height=p["length"], sections=32
        )
    elif kind in ("hook", "hole"):
        sweep = p.get("arc_angle", 360.0)
        mesh = _arc_mesh(p["arc_radius"], p["thickness"], sweep)
    elif kind == "clip":
        offset = (p["dist"] + p["open_gap"]) / 4.0
        jaws = []
        for side in (-1.0, 1.0):
            jaw = trimesh.creation.box(extents=(p["thickness"], p["width"], p["height"]))
            jaw.apply_translation((side * offset, 0.0, 0.0))
            jaws.append(jaw)
        mesh = trimesh.util.concatenate(jaws)
    elif kind == "edge":
        mesh = trimesh.creation.box(extents=(p["length"], p["width"], p["height"]))
    elif kind == "surface":
        mesh = trimesh.creation.box(extents=(p["length"], p["width"], 0.1))
    else:
        mesh = _lower_half_ball(p["radius"])
    mesh.apply_transform(primitive.base_frame())
    return mesh


def part_mesh(
    spec: PartSpec, shape: Callable[[Primitive], trimesh.Trimesh] = primitive_mesh
) -> trimesh.Trimesh:
    """The part's mesh file, or its primitives' shapes (`shape` of each) when it has none."""
    import trimesh

    if spec.mesh is not None:
        return load_mesh(spec.mesh)
    combined = trimesh.util.concatenate([shape(p) for p in spec.primitives])
    assert isinstance(combined, trimesh.Trimesh)
    return combined


def mass_properties(spec: PartSpec) -> MassProperties:
    volume, centroid, (low, high) = _mesh_measures(spec)
    if spec.mass_override is not None:
        mass, source = spec.mass_override, "mass line"
    elif spec.density is not None:
        mass = volume * spec.density / 1000.0  # mm3 x g/cm3 -> g
        source = "mesh" if spec.mesh is not None else "primitives"
    else:
        mass, source = None, "mesh" if spec.mesh is not None else "primitives"
    return MassProperties(
        mass,
        (float(centroid[0]), float(centroid[1]), float(centroid[2])),
        (low, high),  # type: ignore[arg-type]
        volume,
        source,
    )


Measures = tuple[float, tuple[float, float, float], tuple[tuple[float, ...], tuple[float, ...]]]


def _mesh_measures(spec: PartSpec) -> Measures:
    """Volume (mm3), centroid and bounds of the part's mesh: from `measures.json`
    beside the mesh file when it lists that very file; else measured once and
    kept on disk in the user cache dir, keyed by the mesh file's bytes (or the
    primitives it is built from) and this module's code. Solving then needs no
    mesh loaded, and not even trimesh imported (~1.5 s on a cold start)."""
    import hashlib
    import json

    from fabhal import resources

    if spec.mesh is not None:
        shipped = _shipped_measures(spec.mesh)
        if shipped is not None:
            return shipped
    digest = hashlib.sha256(_file_digest(Path(__file__)))
    digest.update(_file_digest(spec.mesh) if spec.mesh is not None else repr(spec.primitives).encode())
    directory = resources.cache_dir()
    path = directory / f"mesh-{digest.hexdigest()[:24]}.json" if directory is not None else None
    if path is not None and path.is_file():
        try:
            volume, centroid, low, high = json.loads(path.read_text())
            return float(volume), tuple(centroid), (tuple(low), tuple(high))  # type: ignore[return-value]
        except (ValueError, TypeError, OSError):
            pass  # damaged: measure again
    measures = _measure(part_mesh(spec))
    low, high = (list(corner) for corner in measures[2])
    if path is not None:
        try:
            temporary = path.with_suffix(f".{os.getpid()}.tmp")
            temporary.write_text(json.dumps([measures[0], list(measures[1]), low, high]))
            temporary.replace(path)
        except OSError:
            pass
    return measures  # type: ignore[return-value]


def _measure(mesh: trimesh.Trimesh) -> Measures:
    volume, centroid = volume_and_centroid(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    low, high = (tuple(float(c) for c in corner) for corner in mesh.bounds)
    return float(volume), tuple(float(c) for c in centroid), (low, high)  # type: ignore[return-value]


def _shipped_measures(mesh: Path) -> Measures | None:
    """The measures in `measures.json` beside the mesh, if it lists this very file."""
    entry = _measures_table(mesh.parent).get(mesh.name)
    if not isinstance(entry, dict) or entry.get("sha256") != _file_digest(mesh).hex():
        return None
    try:
        low, high = entry["bounds"]
        return float(entry["volume"]), tuple(entry["centroid"]), (tuple(low), tuple(high))
    except (KeyError, TypeError, ValueError):
        return None


@lru_cache(maxsize=16)
def _measures_table(directory: Path) -> dict[str, object]:
    import json

    try:
        table = json.loads((directory / MEASURES_FILE).read_text())
    except (OSError, ValueError):
        return {}
    return table if isinstance(table, dict) else {}


def measure_directory(directory: Path) -> dict[str, dict[str, object]]:
    """`measures.json`'s content for every mesh file in `directory`."""
    table: dict[str, dict[str, object]] = {}
    for path in sorted(p for p in directory.iterdir() if p.suffix.lower() in MESH_SUFFIXES):
        volume, centroid, bounds = _measure(load_mesh(path))
        table[path.name] = {
            "sha256": _file_digest(path).hex(),
            "volume": volume,
            "centroid": list(centroid),
            "bounds": [list(corner) for corner in bounds],
        }
    return table


@lru_cache(maxsize=256)
def _file_digest(path: Path) -> bytes:
    """SHA-256 of a file, once per process: every solve attempt asks again for
    each part's mass, and the largest meshes are megabytes."""
    import hashlib

    return hashlib.sha256(path.read_bytes()).digest()


# ---------------------------------------------------------------- contact shapes

# an environment's distance grid reaches this far beyond its mesh (mm)
CONTACT_MARGIN_MM = 50.0
# a piece of a mesh thinner than this, joined to nothing thicker, is a sheet with no
# inside (a decal on a wall): not an obstacle; walls and floors are modelled as solids
SHEET_MM = 1.0
# a flat piece smaller than this (mm^2) is a sliver a scan left, not a face (a broom
# handle's end cap has 178 of 0.7 mm^2)
SLIVER_MM2 = 1.0
# a slab this thick stands behind an environment's surface primitive (a wall, a counter top)
SURFACE_SLAB_MM = 40.0
# points sampled on a movable part's surface to keep out of the environment:
# about one per this spacing (mm), within the bounds below
CONTACT_POINT_SPACING_MM = 8.0
CONTACT_POINTS = (64, 400)
# the check's points (`check_points`): fine enough for a wire (a hanger's 6.3 mm, a
# mug's 2.2 mm wall, a caddy's handle) that the settle's points, up to 40 mm apart on
# a large part, can pass between
CHECK_POINT_SPACING_MM = 3.0
CHECK_POINTS = (256, 40_000)


def contact_grid(spec: PartSpec, building: Callable[[], None] | None = None) -> DistanceGrid:
    """The part's signed distance grid (fabhal/kinematics/contact.py), built
    once from its mesh and kept in the user cache dir like the measures;
    `building` is told before a grid is built (0.1-10 s)."""
    return _cached_array(spec, "grid", _build_grid, building)  # type: ignore[return-value]


def hull_grid(spec: PartSpec, building: Callable[[], None] | None = None) -> DistanceGrid:
    """The signed distance grid of the part's convex hull: its volume with every
    cavity and opening filled (a mug's inside, a ring's hole). Where two parts
    pass through each other, their thin walls cross and the true grids know
    only the wall's millimetres; the hulls' depth says which way is out.
    Cached like `contact_grid`."""
    return _cached_array(spec, "hull-grid", _build_hull_grid, building)  # type: ignore[return-value]


def contact_points(spec: PartSpec, check: bool = False) -> Array:
    """(N, 3) points on the movable part's surface, in its frame (seeded: the
    same every run): about CONTACT_POINT_SPACING_MM apart for the settle's
    springs, CHECK_POINT_SPACING_MM apart for the check (`check`)."""
    if check:
        finer = partial(_sample_points, spacing=CHECK_POINT_SPACING_MM, counts=CHECK_POINTS)
        return _cached_array(spec, "check-points", finer)  # type: ignore[return-value]
    return _cached_array(spec, "points", _sample_points)  # type: ignore[return-value]


def near_primitive(
    spec: PartSpec, primitive: Primitive, reach: float, check: bool = False
) -> NDArray[np.bool_]:
    """(N,) whether each of the part's contact points (`contact_points`, the
    check's if `check`) lies within `reach` of the primitive's shape
    (`primitive_mesh`), or inside it. Cached like the points (measured once per
    machine: sampling the shape costs a solve 0.1-1 s, importing trimesh included)."""
    import hashlib

    which = hashlib.sha256(f"{primitive!r} {reach!r}".encode()).hexdigest()[:12]
    kind = f"near-{'check-' if check else ''}{which}"
    near = _cached_array(spec, kind, lambda s: _near(contact_points(s, check), primitive, reach))
    return near  # type: ignore[return-value]


def _near(points: Array, primitive: Primitive, reach: float) -> NDArray[np.bool_]:
    import trimesh
    from scipy.spatial import cKDTree

    shape = primitive_mesh(primitive)
    # samples about a millimetre apart: far finer than the reach
    count = int(np.clip(shape.area, 500, 50_000))
    samples, faces = trimesh.sample.sample_surface(shape, count, seed=0)
    distance, nearest = cKDTree(samples).query(points)
    # behind the nearest sample's outward normal is inside
    behind = np.einsum("ij,ij->i", points - samples[nearest], shape.face_normals[faces][nearest]) < 0.0
    near: NDArray[np.bool_] = (distance <= reach) | behind
    return near


def obstacle_bounds(spec: PartSpec) -> Array:
    """(2, 3) mm, part frame: the bounds of the part as an obstacle (its contact
    grid's mesh: a surface primitive is a slab behind its face, `_solid_shape`),
    without building that mesh."""
    low, high = (np.asarray(corner, dtype=float) for corner in mass_properties(spec).bounds)
    for primitive in spec.primitives:
        if primitive.kind != "surface":
            continue
        extents, placement = _slab(primitive)
        signs = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        corners = np.hstack([signs * extents / 2, np.ones((8, 1))]) @ placement.T
        low, high = np.minimum(low, corners[:, :3].min(axis=0)), np.maximum(high, corners[:, :3].max(axis=0))
    return np.array([low, high])


def inside_bounds(spec: PartSpec) -> Array:
    """(2, 3) mm, part frame: where its grid (`contact_grid`, `hull_grid`: the
    same bounds, the same cells) may give a negative distance, the obstacle's
    bounds widened by two cells. The grid is measured from samples of the
    surface, so a node a fraction of a cell outside may read inside (the
    mug's, 0.66 mm out: -0.04 mm), and trilinear distances between nodes cut
    across curved faces; a point two cells out has every corner of its cell
    more than a cell outside, where the nodes read outside. Cut at the
    bounds, a point 0.02 mm inside by the grid switched in at that depth, and
    the settle's energy jumped by a spring's worth (three mugs on a rod:
    1.9e-6 J within 2e-5 mm; line searches halved 25 times, not at rest)."""
    low, high = obstacle_bounds(spec)
    cells = 2.0 * grid_spacing(low - CONTACT_MARGIN_MM, high + CONTACT_MARGIN_MM)
    return np.array([low - cells, high + cells])


def _slab(primitive: Primitive) -> tuple[Array, Array]:
    """A surface primitive as an obstacle: the extents (3,) mm of the slab behind
    its face and the placement (4, 4) of the slab's centre in the part's frame."""
    p = primitive.params
    behind = np.eye(4)
    behind[2, 3] = -SURFACE_SLAB_MM / 2
    return np.array([p["length"], p["width"], SURFACE_SLAB_MM]), np.asarray(
        primitive.base_frame(), dtype=float
    ) @ behind


def _solid_shape(primitive: Primitive) -> trimesh.Trimesh:
    """A primitive's shape as an obstacle: a surface primitive is a slab behind its face."""
    import trimesh

    if primitive.kind != "surface":
        return primitive_mesh(primitive)
    extents, placement = _slab(primitive)
    return trimesh.creation.box(extents=extents, transform=placement)


def _build_grid(spec: PartSpec) -> DistanceGrid:
    return _mesh_grid(part_mesh(spec, _solid_shape))


def _build_hull_grid(spec: PartSpec) -> DistanceGrid:
    return _mesh_grid(part_mesh(spec, _solid_shape).convex_hull)


def _mesh_grid(mesh: trimesh.Trimesh) -> DistanceGrid:
    low = np.asarray(mesh.bounds[0]) - CONTACT_MARGIN_MM
    high = np.asarray(mesh.bounds[1]) + CONTACT_MARGIN_MM
    sample_spacing = grid_spacing(low, high) / 2
    surfaces = []
    for pieces in _closed_surfaces(mesh):
        points, normals = zip(*(_surface_samples(piece, sample_spacing) for piece in pieces), strict=True)
        surfaces.append((np.concatenate(points), np.concatenate(normals)))
    return signed_distance_grid(surfaces, low, high)


def _surface_samples(piece: trimesh.Trimesh, spacing: float) -> tuple[Array, Array]:
    """Points about `spacing` apart on the piece (at least 100), with their outward normals."""
    import trimesh

    count = max(int(piece.area / spacing**2), 100)
    points, faces = trimesh.sample.sample_surface(piece, count, seed=0)
    return np.asarray(points), np.asarray(piece.face_normals[faces])


def _closed_surfaces(mesh: trimesh.Trimesh) -> list[list[trimesh.Trimesh]]:
    """The mesh's closed surfaces, each as the pieces (faces joined by their
    edges) that make it up. A piece is one surface unless a flat piece (thinner
    than SHEET_MM) shares a vertex with it: a board scanned with its front face
    and its sides not stitched along their edges is one solid, whose pieces the
    grid must measure together (apart, the face alone read everything behind it
    as inside, and the sides everything in front). A flat piece that shares no
    vertex with a thicker one is a sheet (a decal on a wall): no inside."""
    import trimesh

    component = {}
    for label, vertices in enumerate(
        trimesh.graph.connected_components(mesh.edges, nodes=np.arange(len(mesh.vertices)), min_len=1)
    ):
        component.update(dict.fromkeys(map(tuple, mesh.vertices[vertices].tolist()), label))
    joined: dict[int, list[trimesh.Trimesh]] = {}
    for piece in mesh.split(only_watertight=False):
        if piece.area >= SLIVER_MM2 or not _flat(piece):  # a scan's flat slivers bound nothing
            joined.setdefault(component[tuple(piece.vertices[0].tolist())], []).append(piece)
    surfaces = []
    for pieces in joined.values():
        flat = [_flat(piece) for piece in pieces]
        if all(flat):
            continue
        surfaces.extend([pieces] if any(flat) else [[piece] for piece in pieces])
    return surfaces


def _flat(piece: trimesh.Trimesh) -> bool:
    return bool(piece.extents.min() < SHEET_MM)


def _sample_points(
    spec: PartSpec, spacing: float = CONTACT_POINT_SPACING_MM, counts: tuple[int, int] = CONTACT_POINTS
) -> Array:
    import trimesh

    mesh = part_mesh(spec)
    count = int(np.clip(mesh.area / spacing**2, *counts))
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=0)
    return np.asarray(points, dtype=float)


_CONTACT_CACHE: dict[tuple[str, str], object] = {}


def _cached_array(
    spec: PartSpec, kind: str, build: Callable[[PartSpec], object], building: Callable[[], None] | None = None
) -> object:
    """`build(spec)` once per process and once per machine: kept in the user cache
    dir (an .npz), keyed by the mesh file's bytes (or the primitives) and the code
    that builds it."""
    import hashlib

    from fabhal import resources
    from fabhal.kinematics import contact

    digest = hashlib.sha256(_file_digest(Path(__file__)) + _file_digest(Path(contact.__file__)))
    digest.update(_file_digest(spec.mesh) if spec.mesh is not None else repr(spec.primitives).encode())
    key = (kind, digest.hexdigest()[:24])
    if key in _CONTACT_CACHE:
        return _CONTACT_CACHE[key]
    directory = resources.cache_dir()
    path = directory / f"{kind}-{key[1]}.npz" if directory is not None else None
    value = _load_array(path, kind) if path is not None and path.is_file() else None
    if value is None:
        if building is not None:
            building()
        value = build(spec)
        if path is not None:
            _save_array(path, value)
    _CONTACT_CACHE[key] = value
    return value


def _load_array(path: Path, kind: str) -> object | None:
    try:
        with np.load(path) as stored:
            if "values" in stored:  # a grid: the surface's or the hull's (`_save_array`)
                return DistanceGrid(stored["origin"], float(stored["spacing"]), stored["values"])
            return stored["points"]
    except (OSError, ValueError, KeyError):
        return None  # damaged: build again


def _save_array(path: Path, value: object) -> None:
    arrays = (
        {"origin": value.origin, "spacing": np.array(value.spacing), "values": value.values}
        if isinstance(value, DistanceGrid)
        else {"points": value}
    )
    try:
        temporary = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")
        np.savez_compressed(temporary, **arrays)
        temporary.replace(path)
    except OSError:
        pass


if __name__ == "__main__":  # python -m fabhal.meshes DIRECTORY: write DIRECTORY/measures.json
    import json
    import sys

    target = Path(sys.argv[1])
    (target / MEASURES_FILE).write_text(json.dumps(measure_directory(target), indent=1) + "\n")
