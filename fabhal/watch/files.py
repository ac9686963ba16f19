"""Saves of the program and what it imports. Editors save by writing a new file
and renaming it over the old one, so the directories are watched, not the
files, and a change counts when its path is one of the program's files."""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

DEBOUNCE_MS = 30  # an editor's burst of writes for one save is one change
STEP_MS = 10  # how long to wait for more of that burst before calling it one
POLL_MS = 200  # how often the watcher looks up from waiting, to see new imports or a stop


def watch_files(
    dependencies: Callable[[], frozenset[Path]], changed: Callable[[], None], stop: threading.Event
) -> None:
    """Call `changed` after each save of a file in `dependencies()` (asked again
    after every change: a new import is watched from then on) until `stop`."""
    from watchfiles import watch

    while not stop.is_set():
        files = dependencies()
        directories = sorted({str(f.parent) for f in files if f.parent.is_dir()})
        for batch in watch(
            *directories,
            stop_event=stop,
            debounce=DEBOUNCE_MS,
            step=STEP_MS,
            rust_timeout=POLL_MS,
            yield_on_timeout=True,
        ):
            if any(Path(path).resolve() in files for _, path in batch):
                changed()
            if dependencies() != files:
                break  # watch the new set of directories
