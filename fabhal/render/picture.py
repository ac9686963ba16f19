"""A headless picture of the scene: PNG bytes, no display and no GPU needed.

Each view is an orthographic projection rasterised by raster.py, flat-shaded
with a light over the viewer's shoulder. Parts are labelled with their
program names; the requested target frame is drawn as axes (x red, y green,
z blue) beside the achieved one, joined by a dashed line so the gap shows.
Environments are drawn without their back faces, so a room's wall between
the camera and the hack does not hide it.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

from fabhal.kinematics.frames import Array
from fabhal.render.raster import rasterize
from fabhal.render.scene import CONTACT_COLOR, HELD_COLOR, OVERLAY_ROLES

if TYPE_CHECKING:
    from PIL import ImageDraw

    from fabhal.render.scene import Scene, SceneItem

# (azimuth about z, elevation) in degrees of the direction the camera looks from
VIEWS = {"iso": (-55.0, 25.0), "front": (-90.0, 0.0), "side": (0.0, 0.0), "top": (-90.0, 89.0)}
VIEW_TITLES = {
    "iso": "three-quarter view",
    "front": "front (looking along +y)",
    "side": "side (looking along -x)",
    "top": "top",
}
BACKGROUND = (250, 250, 248)
MARGIN = 60  # pixels around the hack in each view
HEADER = 64  # pixels of title bar over the views
AXIS_MM_FRACTION = 0.12  # target axes: this fraction of the hack's size
STATUS_COLORS = {"solved": (30, 130, 60), "falls_apart": (200, 30, 30), "not_at_rest": (200, 30, 30)}


@dataclass(frozen=True)
class Camera:
    right: Array  # (3,) world direction of screen x
    up: Array  # (3,) world direction of screen -y
    toward: Array  # (3,) from the scene to the camera
    scale: float  # pixels per mm
    offset: Array  # (2,) pixel position of the world origin

    def project(self, points: Array) -> Array:
        """(n, 3) world -> (n, 3) pixel x, pixel y (down), depth (larger is farther)."""
        x = points @ self.right * self.scale + self.offset[0]
        y = -(points @ self.up) * self.scale + self.offset[1]
        return np.stack([x, y, -(points @ self.toward)], axis=1)


def camera_for(view: str, focus: Array, width: int, height: int) -> Camera:
    """An orthographic camera that fits the `focus` points into the image."""
    azimuth, elevation = np.radians(VIEWS[view])
    toward = np.array(
        [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)]
    )
    right = np.cross(-toward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -toward)
    sx, sy = focus @ right, focus @ up
    span_x, span_y = max(np.ptp(sx), 1.0), max(np.ptp(sy), 1.0)
    scale = min((width - 2 * MARGIN) / span_x, (height - 2 * MARGIN) / span_y)
    centre = np.array([(sx.min() + sx.max()) / 2, (sy.min() + sy.max()) / 2])
    offset = np.array([width / 2 - centre[0] * scale, height / 2 + centre[1] * scale])
    return Camera(right, up, toward, scale, offset)


def picture_png(scene: Scene, summary: dict[str, Any], options: Any) -> bytes:
    from PIL import Image, ImageDraw

    width, height = options.size
    focus = _focus_points(scene)  # every view frames the same points
    views = [_view(scene, focus, view, width, height) for view in options.views]
    canvas = Image.new("RGB", (width * len(views), height + HEADER), BACKGROUND)
    for k, view in enumerate(views):
        canvas.paste(view, (k * width, HEADER))
    _header(ImageDraw.Draw(canvas), scene, summary, canvas.width)
    buffer = io.BytesIO()
    canvas.save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()


def _focus_points(scene: Scene) -> Array:
    """What the camera frames: the hack and the requested target, not the whole room."""
    points = [item.world_vertices() for item in scene.items if item.role != "environment"]
    points.append(scene.requested[None, :3, 3])
    return np.concatenate(points)


def _view(scene: Scene, focus: Array, view: str, width: int, height: int) -> Any:
    from PIL import Image, ImageDraw

    camera = camera_for(view, focus, width, height)
    # contacts lie where two bodies meet, hidden by one of them: drawn over everything
    overlays = [item for item in scene.items if item.role in OVERLAY_ROLES]
    solid = [item for item in scene.items if item.opacity >= 1.0 and item.role not in OVERLAY_ROLES]
    ghosts = [item for item in scene.items if item.opacity < 1.0]
    image, owner = _shade(solid, camera, width, height)
    for ghost in ghosts:  # see-through: blended over everything, wherever it projects
        ghost_image, ghost_owner = _shade([ghost], camera, width, height)
        covered = ghost_owner >= 0
        image[covered] = (1 - ghost.opacity) * image[covered] + ghost.opacity * ghost_image[covered]
    overlay_image, overlay_owner = _shade(overlays, camera, width, height)
    image[overlay_owner >= 0] = overlay_image[overlay_owner >= 0]
    picture = Image.fromarray(np.clip(image, 0, 255).astype(np.uint8))
    draw = ImageDraw.Draw(picture)
    _target_axes(draw, scene, camera, focus)
    taken = _labels(draw, solid, owner, camera)
    _labels(draw, overlays, overlay_owner, camera, taken)
    title_box = draw.textbbox((12, 10), VIEW_TITLES[view], font=label_font(15))
    draw.rectangle(
        [title_box[0] - 4, title_box[1] - 3, title_box[2] + 4, title_box[3] + 3], fill=(255, 255, 255)
    )
    draw.text((12, 10), VIEW_TITLES[view], fill=(90, 90, 90), font=label_font(15))
    return picture


def _shade(items: list[SceneItem], camera: Camera, width: int, height: int) -> tuple[Array, np.ndarray]:
    """(height, width, 3) colours and (height, width) index of the item seen at each pixel (-1: none)."""
    vertices, faces, owners, kept = [], [], [], 0
    for k, item in enumerate(items):
        world = item.world_vertices()
        item_faces = item.faces
        if item.role == "environment":
            normals = _normals(world, item_faces)
            item_faces = item_faces[normals @ camera.toward >= 0.0]  # drop faces turned away
        vertices.append(world)
        faces.append(item_faces + kept)
        owners.append(np.full(len(item_faces), k))
        kept += len(world)
    image = np.empty((height, width, 3))
    image[:] = BACKGROUND
    owner = np.full((height, width), -1)
    if not vertices:
        return image, owner
    world = np.concatenate(vertices)
    all_faces = np.concatenate(faces)
    face_owner = np.concatenate(owners)
    raster = rasterize(camera.project(world), all_faces, width, height)
    seen = raster.face >= 0
    face = raster.face[seen]
    light = camera.toward + 0.5 * camera.up + 0.3 * camera.right
    light /= np.linalg.norm(light)
    brightness = 0.35 + 0.65 * np.abs(_normals(world, all_faces[face]) @ light)
    colors = np.array([item.color for item in items]) * 255
    image[seen] = colors[face_owner[face]] * brightness[:, None]
    owner[seen] = face_owner[face]
    return image, owner


def _normals(vertices: Array, faces: np.ndarray) -> Array:
    triangle = vertices[faces]
    normal = np.cross(triangle[:, 1] - triangle[:, 0], triangle[:, 2] - triangle[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    return normal / np.where(length > 0, length, 1.0)


def _target_axes(draw: ImageDraw.ImageDraw, scene: Scene, camera: Camera, focus: Array) -> None:
    """Requested frame as long axes, achieved as short ones, a dashed line between."""
    size = AXIS_MM_FRACTION * max(np.ptp(focus, axis=0).max(), 1.0)
    for frame, length, width in ((scene.requested, size, 3), (scene.achieved, size * 0.6, 2)):
        origin = camera.project(frame[None, :3, 3])[0, :2]
        for axis, color in enumerate(((220, 40, 40), (40, 160, 40), (40, 80, 220))):
            tip = camera.project((frame[:3, 3] + length * frame[:3, axis])[None])[0, :2]
            draw.line([tuple(origin), tuple(tip)], fill=color, width=width)
    start = camera.project(scene.achieved[None, :3, 3])[0, :2]
    end = camera.project(scene.requested[None, :3, 3])[0, :2]
    gap = float(np.linalg.norm(end - start))
    for k in range(0, int(gap), 12):  # dashes of 6 px
        a = start + (end - start) * k / gap
        b = start + (end - start) * min(k + 6, gap) / gap
        draw.line([tuple(a), tuple(b)], fill=(60, 60, 60), width=2)
    font = label_font(13)
    draw.text(tuple(end + 6), "requested", fill=(60, 60, 60), font=font)


Box = tuple[float, float, float, float]


def _labels(
    draw: ImageDraw.ImageDraw,
    items: list[SceneItem],
    owner: np.ndarray,
    camera: Camera,
    taken: list[Box] | None = None,
) -> list[Box]:
    """Each visible part's name beside its visible pixels, with a leader line;
    labels never overlap each other or those in `taken`. Returns every label's box."""
    font = label_font(14)
    taken = [] if taken is None else taken
    for k, item in enumerate(items):
        if item.role in ("environment", "primitive"):
            continue
        rows, cols = np.nonzero(owner == k)
        if len(rows) == 0:
            continue
        anchor = np.array([np.median(cols), np.median(rows)])
        box = draw.textbbox((0, 0), item.name, font=font)
        w, h = box[2] - box[0] + 8, box[3] - box[1] + 6
        x, y = cols.max() + 14, anchor[1] - h / 2
        while any(x < x1 and x + w > x0 and y < y1 and y + h > y0 for x0, y0, x1, y1 in taken):
            y += h + 2
        taken.append((x, y, x + w, y + h))
        draw.line([tuple(anchor), (x, y + h / 2)], fill=(80, 80, 80), width=1)
        draw.rectangle([x, y, x + w, y + h], fill=(255, 255, 255), outline=(150, 150, 150))
        draw.text((x + 4, y + 2), item.name, fill=(20, 20, 20), font=font)
    return taken


