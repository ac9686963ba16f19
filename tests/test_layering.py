"""Data flows one way: a stage never imports a later one (docs/ARCHITECTURE.md)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import REPO

# earlier stages first; a module may import its own stage or earlier ones
ORDER = [
    "__init__",
    "source",
    "diagnostics",
    "resources",
    "kinematics",
    "optimize",
    "primitives",
    "syntax",
    "load",
    "evaluate",
    "library",
    "meshes",
    "elaborate",
    "inventory",
    "model",
    "check",
    "solve",
    "report",
    "render",
    "api",
    "search",
    "design",
    "watch",
    "lsp",
    "bench",
    "cli",
]


def stage_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def fabhal_imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("fabhal"):
            names = (
                [f"{node.module}.{a.name}" for a in node.names] if node.module == "fabhal" else [node.module]
            )
            found.update(names)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("fabhal"))
    return found


MODULES = sorted((REPO / "fabhal").rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=[str(p.relative_to(REPO)) for p in MODULES])
def test_no_stage_imports_a_later_one(path: Path) -> None:
    relative = path.relative_to(REPO).with_suffix("")
    own = stage_of(".".join(relative.parts))
    if own not in ORDER:
        pytest.skip(f"{own} is not a stage")
    for imported in fabhal_imports(path):
        other = stage_of(imported)
        if other in ORDER:
            assert ORDER.index(other) <= ORDER.index(own), f"{relative} imports later stage {imported}"
