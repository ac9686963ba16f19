"""The pictures of a search: the best members drawn, a contact sheet of them
side by side, and the settled target error plotted against the params (one
panel per value of a name-valued param, one line per value of the others, as
the paper's figure of the clip-light study)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fabhal import api
from fabhal.render import RenderOptions, render
from fabhal.render.picture import label_font as font
from fabhal.report.solution import to_dict
from fabhal.search import SearchOptions, SearchPlan
from fabhal.search.members import MemberResult
from fabhal.search.report import categorical_params, describe, short

if TYPE_CHECKING:
    from fabhal.solve import Solution

TILE = (480, 360)  # pixels of each member's picture
SHEET_COLUMNS = 4
PANEL = (560, 380)  # pixels of each plot panel
MARGIN = (70, 60, 24, 56)  # left, top, right, bottom of a panel's axes
LINE_COLORS = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75)]


def render_members(
    search: SearchPlan,
    members: Sequence[MemberResult],
    options: SearchOptions,
    directory: Path,
    progress: Callable[[int, int], None] | None = None,
    sheet_name: str = "contact_sheet.png",
) -> list[Path]:
    """Solve each member again (the same answer: same program, values, seed; a
    member `--smooth` continued, from the configuration it was found in) and
    draw it; then the contact sheet `sheet_name`. Returns every file written."""
    from fabhal.search.emit import member_file_name

    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for place, member in enumerate(members, start=1):
        if progress is not None:
            progress(place, len(members))
        start = np.array(member.x) if member.x is not None else None
        result = api.solve(
            search.program, member.bindings, options.seed, options.time_limit, two_step=options.two_step,
            start=start,
        )  # fmt: skip
        path = directory / (member_file_name(search.program, member, place) + ".png")
        if draw_tile(result, f"#{place} {member.key}", path):
            written.append((path, f"#{place}  {short_key(member)}", describe(member)))
    sheet = directory / sheet_name
    contact_sheet(written, sheet)
    return [p for p, _, _ in written] + [sheet]


def draw_tile(result: api.SolveResult, title: str, path: Path) -> bool:
    """One contact-sheet tile: the solved result's three-quarter view, TILE
    pixels; False (nothing drawn) when there is no solution to draw."""
    if result.solution is None:
        return False
    solution = cast("Solution", result.solution)
    render(solution, title, path, RenderOptions(views=("iso",), size=TILE), to_dict(result, title))
    return True


def short_key(member: MemberResult) -> str:
    return " ".join(f"{k}={short(v)}" for k, v in member.bindings.items())


def contact_sheet(pictures: Sequence[tuple[Path, str, str]], out: Path) -> None:
    """The pictures in a grid, each captioned with its rank, params and errors."""
    from PIL import Image, ImageDraw

    columns = max(1, min(SHEET_COLUMNS, len(pictures)))
    rows = max(1, math.ceil(len(pictures) / columns))
    caption = 44
    sheet = Image.new("RGB", (columns * TILE[0], rows * (TILE[1] + caption)), "white")
    draw = ImageDraw.Draw(sheet)
    for index, (path, title, detail) in enumerate(pictures):
        x, y = (index % columns) * TILE[0], (index // columns) * (TILE[1] + caption)
        with Image.open(path) as picture:
            picture.thumbnail(TILE)
            sheet.paste(picture, (x, y))
        draw.text((x + 8, y + TILE[1] + 4), title, fill=(20, 20, 20), font=font(15))
        draw.text((x + 8, y + TILE[1] + 24), detail, fill=(80, 80, 80), font=font(13))
    sheet.save(out)


def plot_errors(search: SearchPlan, members: Sequence[MemberResult], out: Path) -> None:
    """Settled position error (mm) against the numeric param with the most
    values; a panel per value of the name-valued params, a line per value of
    the remaining ones; members not at rest are left out (gaps in a line)."""
    from PIL import Image

    named = categorical_params(search)
    numeric = [p for p in search.params if p not in named]
    # along x: the numeric param with the most values
    axis = max(numeric, key=lambda p: len({m[p] for m in search.members})) if numeric else None
    panels = _group(members, named)
    lines_by = [p for p in numeric if p != axis]
    columns = min(2, len(panels))
    rows = math.ceil(len(panels) / columns)
    image = Image.new("RGB", (columns * PANEL[0], rows * PANEL[1]), "white")
    for index, (title, group) in enumerate(panels.items()):
        origin = ((index % columns) * PANEL[0], (index // columns) * PANEL[1])
        _panel(image, origin, title or out.stem, axis, _group(group, lines_by))
    image.save(out)


def _group(members: Sequence[MemberResult], params: Sequence[str]) -> dict[str, list[MemberResult]]:
    groups: dict[str, list[MemberResult]] = {}
    for member in members:
        label = " ".join(f"{p}={short(member.bindings[p])}" for p in params)
        groups.setdefault(label, []).append(member)
    return groups


def _panel(
    image: Any, origin: tuple[int, int], title: str, axis: str | None, lines: dict[str, list[MemberResult]]
) -> None:
    from PIL import ImageDraw

    draw = ImageDraw.Draw(image)
    points = {
        label: [
            (_x_of(m, axis, i), m.position_mm if m.status == "solved" else None) for i, m in enumerate(group)
        ]
        for label, group in lines.items()
    }
    xs = [x for series in points.values() for x, _ in series]
    ys = [y for series in points.values() for _, y in series if y is not None]
    whole = all(float(x).is_integer() for x in xs)  # n = 1 .. 4: no tick at 1.5
    x_ticks = _ticks(min(xs), max(xs), whole=whole)
    y_ticks = _ticks(0.0, max(ys) if ys else 1.0)
    left, top = origin[0] + MARGIN[0], origin[1] + MARGIN[1]
    right, bottom = origin[0] + PANEL[0] - MARGIN[2], origin[1] + PANEL[1] - MARGIN[3]

    def at(x: float, y: float) -> tuple[float, float]:
        fx = (x - x_ticks[0]) / ((x_ticks[-1] - x_ticks[0]) or 1.0)
        fy = (y - y_ticks[0]) / ((y_ticks[-1] - y_ticks[0]) or 1.0)
        return left + fx * (right - left), bottom - fy * (bottom - top)

    _axes(draw, at, x_ticks, y_ticks, (left, top, right, bottom))
    draw.text((left, origin[1] + 10), title, fill=(20, 20, 20), font=font(16))
    draw.text(
        (left + (right - left) / 2 - 30, bottom + 30), axis or "member", fill=(60, 60, 60), font=font(13)
    )
    draw.text((origin[0] + 8, top - 22), "target error, mm", fill=(60, 60, 60), font=font(13))
    drawn: list[tuple[float, float]] = []
    for index, (_, series) in enumerate(points.items()):
        pixels = [at(x, y) if y is not None else None for x, y in series]
        _series(draw, pixels, LINE_COLORS[index % len(LINE_COLORS)])
        drawn.extend(pixel for pixel in pixels if pixel is not None)
    title_end = left + draw.textlength(title, font=font(16))
    _legend(draw, [label for label in points if label], (left, top, right, bottom), drawn, title_end)
    if ys:
        best = min((y, x) for series in points.values() for x, y in series if y is not None)
        cx, cy = at(best[1], best[0])
        draw.ellipse([cx - 7, cy - 7, cx + 7, cy + 7], outline=(0, 0, 0), width=2)


def _legend(
    draw: Any,
    labels: list[str],
    box: tuple[float, float, float, float],
    drawn: list[tuple[float, float]],
    title_end: float,
) -> None:
    """Line colours and labels: in one row above the plot, right of the panel's
    title, where they hide nothing; where the row does not fit there, in a white
    box in the corner of the plot that hides the fewest of the points drawn (the
    clip-light family's n = 1 line ran under a box fixed at the top right)."""
    if not labels:
        return
    widths = [36 + draw.textlength(label, font=font(13)) for label in labels]
    left, top, right, _ = box
    if title_end + 20 + sum(widths) <= right:
        x = right - sum(widths)
        for index, (label, width) in enumerate(zip(labels, widths, strict=True)):
            _legend_entry(draw, (x, top - 44), label, index)
            x += width
        return
    size = (max(widths), 8 + 18 * len(labels))
    left, top = _emptiest_corner(box, size, drawn)
    draw.rectangle([left, top, left + size[0], top + size[1]], fill="white", outline=(200, 200, 200))
    for index, label in enumerate(labels):
        _legend_entry(draw, (left, top + 18 * index), label, index)


def _legend_entry(draw: Any, at: tuple[float, float], label: str, index: int) -> None:
    """A line in the index-th colour and its label, from `at` (the entry's top left)."""
    x, y = at[0], at[1] + 12
    draw.line([(x + 6, y), (x + 26, y)], fill=LINE_COLORS[index % len(LINE_COLORS)], width=3)
    draw.text((x + 30, y - 7), label, fill=(40, 40, 40), font=font(13))


def _emptiest_corner(
    box: tuple[float, float, float, float], size: tuple[float, float], drawn: list[tuple[float, float]]
) -> tuple[float, float]:
    """The top left of a `size` box in a corner of `box` (6 px in) that covers
    the fewest `drawn` points, the top right first among equals."""
    left, top, right, bottom = box
    corners = [
        (right - 6 - size[0], top + 6),
        (left + 6, top + 6),
        (right - 6 - size[0], bottom - 6 - size[1]),
        (left + 6, bottom - 6 - size[1]),
    ]

    def covered(corner: tuple[float, float]) -> int:
        x, y = corner
        return sum(1 for px, py in drawn if x - 4 <= px <= x + size[0] + 4 and y - 4 <= py <= y + size[1] + 4)

    return min(corners, key=covered)


def _x_of(member: MemberResult, axis: str | None, index: int) -> float:
    return float(member.bindings[axis]) if axis is not None else float(index)


def _axes(
    draw: Any,
    at: Callable[[float, float], tuple[float, float]],
    x_ticks: list[float],
    y_ticks: list[float],
    box: tuple[float, float, float, float],
) -> None:
    left, top, right, bottom = box
    draw.rectangle([left, top, right, bottom], outline=(120, 120, 120))
    for x in x_ticks:
        px, _ = at(x, y_ticks[0])
        draw.line([(px, bottom), (px, bottom + 5)], fill=(120, 120, 120))
        draw.text((px - 10, bottom + 8), f"{x:g}", fill=(60, 60, 60), font=font(12))
    for y in y_ticks:
        _, py = at(x_ticks[0], y)
        draw.line([(left, py), (right, py)], fill=(232, 232, 232))
        draw.text((left - 44, py - 7), f"{y:g}", fill=(60, 60, 60), font=font(12))


def _series(draw: Any, pixels: list[tuple[float, float] | None], color: tuple[int, int, int]) -> None:
    run: list[tuple[float, float]] = []
    for pixel in [*pixels, None]:
        if pixel is None:
            if len(run) > 1:
                draw.line(run, fill=color, width=2)
            run = []
            continue
        run.append(pixel)
        draw.ellipse([pixel[0] - 3, pixel[1] - 3, pixel[0] + 3, pixel[1] + 3], fill=color)


def _ticks(low: float, high: float, count: int = 5, whole: bool = False) -> list[float]:
    """Round tick values covering [low, high]: steps of 1, 2 or 5 times a power
    of ten (at least 1 for `whole` values)."""
    if high <= low:
        high = low + 1.0
    raw = max((high - low) / count, 1.0) if whole else (high - low) / count
    power = 10 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    start = math.floor(low / step) * step
    return [start + k * step for k in range(math.ceil((high - start) / step) + 1)]
