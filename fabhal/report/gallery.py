"""The installed gallery (`fabhal gallery`): each hack and reusable sub-assembly
with the first paragraph of its header and where the file is."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rich.console import RenderableType


@dataclass(frozen=True)
class GalleryEntry:
    name: str  # how to refer to it: `mug_hanger.fhl`, or `lib/s_hook_chain.fhl` for an import
    summary: str  # the header's first paragraph, in one line
    path: Path


def header_summary(text: str) -> str:
    """The first paragraph of a file's leading `#` comment, joined into one line."""
    lines: list[str] = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        words = line.lstrip("#").strip()
        if not words:
            if lines:
                break
            continue
        lines.append(words)
    return " ".join(lines)


def entries(gallery: Path) -> list[GalleryEntry]:
    """The gallery's programs, then its sub-assemblies, each sorted by name."""
    files = sorted(gallery.glob("*.fhl")) + sorted((gallery / "lib").glob("*.fhl"))
    return [
        GalleryEntry(
            str(path.relative_to(gallery)),
            header_summary(path.read_text(encoding="utf-8-sig")),
            path,
        )
        for path in files
    ]


def to_json(items: list[GalleryEntry]) -> list[dict[str, Any]]:
    return [
        {
            "name": e.name,
            "kind": "assembly" if "/" in e.name else "program",
            "summary": e.summary,
            "path": str(e.path),
        }
        for e in items
    ]


def table(items: list[GalleryEntry], gallery: Path) -> RenderableType:
    from rich.table import Table

    result = Table(title=f"The gallery, installed in {gallery}", title_justify="left")
    result.add_column("file", no_wrap=True)
    result.add_column("what it is")
    for entry in items:
        name = f'import "{entry.name}"' if "/" in entry.name else entry.name
        result.add_row(name, entry.summary)
    return result