def _header(draw: ImageDraw.ImageDraw, scene: Scene, summary: dict[str, Any], width: int) -> None:
    draw.rectangle([0, 0, width, HEADER], fill=(255, 255, 255))
    draw.line([0, HEADER - 1, width, HEADER - 1], fill=(200, 200, 200))
    draw.text((16, 10), scene.title, fill=(20, 20, 20), font=label_font(20))
    status = scene.status.replace("_", " ")
    target = summary.get("target") or {}
    detail = ""
    if target.get("position_error_mm") is not None:
        detail = (
            f"target {target['part']}: {target['position_error_mm']:.1f} mm, "
            f"{target['rotation_error_deg']:.1f} deg from requested"
        )
    draw.text((16, 38), status, fill=STATUS_COLORS.get(scene.status, (120, 120, 120)), font=label_font(16))
    draw.text((130, 38), detail, fill=(70, 70, 70), font=label_font(16))
    legend: list[tuple[str, tuple[int, int, int] | None]] = [
        ("environment", (158, 160, 168)),
        ("target", (245, 140, 31)),
    ]
    if any(item.role == "contact" for item in scene.items):
        red, green, blue = (round(255 * c) for c in CONTACT_COLOR)
        legend.append(("contact, force on the part", (red, green, blue)))
    if any(item.role == "held" for item in scene.items):
        red, green, blue = (round(255 * c) for c in HELD_COLOR)
        legend.append(("held (set when building)", (red, green, blue)))
    legend.append(("requested target axes: x y z", None))
    font = label_font(14)
    widths = [int(draw.textlength(text, font=font)) + (18 if color else 0) + 18 for text, color in legend]
    # on the title's row, right-aligned; left out where it would run into the title
    x = width - sum(widths)
    if x < 16 + int(draw.textlength(scene.title, font=label_font(20))) + 24:
        return
    for (text, color), taken in zip(legend, widths, strict=True):
        if color is not None:
            draw.rectangle([x, 16, x + 12, 28], fill=color)
        draw.text((x + (18 if color else 0), 14), text, fill=(70, 70, 70), font=font)
        x += taken


@cache
def label_font(size: int) -> Any:
    from PIL import ImageFont

    return ImageFont.load_default(size=size)
