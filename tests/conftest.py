"""Shared fixtures. Golden files are refreshed with `FABHAL_UPDATE_GOLDEN=1 pytest`
and reviewed as diffs."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
UPDATE_GOLDEN = os.environ.get("FABHAL_UPDATE_GOLDEN") == "1"


def all_fhl_files() -> list[Path]:
    """Every .fhl file the repository ships (library, gallery, docs examples)."""
    roots = [REPO / "stdlib_parts", REPO / "programs", REPO / "docs"]
    return sorted(p for root in roots for p in root.rglob("*.fhl"))


def assert_golden(actual: str, golden: Path) -> None:
    if UPDATE_GOLDEN or not golden.exists():
        if not UPDATE_GOLDEN:
            pytest.fail(f"missing golden file {golden}; run with FABHAL_UPDATE_GOLDEN=1 to create it")
        golden.write_text(actual)
    assert actual == golden.read_text(), f"output differs from {golden}"


@pytest.fixture
def repo() -> Path:
    return REPO
