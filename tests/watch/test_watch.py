"""`fabhal watch` end to end: the command on a temporary program, the live view
in headless Chromium (driven by Playwright), the program edited on disk; the
page must follow each save without a reload.

The program is the mug hanger: three S-hooks from a rod, the mug on the last.
Asking for the mug 200 mm lower than the chain can reach changes its settled
error by about that much (the chain hangs straight down either way: W505),
which is what the page must then show."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import REPO

PROGRAM = REPO / "programs" / "mug_hanger.fhl"
REACHED = "target mug.hook at (0, 0, 50) rot (-35, 0, -90)"
TOO_LOW = "target mug.hook at (0, 0, -150) rot (-35, 0, -90)"


@pytest.fixture
def watched(tmp_path: Path) -> Iterator[tuple[Path, str]]:
    program = tmp_path / "mug.fhl"
    program.write_text(PROGRAM.read_text())
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "s_hook_chain.fhl").write_text(
        (REPO / "programs" / "lib" / "s_hook_chain.fhl").read_text()
    )
    process = subprocess.Popen(
        [sys.executable, "-m", "fabhal", "watch", str(program)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert process.stdout is not None
    first = process.stdout.readline()
    found = re.search(r"live view at (http://127\.0\.0\.1:\d+/)", first)
    assert found, first
    yield program, found.group(1)
    process.terminate()
    process.wait(timeout=10)


def edit(program: Path, old: str, new: str) -> None:
    """Save as editors do: a new file renamed over the old one."""
    text = program.read_text()
    assert old in text
    scratch = program.with_suffix(".tmp")
    scratch.write_text(text.replace(old, new))
    scratch.replace(program)


def test_the_page_follows_each_save_and_keeps_the_last_good_scene_on_errors(
    watched: tuple[Path, str], chromium: str, tmp_path: Path
) -> None:
    sync_api = pytest.importorskip(
        "playwright.sync_api", reason="playwright is installed by the [test] extra"
    )
    program, url = watched
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=chromium, args=["--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader"]
        )
        page = browser.new_page(viewport={"width": 1000, "height": 700})
        page.goto(url)
        page.wait_for_selector("body[data-live-status='solved']", timeout=30_000)
        first = page.inner_text("#live .summary")
        assert first.startswith("solved: target ") and "mm" in first
        generation = int(page.get_attribute("body", "data-generation") or 0)
        page.evaluate("window.notReloaded = true")

        edit(program, REACHED, TOO_LOW)
        page.wait_for_function(f"Number(document.body.dataset.generation) > {generation}", timeout=30_000)
        page.wait_for_selector("body[data-live-status='solved']", timeout=30_000)
        moved = page.inner_text("#live .summary")
        errors = [float(v) for v in re.findall(r"target ([\d.]+) mm", first + moved)]
        assert errors[1] > errors[0] + 150  # asked 200 mm lower than the chain reaches
        assert page.evaluate("window.notReloaded") is True  # updated in place
        assert int(page.get_attribute("body", "data-rendered") or 0) > 1000  # the scene is drawn

        edit(program, "connect mug.hook -- s3.hook2", "connect mug.hook -- s3.hookk2")
        page.wait_for_selector("body[data-live-status='error']", timeout=30_000)
        assert "(showing the last result that solved)" in page.inner_text("#live .summary")
        problem = page.inner_text("#live .problems li")
        assert "mug.fhl:21:21: " in problem and "error[E" in problem and "hookk2" in problem
        assert page.get_attribute("body", "data-status") == "solved"  # the viewer still shows the last good
        assert int(page.get_attribute("body", "data-rendered") or 0) > 1000
        assert page.is_visible("#source")  # the first error's line, marked
        assert "s3.hookk2" in page.inner_text("#source .marked")
        assert page.evaluate("window.notReloaded") is True
        browser.close()


def test_a_newer_save_abandons_the_solve_it_supersedes(tmp_path: Path) -> None:
    """Three saves in quick succession: the session solves the first version it
    starts with and then only the newest; the intermediate one is never
    published (each solve takes about 0.5 s, the saves come 0.05 s apart)."""
    from fabhal.watch.session import LiveSession, SolveSettings

    program = tmp_path / "mug.fhl"
    program.write_text(PROGRAM.read_text())
    published: list[str] = []
    session = LiveSession(program, SolveSettings(), lambda result: published.append(result.summary))
    session.start()
    time.sleep(0.05)
    edit(program, REACHED, TOO_LOW)
    session.changed()
    time.sleep(0.05)
    edit(program, TOO_LOW, REACHED)
    session.changed()
    result = session.wait_for(2, timeout=30)
    session.stop()
    assert result is not None and result.generation == 3 and result.status == "solved"
    assert len(published) == 1  # versions 1 and 2 were abandoned at their next stage


def test_only_saves_of_the_programs_own_files_count(tmp_path: Path) -> None:
    """The folder is watched (editors save by renaming), but a save of a file
    the program does not read is not a change; a rename over the program is."""
    import threading

    from fabhal.watch.files import watch_files

    program, other = tmp_path / "mug.fhl", tmp_path / "notes.fhl"
    program.write_text("# a program\n")
    changes: list[float] = []
    stop = threading.Event()
    watcher = threading.Thread(
        target=watch_files, args=(lambda: frozenset({program.resolve()}), lambda: changes.append(1.0), stop)
    )
    watcher.start()
    try:
        time.sleep(0.5)  # the watcher is listening
        other.write_text("# not read by the program\n")
        time.sleep(0.5)
        assert changes == []
        edit(program, "a program", "the program")
        deadline = time.monotonic() + 5
        while not changes and time.monotonic() < deadline:
            time.sleep(0.05)
        assert changes == [1.0]
    finally:
        stop.set()
        watcher.join(timeout=5)
