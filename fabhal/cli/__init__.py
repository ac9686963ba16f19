"""The `fabhal` command: composes the stages in fabhal.api, renders what they return.

Exit codes: 0 clean, 1 the program has errors (or, for `solve`, cannot be
built), 2 usage, I/O or internal error.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fabhal import __version__
from fabhal.cli.common import (
    EXIT_USAGE,
    ISSUES_URL,
    Parser,
    add_define,
    add_drawing_options,
    add_parallel_options,
    add_solver_options,
    gallery_display,
    positive,
    seconds,
)
from fabhal.cli.epilogs import (
    BENCH_EPILOG,
    CHECK_EPILOG,
    DESIGN_EPILOG,
    GALLERY_EPILOG,
    LSP_EPILOG,
    MAIN_EPILOG,
    PARTS_EPILOG,
    RENDER_EPILOG,
    SOLVE_EPILOG,
    WATCH_EPILOG,
)
from fabhal.cli.families import add_search_command, run_design
from fabhal.cli.live import run_lsp, run_watch
from fabhal.cli.programs import run_bench, run_check, run_gallery, run_parts, run_render, run_solve


def build_parser() -> argparse.ArgumentParser:
    formatter = argparse.RawDescriptionHelpFormatter
    gallery = gallery_display()
    parser = Parser(
        prog="fabhal",
        description="FabHaL: design fixture hacks from everyday objects.",
        epilog=MAIN_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    parser.add_argument("--version", action="version", version=f"fabhal {__version__}")
    parser.add_argument("--debug", action="store_true", help="show Python tracebacks of internal errors")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)

    check = commands.add_parser(
        "check",
        help="validate programs without solving them",
        description="Parse and check .fhl programs; report every problem found, sorted by position.",
        epilog=CHECK_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    check.add_argument("files", nargs="+", type=Path, metavar="FILE", help=".fhl program(s) to check")
    check.add_argument("--json", action="store_true", help="print diagnostics as a JSON array on stdout")
    add_define(check)
    check.set_defaults(run=run_check)

    solve = commands.add_parser(
        "solve",
        help="solve a program: where every part ends up",
        description="Check a program, then solve it: fit the target, settle under gravity, "
        "report where every part ends up and whether it holds.",
        epilog=SOLVE_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    solve.add_argument("file", type=Path, metavar="FILE", help=".fhl program to solve")
    solve.add_argument("--json", action="store_true", help="print the result object as JSON on stdout")
    solve.add_argument(
        "-o", "--output", type=Path, metavar="FILE.json", help="write the JSON result to a file"
    )
    solve.add_argument(
        "--dofs",
        action="store_true",
        help="also list the design's degrees of freedom: each one's range, where it settled (as a builder "
        "would set it) and whether the builder sets it once or gravity settles it",
    )
    add_solver_options(solve)
    solve.add_argument(
        "--render",
        type=Path,
        metavar="OUT",
        help="also draw the result (.png .html .glb .obj .stl, see `render`)",
    )
    add_drawing_options(solve)
    solve.set_defaults(run=run_solve)

    render = commands.add_parser(
        "render",
        help="solve a program and draw it: picture, 3D file or browser viewer",
        description="Solve a program and write the result as a picture (.png), a self-contained "
        "3D viewer page (.html) or a 3D file (.glb, .obj, .stl).",
        epilog=RENDER_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    render.add_argument("file", type=Path, metavar="FILE", help=".fhl program to solve and draw")
    render.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="OUT",
        help="where to write; the suffix picks the format",
    )
    add_drawing_options(render)
    add_solver_options(render)
    render.set_defaults(run=run_render)

    bench = commands.add_parser(
        "bench",
        help="time parsing, checking and solving of the gallery programs",
        description="Benchmark the gallery: per program the parse, check and solve times and "
        "whole `fabhal solve` processes, against the speed targets.",
        epilog=BENCH_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    bench.add_argument(
        "files", nargs="*", type=Path, metavar="FILE", help="programs (default: programs/*.fhl)"
    )
    bench.add_argument(
        "-n", "--runs", type=int, default=5, help="runs per program in one process (default 5)"
    )
    bench.add_argument("-o", "--output", type=Path, metavar="FILE.json", help="where to write the results")
    bench.add_argument("--no-process", action="store_true", help="skip the whole-process timings")
    bench.set_defaults(run=run_bench)

    parts = commands.add_parser(
        "parts",
        help="list the part library, or show one part",
        description="Show the annotated object library (stdlib_parts/*.fhl).",
        epilog=PARTS_EPILOG,
        formatter_class=formatter,
    )
    parts.add_argument("name", nargs="?", metavar="NAME", help="a part to show in full")
    parts.add_argument("--json", action="store_true", help="print JSON instead of tables")
    parts.set_defaults(run=run_parts)

    add_search_command(commands, formatter, gallery)

    watch = commands.add_parser(
        "watch",
        help="solve on every save and show the result live in the browser",
        description="Solve a program again whenever it (or a file it imports) is saved, and show "
        "each result in a live 3D view at http://127.0.0.1:PORT/.",
        epilog=WATCH_EPILOG,
        formatter_class=formatter,
    )
    watch.add_argument("file", type=Path, metavar="FILE", help=".fhl program to watch")
    watch.add_argument("--port", type=int, default=0, help="port of the live view (default: a free one)")
    add_solver_options(watch)
    watch.set_defaults(run=run_watch)

    designer = commands.add_parser(
        "design",
        help="find designs that hang the target, from the parts you own",
        description="Enumerate the designs an inventory allows for a spec (environments and a target), "
        "solve the most promising in parallel and rank them by where the target settles.",
        epilog=DESIGN_EPILOG,
        formatter_class=formatter,
    )
    designer.add_argument("file", type=Path, metavar="SPEC", help=".fhl spec: environments and a target")
    designer.add_argument(
        "--inventory",
        type=Path,
        required=True,
        metavar="FILE.toml",
        help="the parts you own: `PartType = count`",
    )
    designer.add_argument("--max-parts", type=positive, default=4, metavar="N", help="parts per design (4)")
    designer.add_argument(
        "--budget", type=positive, default=60, metavar="N", help="designs solved at most (60)"
    )
    designer.add_argument(
        "--tolerance", type=float, default=10.0, metavar="MM", help="near enough to the target, mm (10)"
    )
    designer.add_argument(
        "--time-limit", type=seconds, metavar="SECONDS", help="stop solving after this long (default: none)"
    )
    designer.add_argument(
        "--top", type=positive, default=5, metavar="K", help="show, emit, render the best K (5)"
    )
    add_parallel_options(designer)
    designer.add_argument("--seed", type=int, default=0, help="seed for the random starts (default 0)")
    designer.add_argument("--json", action="store_true", help="print every design and its result as JSON")
    designer.add_argument("--emit", type=Path, metavar="DIR", help="write the best K as .fhl programs")
    designer.add_argument("--render", type=Path, metavar="DIR", help="draw the best K and a contact sheet")
    designer.set_defaults(run=run_design)

    lsp = commands.add_parser(
        "lsp",
        help="the language server for editors (stdio; needs `pip install 'fabhal[lsp]'`)",
        description="Run FabHaL's language server on stdin/stdout: diagnostics as you type, hover, "
        "completion, go-to-definition and document symbols for .fhl files.",
        epilog=LSP_EPILOG,
        formatter_class=formatter,
    )
    lsp.set_defaults(run=run_lsp)

    gallery_command = commands.add_parser(
        "gallery",
        help="list the example hacks and the reusable sub-assemblies, and where they are",
        description="The gallery installed with FabHaL: example programs to solve or copy, and "
        "sub-assemblies (lib/) that any program can import.",
        epilog=GALLERY_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    gallery_command.add_argument("--json", action="store_true", help="print JSON instead of a table")
    gallery_command.set_defaults(run=run_gallery)
    return parser


class _ReaderMayLeave:
    """stdout that lets its reader stop early (`fabhal solve x | head -2`): once the
    pipe is closed, what is left is dropped instead of raising BrokenPipeError,
    and the command ends with its own exit status."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self._gone = False

    def write(self, text: str) -> int:
        if not self._gone:
            try:
                self._stream.write(text)
            except BrokenPipeError:
                self._reader_left()
        return len(text)

    def flush(self) -> None:
        if not self._gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._reader_left()

    def _reader_left(self) -> None:
        self._gone = True
        # what Python still holds for the closed pipe goes nowhere at exit
        os.dup2(os.open(os.devnull, os.O_WRONLY), self._stream.fileno())

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def main(argv: Sequence[str] | None = None) -> int:
    if not isinstance(sys.stdout, _ReaderMayLeave):
        sys.stdout = _ReaderMayLeave(sys.stdout)  # type: ignore[assignment]
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_USAGE
    try:
        return int(args.run(args))
    except KeyboardInterrupt:
        print("fabhal: interrupted", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # an internal error: say so, never a bare traceback
        if args.debug:
            traceback.print_exc()
        print(
            f"fabhal: internal error: {type(exc).__name__}: {exc}\n"
            f"This is a bug in FabHaL, not in your program. Please report it to {ISSUES_URL} "
            "with the .fhl file and the command you ran (add --debug to see the traceback).",
            file=sys.stderr,
        )
        return EXIT_USAGE
