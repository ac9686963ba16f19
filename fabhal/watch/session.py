"""The live design loop's state: the program solved again on every save, each
result published as a payload the page draws, the last good scene kept when a
new version has errors, and a solve still running when a newer save arrives
abandoned at its next stage (it would only be drawn over)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from fabhal import api
from fabhal.diagnostics import Diagnostic, render_text, to_json
from fabhal.load import InputError
from fabhal.render.scene import RenderOptions, build_scene
from fabhal.render.viewer import scene_payload
from fabhal.report.solution import to_dict
from fabhal.resources import display_name
from fabhal.source import SourceFile

if TYPE_CHECKING:
    from fabhal.solve import Solution


class Superseded(Exception):
    """A newer save arrived while this solve was running."""


@dataclass(frozen=True)
class LiveResult:
    """One solve of one version of the program, as the page and the terminal show it."""

    generation: int
    status: str  # solved, falls_apart, ..., error (the program has errors or cannot be read)
    summary: str  # one line: the status and the target error, or the first problem
    problems: tuple[dict[str, Any], ...]  # errors and warnings: code, message, file, line, column, text
    sources: dict[str, str]  # the text of each file a problem points at, for the source view
    scene: dict[str, Any] | None  # the viewer's payload; None: keep showing the last good one
    elapsed_s: float
    dependencies: frozenset[Path] = field(default=frozenset())  # the files read (program and imports)

    def to_json(self) -> dict[str, Any]:
        return {
            "generation": self.generation,
            "status": self.status,
            "summary": self.summary,
            "problems": list(self.problems),
            "sources": self.sources,
            "scene": self.scene,
            "elapsed_s": self.elapsed_s,
        }


@dataclass(frozen=True)
class SolveSettings:
    bindings: Mapping[str, str] = field(default_factory=dict)
    seed: int = 0
    time_limit: float | None = None
    two_step: bool = False


class LiveSession:
    """Solves `path` in a background thread whenever `changed()` is called, and
    keeps the latest result and the last one with a scene. `wait_for(n)`
    blocks until a result newer than generation n is there (the server's
    event stream)."""

    def __init__(
        self, path: Path, settings: SolveSettings, on_result: Callable[[LiveResult], None] | None = None
    ) -> None:
        self.path = path
        self.settings = settings
        self.on_result = on_result
        self._condition = threading.Condition()
        self._requested = 0  # the newest version saved
        self._latest: LiveResult | None = None
        self._last_scene: dict[str, Any] | None = None
        self._stopped = False
        self._thread = threading.Thread(target=self._solve_forever, name="fabhal-solve", daemon=True)

    def start(self) -> None:
        self._thread.start()
        self.changed()

    def stop(self) -> None:
        with self._condition:
            self._stopped = True
            self._condition.notify_all()

    def changed(self) -> None:
        """A file the program depends on was saved: solve the new version."""
        with self._condition:
            self._requested += 1
            self._condition.notify_all()

    @property
    def dependencies(self) -> frozenset[Path]:
        latest = self._latest
        found = latest.dependencies if latest is not None else frozenset()
        return found | {self.path.resolve()}

    def latest(self) -> tuple[LiveResult | None, dict[str, Any] | None]:
        """The newest result and the last scene drawn (from it or an earlier one)."""
        with self._condition:
            return self._latest, self._last_scene

    def wait_for(self, newer_than: int, timeout: float) -> LiveResult | None:
        """The latest result once its generation passes `newer_than` (None at the timeout)."""
        with self._condition:
            self._condition.wait_for(
                lambda: self._stopped or (self._latest is not None and self._latest.generation > newer_than),
                timeout,
            )
            latest = self._latest
        return latest if latest is not None and latest.generation > newer_than else None

    def _solve_forever(self) -> None:
        done = 0
        while True:
            with self._condition:
                self._condition.wait_for(partial(self._wanted, done))
                if self._stopped:
                    return
                generation = self._requested
            try:
                result = self._solve(generation)
            except Superseded:
                continue  # the loop takes the newer version
            done = generation
            with self._condition:
                self._latest = result
                if result.scene is not None:
                    self._last_scene = result.scene
                self._condition.notify_all()
            if self.on_result is not None:
                self.on_result(result)

    def _wanted(self, done: int) -> bool:
        return self._stopped or self._requested > done

    def _solve(self, generation: int) -> LiveResult:
        def still_wanted(_: str) -> None:
            if self._requested != generation or self._stopped:
                raise Superseded

        started = time.perf_counter()
        settings = self.settings
        try:
            result = api.solve(
                self.path,
                settings.bindings,
                settings.seed,
                settings.time_limit,
                progress=still_wanted,
                two_step=settings.two_step,
            )
        except InputError as exc:
            problems = _problems(exc.diagnostics, {})
            first = problems[0]["text"].splitlines()[0] if problems else "cannot read the program"
            return LiveResult(generation, "error", first, problems, {}, None, time.perf_counter() - started)
        still_wanted("")
        elapsed = time.perf_counter() - started
        sources = result.check.sources
        problems = _problems(result.diagnostics, sources)
        dependencies = frozenset(p.resolve() for p in result.check.program.paths.values())
        shown = {p["file"]: sources[p["file"]].text for p in problems if p["file"] in sources}
        scene = None
        if result.solution is not None:
            name = display_name(self.path.resolve())
            summary = to_dict(result, name)
            solution = cast("Solution", result.solution)
            scene = scene_payload(build_scene(solution, self.path.stem, RenderOptions()), summary)
        return LiveResult(
            generation,
            result.status,
            _summary(result, problems),
            problems,
            shown,
            scene,
            elapsed,
            dependencies,
        )


def _problems(
    diagnostics: tuple[Diagnostic, ...], sources: Mapping[str, SourceFile]
) -> tuple[dict[str, Any], ...]:
    """The errors and warnings as `fabhal check --json` gives them, each with its text as printed."""
    shown = [d for d in diagnostics if d.severity.value in ("error", "warning")]
    return tuple({**to_json(d), "text": render_text(d, sources)} for d in shown)


def _summary(result: api.SolveResult, problems: tuple[dict[str, Any], ...]) -> str:
    status = result.status.replace("_", " ")
    if result.solution is not None:
        position, rotation = cast("Solution", result.solution).target_errors()
        return f"{status}: target {position:.1f} mm, {rotation:.1f} deg from the request"
    errors = [p for p in problems if p["severity"] == "error"]
    if errors:
        first = errors[0]
        where = f"{first['file']}:{first['line']}:{first['column']}: " if first["file"] else ""
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        return f"{status}: {where}{first['message']}{more}"
    return status
