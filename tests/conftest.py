"""Shared fixtures. Golden files are refreshed with `FABHAL_UPDATE_GOLDEN=1 pytest`
and reviewed as diffs."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from functools import cache
from pathlib import Path
from typing import Any

import pytest

import fabhal  # noqa: F401  (first: pins the numeric libraries to one thread before numpy loads)

REPO = Path(__file__).resolve().parent.parent


def pytest_configure(config: pytest.Config) -> None:
    """Every run starts as on a new machine: FabHaL's per-user cache (contact
    grids, points, mesh measures, parser tables) in an empty directory of its
    own, removed at the end, so what only a warm cache hid fails here (grids
    once needed networkx, which no project file installed, and only cached
    grids let the tests pass). FABHAL_TEST_CACHE=keep uses the user's cache
    instead (faster, for a quick local run)."""
    if os.environ.get("FABHAL_TEST_CACHE") == "keep":
        return
    config._fabhal_cache = tempfile.mkdtemp(prefix="fabhal-test-cache-")  # type: ignore[attr-defined]
    os.environ["XDG_CACHE_HOME"] = config._fabhal_cache  # type: ignore[attr-defined]


def pytest_unconfigure(config: pytest.Config) -> None:
    cache = getattr(config, "_fabhal_cache", None)
    if cache is not None:
        shutil.rmtree(cache, ignore_errors=True)


DATA = REPO / "tests" / "data"  # reference data (MIT, see tests/data/LICENSE)
UPDATE_GOLDEN = os.environ.get("FABHAL_UPDATE_GOLDEN") == "1"


def all_fhl_files() -> list[Path]:
    """Every .fhl file the repository ships (library, gallery, docs examples)."""
    roots = [REPO / "stdlib_parts", REPO / "programs", REPO / "docs"]
    return sorted(p for root in roots for p in root.rglob("*.fhl"))


def gallery_programs(expected_to_fail: dict[str, str], strict: bool) -> list[Any]:
    """The gallery's program names as parameters, those in `expected_to_fail`
    marked xfail with their reason (`strict`: one that passes fails the run)."""
    names = sorted(p.stem for p in (REPO / "programs").glob("*.fhl"))
    return [
        pytest.param(name, marks=pytest.mark.xfail(reason=expected_to_fail[name], strict=strict))
        if name in expected_to_fail
        else name
        for name in names
    ]


def written_in_reverse(text: str, declarations: bool = False) -> str:
    """A program's text with its connections (and, with `declarations`, its part
    declarations) written in reverse order, each kind in its own lines' places."""
    lines = text.splitlines()
    kinds = [lambda line: line.startswith("connect ")]
    if declarations:
        kinds.append(lambda line: re.match(r"\w+ = \w+\(", line) is not None)
    out = list(lines)
    for kind in kinds:
        rows = [i for i, line in enumerate(lines) if kind(line)]
        for i, j in zip(rows, reversed(rows), strict=True):
            out[i] = lines[j]
    return "\n".join(out) + "\n"


def assert_golden(actual: str, golden: Path) -> None:
    if UPDATE_GOLDEN or not golden.exists():
        if not UPDATE_GOLDEN:
            pytest.fail(f"missing golden file {golden}; run with FABHAL_UPDATE_GOLDEN=1 to create it")
        golden.write_text(actual)
    assert actual == golden.read_text(), f"output differs from {golden}"


@cache
def spec_json(name: str) -> Any:
    """A data file of the FabHacks reference implementation, kept in tests/data."""
    return json.loads((DATA / name).read_text())


@pytest.fixture
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's Chromium, installed here if missing (CI machines start without it)."""
    found = shutil.which("chromium")
    if found:
        return found
    apt = shutil.which("apt-get")
    if apt is None or os.geteuid() != 0:
        pytest.skip("Chromium is not installed and cannot be: needs apt-get as root")
    for command in (
        [apt, "install", "-y", "-q", "chromium"],
        [apt, "update", "-q"],
        [apt, "install", "-y", "-q", "chromium"],
    ):
        subprocess.run(command, capture_output=True, timeout=900, check=False)
        if shutil.which("chromium"):
            return str(shutil.which("chromium"))
    pytest.skip("Chromium could not be installed from the system packages (apt-get install chromium failed)")
