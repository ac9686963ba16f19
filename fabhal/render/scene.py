"""The solved scene: every part's mesh at its solved frame, coloured by role."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fabhal.kinematics.frames import Array, invert
from fabhal.meshes import part_mesh, primitive_mesh
from fabhal.report.solution import hanging_lines

if TYPE_CHECKING:
    from fabhal.solve import Solution
    from fabhal.solve.contacts import Contact

FORMATS = (".glb", ".obj", ".stl", ".png", ".html")

ENVIRONMENT_COLOR = (0.62, 0.63, 0.66)
TARGET_COLOR = (0.96, 0.55, 0.12)
FAILURE_COLOR = (0.86, 0.1, 0.1)
CONTACT_COLOR = (0.8, 0.15, 0.7)  # magenta: no part takes it
# near black, unlike any part: a setting the builder makes (a clip's grip, a `fixed` connection)
HELD_COLOR = (0.12, 0.12, 0.12)
# drawn over everything, like the contacts: where two bodies meet, one hides the other
OVERLAY_ROLES = ("contact", "held")
# parts that are neither: distinct, calm hues (Tableau-like), cycled
PART_COLORS = (
    (0.27, 0.51, 0.71),
    (0.35, 0.63, 0.31),
    (0.58, 0.40, 0.74),
    (0.09, 0.65, 0.67),
    (0.84, 0.37, 0.56),
    (0.55, 0.34, 0.29),
    (0.74, 0.74, 0.13),
)
GHOST_OPACITY = 0.35
FAILURE_MARK_MM = 8.0  # radius of the sphere marking a connection that comes apart
CONTACT_MARK_MM = 5.0  # radius of the dot where a part rests on the environment
HELD_MARK_MM = 9.0  # edge of the cube at a held connection
# the arrow of a contact's force: this long per newton (the gallery's 1-10 N contacts
# draw 10-100 mm, the size of the parts), within these lengths
CONTACT_ARROW_MM_PER_N = 10.0
CONTACT_ARROW_MM = (15.0, 120.0)


@dataclass(frozen=True)
class RenderOptions:
    show_requested: bool = False  # ghost of the target at its requested frame; mark failing connections
    primitives: bool = False  # draw each part's primitives (3D files and the viewer)
    views: tuple[str, ...] = ("iso",)  # pictures: iso, front, side, top
    size: tuple[int, int] = (1200, 900)  # pictures: pixels per view


@dataclass(frozen=True)
class SceneItem:
    name: str  # the program's part name, `part.primitive`, or a marker's description
    role: str  # environment, target, part, primitive, requested, failure, contact, held
    vertices: Array  # (n, 3) in the item's own frame
    faces: np.ndarray  # (m, 3)
    transform: Array  # (4, 4) item frame -> world
    color: tuple[float, float, float]
    opacity: float = 1.0

    def world_vertices(self) -> Array:
        return self.vertices @ self.transform[:3, :3].T + self.transform[:3, 3]


@dataclass(frozen=True)
class Scene:
    items: tuple[SceneItem, ...]
    title: str
    status: str
    requested: Array  # (4, 4) world frame the target should reach
    achieved: Array  # (4, 4) where it is
    tree: tuple[tuple[int, str], ...]  # how it hangs: (depth, line), see report.solution.hanging_lines


def build_scene(solution: Solution, title: str, options: RenderOptions) -> Scene:
    model = solution.model
    target_part = solution.goal.part
    items: list[SceneItem] = []
    colors = iter(PART_COLORS * (1 + len(model.parts) // len(PART_COLORS)))
    for i, part in enumerate(model.parts):
        role = "environment" if part.environment else "target" if i == target_part else "part"
        color = {"environment": ENVIRONMENT_COLOR, "target": TARGET_COLOR}.get(role) or next(colors)
        mesh = _with_body(part.spec, part_mesh(part.spec))
        items.append(_item(part.name, role, mesh, solution.frames[i], color))
        if options.primitives:
            for primitive in part.spec.primitives:
                shape = primitive_mesh(primitive)
                name = f"{part.name}.{primitive.name}"
                items.append(_item(name, "primitive", shape, solution.frames[i], (0.95, 0.85, 0.2)))
    items.extend(_contact_marker(solution, contact) for contact in solution.contacts)
    items.extend(_held_marker(solution, joint.index) for joint in model.joints if joint.held)
    if options.show_requested:
        requested_part = solution.goal.requested @ invert(solution.goal.local())
        ghost = part_mesh(model.parts[target_part].spec)
        name = f"{model.parts[target_part].name} (requested)"
        items.append(_item(name, "requested", ghost, requested_part, TARGET_COLOR, GHOST_OPACITY))
        for fall in solution.falls:
            items.append(_failure_marker(solution, fall.joint, fall.part))
    return Scene(
        tuple(items),
        title,
        solution.status,
        solution.goal.requested,
        solution.target_frame(),
        tuple(hanging_lines(model, solution.forces)),
    )


BODY_RADIUS_MM = 2.0


def _with_body(spec: Any, mesh: Any) -> Any:
    """A part with no mesh file is drawn from its primitives; where they lie apart
    (a turnbuckle's two hooks) a thin rod joins them so it reads as one object.
    Drawing only: masses and centres of mass never see it."""
    import trimesh

    if spec.mesh is not None or len(spec.primitives) < 2:
        return mesh
    origins = [np.array(p.position, dtype=float) for p in spec.primitives]
    sticks = [
        trimesh.creation.cylinder(radius=BODY_RADIUS_MM, segment=(a, b), sections=12)
        for a, b in itertools.pairwise(origins)
        if np.linalg.norm(b - a) > BODY_RADIUS_MM
    ]
    return trimesh.util.concatenate([mesh, *sticks]) if sticks else mesh


def _item(
    name: str, role: str, mesh: Any, transform: Array, color: tuple[float, float, float], opacity: float = 1.0
) -> SceneItem:
    return SceneItem(
        name,
        role,
        np.asarray(mesh.vertices, dtype=float),
        np.asarray(mesh.faces, dtype=int),
        np.asarray(transform, dtype=float),
        color,
        opacity,
    )


def _contact_marker(solution: Solution, contact: Contact) -> SceneItem:
    """A dot where a part rests on the environment and an arrow from it along
    the force the environment exerts on the part, as long as that force is large."""
    import trimesh

    force = np.asarray(contact.force, dtype=float)
    newtons = float(np.linalg.norm(force))
    direction = force / newtons if newtons > 0.0 else np.array([0.0, 0.0, 1.0])
    length = float(np.clip(CONTACT_ARROW_MM_PER_N * newtons, *CONTACT_ARROW_MM))
    point = np.asarray(contact.point, dtype=float)
    dot = trimesh.creation.icosphere(subdivisions=2, radius=CONTACT_MARK_MM)
    neck = direction * length * 0.75  # the shaft three quarters, the head the rest
    shaft = trimesh.creation.cylinder(radius=1.5, segment=(np.zeros(3), neck), sections=10)
    head = trimesh.creation.cone(radius=4.0, height=length * 0.25, sections=12)
    head.apply_transform(_along(direction, neck))
    marker = trimesh.util.concatenate([dot, shaft, head])
    part, holder = (solution.model.parts[i].name for i in (contact.part, contact.rests_on))
    where = np.eye(4)
    where[:3, 3] = point
    return _item(f"{part} rests on {holder} ({newtons:.1f} N)", "contact", marker, where, CONTACT_COLOR)


def _along(direction: Array, origin: Array) -> Array:
    """A frame at `origin` whose z axis is `direction` (a unit vector)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(direction[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, direction)
    x /= np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(direction, x), direction, origin
    return frame


def _held_marker(solution: Solution, joint_index: int) -> SceneItem:
    """A cube where a held connection (a clip, a `fixed` connection) grips:
    the settings a builder makes once, which the solver chose (N506)."""
    import trimesh

    joint = solution.model.joints[joint_index]
    where = solution.model.connector_frame(joint.a, solution.x, solution.frames)
    cube = trimesh.creation.box(extents=(HELD_MARK_MM,) * 3)
    name = f"held: {joint.connection.a} -- {joint.connection.b}"
    return _item(name, "held", cube, where, HELD_COLOR)


def _failure_marker(solution: Solution, joint_index: int, part: str) -> SceneItem:
    import trimesh

    joint = solution.model.joints[joint_index]
    where = solution.model.connector_frame(joint.a, solution.x, solution.frames)
    ball = trimesh.creation.icosphere(subdivisions=2, radius=FAILURE_MARK_MM)
    return _item(
        f"{part} slides off here ({joint.connection.a} -- {joint.connection.b})",
        "failure",
        ball,
        where,
        FAILURE_COLOR,
    )


def render(
    solution: Solution, title: str, path: Path, options: RenderOptions, summary: dict[str, Any]
) -> None:
    """Write the scene to `path`; the suffix picks the format (see FORMATS).
    `summary` is the solve result object (fabhal.report.solution.to_dict), shown by the viewer."""
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"cannot render to `{path.name}`: the suffix must be one of {', '.join(FORMATS)}")
    scene = build_scene(solution, title, options)
    if suffix == ".png":
        from fabhal.render.picture import picture_png

        path.write_bytes(picture_png(scene, summary, options))
    elif suffix == ".html":
        from fabhal.render.viewer import viewer_html

        path.write_text(viewer_html(scene, summary), encoding="utf-8")
    else:
        path.write_bytes(export_3d(scene, suffix))


def export_3d(scene: Scene, suffix: str) -> bytes:
    """One node per item, named as in the program, at its solved transform."""
    import trimesh

    out = trimesh.Scene()
    for item in scene.items:
        mesh = trimesh.Trimesh(item.vertices, item.faces, process=False)
        rgba = np.array([*item.color, item.opacity]) * 255
        mesh.visual = trimesh.visual.ColorVisuals(
            mesh, face_colors=np.tile(rgba.astype(np.uint8), (len(item.faces), 1))
        )
        out.add_geometry(mesh, node_name=item.name, geom_name=item.name, transform=item.transform)
    data = out.export(file_type=suffix.lstrip("."))
    return data if isinstance(data, bytes) else str(data).encode()
