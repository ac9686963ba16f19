"""The search log: one JSON line per member as it finishes, after a header that
says which search it belongs to, so an interrupted search resumes where it
stopped and a log of another program or other options is never mixed in."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from pathlib import Path
from typing import IO, Any

from fabhal import __version__
from fabhal.search.members import MemberResult

FORMAT = 1


class LogError(Exception):
    """The log cannot be resumed from (another search's, or not a search log)."""


def fingerprint(sources: Iterable[str], options: dict[str, Any]) -> str:
    """What decides every member's answer: the program's text (imports
    included), the solver options and FabHaL's version."""
    digest = hashlib.sha256()
    for text in sources:
        digest.update(text.encode())
    digest.update(json.dumps(options, sort_keys=True).encode())
    digest.update(__version__.encode())
    return digest.hexdigest()[:16]


def read_log(path: Path, expected: str) -> dict[str, MemberResult]:
    """The members already solved in `path`, by key. A last line cut short by
    the interruption is dropped (that member is solved again)."""
    lines = path.read_text().splitlines()
    if not lines:
        return {}
    try:
        header = json.loads(lines[0])
    except json.JSONDecodeError:
        header = None
    if not isinstance(header, dict) or header.get("fabhal_search") != FORMAT:
        raise LogError(f"{path} is not a `fabhal search` log: name another with --log, or leave out --resume")
    if header.get("fingerprint") != expected:
        raise LogError(
            f"{path} was written for {header.get('program', 'another program')} with other contents or "
            "options (or another FabHaL version): its members would not be this search's; leave out "
            "--resume to start it over, or name another log with --log"
        )
    done: dict[str, MemberResult] = {}
    for line in lines[1:]:
        try:
            member = MemberResult.from_json(json.loads(line))
        except (json.JSONDecodeError, TypeError):
            continue
        done[member.key] = member
    return done


def _ends_a_line(path: Path) -> bool:
    with path.open("rb") as log:
        log.seek(-1, 2)
        return log.read(1) == b"\n"


class LogWriter:
    """Appends members to the log, each line flushed as it is written."""

    def __init__(self, path: Path, program: str, fingerprint: str, resume: bool) -> None:
        fresh = not (resume and path.is_file() and path.stat().st_size > 0)
        cut_short = not fresh and not _ends_a_line(path)
        self._file: IO[str] = path.open("w" if fresh else "a")
        if fresh:
            self._write({"fabhal_search": FORMAT, "program": program, "fingerprint": fingerprint})
        elif cut_short:  # the interrupted line stays alone on its line, and is skipped when read
            self._file.write("\n")

    def add(self, member: MemberResult) -> None:
        self._write(member.to_json())

    def close(self) -> None:
        self._file.close()

    def _write(self, data: dict[str, Any]) -> None:
        self._file.write(json.dumps(data) + "\n")
        self._file.flush()
