"""Where the grammar, the part library, the meshes and the gallery live.

In a checkout they sit beside the package (`grammar/`, `stdlib_parts/`,
`programs/`); a wheel carries them inside the package as `fabhal/grammar`,
`fabhal/stdlib_parts` and `fabhal/programs` (see
`[tool.hatch.build.targets.wheel.force-include]` in pyproject.toml).
"""

from __future__ import annotations

import os
from functools import cache
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def _data_dir(name: str) -> Path:
    installed = _PACKAGE_DIR / name
    if installed.is_dir():
        return installed
    return _PACKAGE_DIR.parent / name


@cache
def grammar_path() -> Path:
    return _data_dir("grammar") / "fabhal.lark"


@cache
def stdlib_dir() -> Path:
    return _data_dir("stdlib_parts")


@cache
def gallery_dir() -> Path:
    """The gallery of hacks (`programs/`) and its reusable sub-assemblies (`programs/lib/`)."""
    return _data_dir("programs")


def display_name(path: Path) -> str:
    """The path as the user would write it: relative to the working directory when
    inside it; library files as `stdlib_parts/...` wherever the library is installed."""
    library = stdlib_dir().resolve()
    if path.resolve().is_relative_to(library):
        return str(Path("stdlib_parts") / path.resolve().relative_to(library))
    try:
        relative = os.path.relpath(path)
    except ValueError:  # another drive on Windows
        return str(path)
    return str(path) if relative.startswith("..") else relative


def cache_dir() -> Path | None:
    """A per-user cache directory (never the installed package), or None if unwritable."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    directory = Path(base) / "fabhal"
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return directory if os.access(directory, os.W_OK) else None
