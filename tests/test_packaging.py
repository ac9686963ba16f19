"""A plain `pip install .` must carry grammar/, stdlib_parts/ and the gallery
(programs/, with its reusable lib/) inside the wheel, so `fabhal check` works
from outside the checkout, a program anywhere can import the gallery's
sub-assemblies, and the examples `--help` prints run as printed."""

from __future__ import annotations

import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from tests.conftest import REPO


@pytest.mark.slow
def test_non_editable_install_works_outside_the_checkout(tmp_path: Path) -> None:
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    _see_running_packages(python)
    source = tmp_path / "src"  # a copy, so the build leaves no artefacts in the checkout
    shutil.copytree(
        REPO, source, ignore=shutil.ignore_patterns(".git", "*.egg-info", "__pycache__", ".*cache")
    )
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", str(source)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert install.returncode == 0, install.stderr
    shutil.rmtree(source)  # nothing may resolve back to a checkout

    elsewhere = tmp_path / "work"
    elsewhere.mkdir()
    program = elsewhere / "demo.fhl"
    program.write_text((REPO / "programs" / "demo.fhl").read_text())
    where = subprocess.run(
        [str(python), "-c", "import fabhal.resources as r; print(r.grammar_path()); print(r.stdlib_dir())"],
        cwd=elsewhere,
        capture_output=True,
        text=True,
    )
    assert str(env_dir) in where.stdout, where.stdout + where.stderr
    run = subprocess.run(
        [str(env_dir / "bin" / "fabhal"), "check", "demo.fhl"], cwd=elsewhere, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "demo.fhl: ok" in run.stdout

    fabhal = str(env_dir / "bin" / "fabhal")
    own = elsewhere / "own.fhl"  # not in the gallery: imports its sub-assembly from anywhere
    own.write_text(
        'import "lib/s_hook_chain.fhl"\n'
        "environment rod = Rod(length: 400, radius: 3) at (0, 0, 300) rot (90, 0, 90)\n"
        "chain = SHookChain(n: 2)\nmug = Mug()\n"
        "connect chain.top -- rod\nconnect mug.hook -- chain.bottom\n"
        "target mug.hook at (0, 0, 200) rot (0, 0, 0)\n"
    )
    run = subprocess.run([fabhal, "check", "own.fhl"], cwd=elsewhere, capture_output=True, text=True)
    assert run.returncode == 0 and "own.fhl: ok" in run.stdout, run.stdout + run.stderr

    help_text = subprocess.run([fabhal, "--help"], cwd=elsewhere, capture_output=True, text=True).stdout
    example = next(
        line.split()[2] for line in help_text.splitlines() if line.strip().startswith("fabhal check ")
    )
    assert example.startswith(str(env_dir)) and example.endswith("mug_hanger.fhl"), help_text
    run = subprocess.run([fabhal, "check", example], cwd=elsewhere, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def _see_running_packages(python: Path) -> None:
    """Let the new venv import what the interpreter running the tests has installed
    (hatchling, lark, numpy, ...), so nothing is downloaded. `system_site_packages`
    would not do: it shows the *base* interpreter's packages, which inside a user's
    venv are not the ones `pip install -e '.[test]'` installed. Only site-packages
    directories are listed, never the checkout an editable install points at."""
    running = [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages") and Path(p).is_dir()]
    target = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    (Path(target) / "_outer_site_packages.pth").write_text("\n".join(running) + "\n")
