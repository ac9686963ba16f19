"""What every command shares: the argument parser class and its option groups,
exit codes, and printing diagnostics and tables."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from fabhal.diagnostics import Diagnostic, Severity, render_all
from fabhal.source import SourceFile

EXIT_OK, EXIT_DIAGNOSTICS, EXIT_USAGE = 0, 1, 2
ISSUES_URL = "the FabHaL issue tracker"


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"fabhal: error: {message}\n(run `{self.prog} --help` for examples)\n")


def binding(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name.strip(), value.strip()


def add_define(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "-D",
        "--define",
        action="append",
        type=binding,
        default=[],
        metavar="NAME=VALUE",
        help="bind a `param` of the program (repeatable), e.g. -D n=3 -D Ring=RingM",
    )


def add_solver_options(command: argparse.ArgumentParser) -> None:
    command.add_argument("--seed", type=int, default=0, help="seed for the random starts (default 0)")
    command.add_argument(
        "--time-limit",
        type=seconds,
        metavar="SECONDS",
        help="stop with the best result so far after this many seconds (default: no limit)",
    )
    command.add_argument("--no-gravity", action="store_true", help="skip step 2 (settling under gravity)")
    command.add_argument(
        "--two-step",
        action="store_true",
        help="the paper's two steps only: keep where step 1 put the parts that stay put (a clip's grip, "
        "a `fixed` connection, a part friction holds on a rod) instead of aiming them (to compare)",
    )
    add_define(command)


def seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(
            f"expected a positive number of seconds, e.g. --time-limit 5; got {text!r} "
            "(leave the option out for no limit)"
        )
    return value


def views(text: str) -> tuple[str, ...]:
    from fabhal.render.picture import VIEWS

    views = tuple(v.strip() for v in text.split(",") if v.strip())
    unknown = [v for v in views if v not in VIEWS]
    if not views or unknown:
        raise argparse.ArgumentTypeError(
            f"views are a comma-separated list of {', '.join(VIEWS)}; got {text!r}"
        )
    return views


def size(text: str) -> tuple[int, int]:
    width, sep, height = text.lower().partition("x")
    if (
        not sep
        or not width.isdigit()
        or not height.isdigit()
        or not (100 <= int(width) <= 8000 and 100 <= int(height) <= 8000)
    ):
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT in pixels (100 to 8000), e.g. 1200x900; got {text!r}"
        )
    return int(width), int(height)


def add_drawing_options(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--show",
        choices=["requested"],
        help="`requested`: also draw the target at its requested frame (see-through) "
        "and mark a connection that comes apart",
    )
    command.add_argument(
        "--primitives", action="store_true", help="also draw every part's connector primitives"
    )
    command.add_argument(
        "--views",
        type=views,
        default=("iso",),
        metavar="LIST",
        help="PNG views, from iso,front,side,top (default iso)",
    )
    command.add_argument(
        "--size",
        type=size,
        default=(1200, 900),
        metavar="WxH",
        help="PNG pixels per view (default 1200x900)",
    )


def gallery_display() -> str:
    """Where the gallery is, as the user would type it: relative inside a
    checkout, the installed path otherwise (so `--help`'s examples run as printed)."""
    from fabhal.resources import display_name, gallery_dir

    return display_name(gallery_dir())


def default_jobs() -> int:
    from fabhal.search.executors import default_jobs as cores

    return cores()


def positive(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number of at least 1; got {text!r}")
    return int(text)


def add_parallel_options(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "-j", "--jobs", type=positive, default=default_jobs(), help="worker processes (default: all cores)"
    )
    command.add_argument("--executor", metavar="dask://HOST:PORT", help="solve on a Dask cluster instead")


def print_diagnostics(diagnostics: Sequence[Diagnostic], sources: dict[str, SourceFile]) -> None:
    if diagnostics:
        text = render_all(diagnostics, sources)
        if sys.stderr.isatty() and "NO_COLOR" not in os.environ:  # https://no-color.org
            from fabhal.syntax.lexer import colour_source_lines

            text = colour_source_lines(text)
        print(text, file=sys.stderr)


def prepare_outputs(files: Sequence[Path | None], directories: Sequence[Path | None] = ()) -> int | None:
    """Make the folders the outputs go to before the work starts (a search of minutes
    must not end in "No such file or directory"); EXIT_USAGE, said, if one cannot be."""
    wanted = [f.parent for f in files if f is not None] + [d for d in directories if d is not None]
    for folder in wanted:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            print(f"fabhal: cannot make the folder {folder}: {exc.strerror}", file=sys.stderr)
            return EXIT_USAGE
    return None


def terminal() -> Any:
    from rich.console import Console

    return Console(width=None if sys.stdout.isatty() else 140)


def warning_count(diagnostics: Sequence[Diagnostic]) -> str:
    counts = []
    for severity in (Severity.WARNING, Severity.NOTE):
        n = sum(1 for d in diagnostics if d.severity is severity)
        if n:
            counts.append(f"{n} {severity.value}{'s' if n != 1 else ''}")
    return f" ({', '.join(counts)})" if counts else ""
