"""The code stays ruff clean, formatted, and type-checked. mypy also enforces that
every diagnostic carries a fix: `error()` and `warning()` require their `help`."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import REPO


def run(*command: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *command], cwd=REPO, capture_output=True, text=True, timeout=300
    )


def test_ruff_lint_and_format() -> None:
    lint = run("ruff", "check", ".")
    assert lint.returncode == 0, lint.stdout + lint.stderr
    formatted = run("ruff", "format", "--check", ".")
    assert formatted.returncode == 0, formatted.stdout + formatted.stderr


def test_mypy() -> None:
    checked = run("mypy")
    assert checked.returncode == 0, checked.stdout + checked.stderr
