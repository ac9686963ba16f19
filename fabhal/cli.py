"""The `fabhal` command: composes the stages in fabhal.api, renders what they return.

Exit codes: 0 clean, 1 the program has errors (or, for `solve`, cannot be
built), 2 usage, I/O or internal error.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from fabhal import __version__
from fabhal.diagnostics import Diagnostic, Severity, render_all, to_json
from fabhal.source import SourceFile

EXIT_OK, EXIT_DIAGNOSTICS, EXIT_USAGE = 0, 1, 2
ISSUES_URL = "the FabHaL issue tracker"

MAIN_EPILOG = """\
examples:
  fabhal solve {gallery}/mug_hanger.fhl       where every part ends up, hanging at rest
  fabhal solve --json -o out.json prog.fhl   the full result as JSON
  fabhal render {gallery}/mug_hanger.fhl -o mug.png   draw it (.png .html .glb .obj .stl)
  fabhal check {gallery}/mug_hanger.fhl       validate a program, report every problem
  fabhal check --json {gallery}/*.fhl         the same as a JSON array, for tools
  fabhal parts                               the part library, one line per part
  fabhal parts DoubleHook                    one part: primitives, DoFs, mass
  fabhal gallery                             the example hacks and reusable sub-assemblies
  fabhal search {gallery}/clip_light_family.fhl   every member of a family, solved and ranked
  fabhal watch my_hack.fhl                   solve on every save; a live view in the browser
  fabhal design {gallery}/specs/mug_under_rod.fhl --inventory {gallery}/specs/s_hooks.toml
                                             designs from the parts you own
  fabhal lsp                                 the language server, for your editor
  fabhal check --help                        more about one command

A program (.fhl) says what the hack hangs from (environment), what it holds
(target) and which connector of which part touches which (connect); the
solver works out where everything ends up. See docs/language.md.
The gallery programs above are installed with FabHaL in {gallery}/;
a program anywhere can `import "lib/s_hook_chain.fhl"` and the other
sub-assemblies that `fabhal gallery` lists.
"""

CHECK_EPILOG = """\
examples:
  fabhal check {gallery}/mug_hanger.fhl
  fabhal check {gallery}/*.fhl                check several files at once
  fabhal check --json my_hack.fhl | jq .     machine-readable diagnostics
  fabhal check -D n=3 -D Ring=RingM family.fhl   bind the program's `param`s

exit status: 0 no errors (warnings allowed), 1 errors found, 2 a file could
not be read (or an internal error).
Each diagnostic reads `file:line:col: error[CODE]: message` and ends with a
`help:` line; docs/errors.md explains every CODE with an example and a fix.
"""


PARTS_EPILOG = """\
examples:
  fabhal parts                      every part: its primitives and what it is
  fabhal parts DoubleHook           primitives with shape parameters, frames and
                                    degrees of freedom; mass, centre of mass, size
  fabhal parts ParamTurnbuckle --json

A part connects through its primitives: `connect s1.hook2 -- rod` uses the
primitive `hook2` of the part `s1`. Tags: UNBOUNDED (turns freely),
BOUNDED_AND_CLAMPED (stops at its ends), BOUNDED_AND_OPEN (past an end the
connection comes apart).
"""


SOLVE_EPILOG = """\
examples:
  fabhal solve {gallery}/mug_hanger.fhl
  fabhal solve --json {gallery}/bird_feeder.fhl      the result object on stdout
  fabhal solve -o result.json {gallery}/demo.fhl     ... or in a file
  fabhal solve --no-gravity my_hack.fhl             only step 1: closest to the target
  fabhal solve --two-step {gallery}/demo.fhl        the paper's two steps, without aiming
  fabhal solve --dofs {gallery}/demo.fhl            every degree of freedom: range, where it settled
  fabhal solve -D n=3 --seed 7 family.fhl           bind a param; another random start
  fabhal solve {gallery}/mug_hanger.fhl --render mug.png   ... and draw it (see `render`)

Step 1 moves the parts (through the connections' degrees of freedom) to bring
the target closest to its requested frame; step 2 lets the assembly settle
under gravity from there (clips and `fixed` connections hold; a part slides
along a rod, or over the floor it stands on, only where gravity beats
friction). Then the settings that stay put (where a clip grips a bar, where
a part sits on a rod that friction holds) are aimed: chosen again so that the
settled target hangs nearest the request (note N506 lists them; --two-step
keeps step 1's). If a connection would slide off an open end, or an object fall
over on its floor, from every start tried, the status is `falls_apart` and
the message names the connection; a result that
is not verified at rest (E503) has the status `not_at_rest`.

--time-limit bounds the whole command (checking included): at the limit the
best result so far is reported, with warning W502; if the loops of the design
are not even closed by then, the status is `out_of_time`. It does not bound
measuring a part's shape for contact (up to 10 s, once per machine, said on
the progress line as it happens).

exit status: 0 solved, 1 falls apart / not at rest / infeasible / out of time / errors in
the program, 2 a file could not be read (or an internal error).
"""


RENDER_EPILOG = """\
examples:
  fabhal render {gallery}/mug_hanger.fhl -o mug.png          a picture (no display needed)
  fabhal render {gallery}/mug_hanger.fhl -o mug.png --views iso,front,side
  fabhal render {gallery}/bird_feeder.fhl -o feeder.html     open in a browser: orbit, zoom, hover
  fabhal render {gallery}/demo.fhl -o demo.glb --primitives  3D file for Blender, a CAD tool, ...
  fabhal render my_hack.fhl -o before.png --show requested  ghost of the target where you asked for it
  fabhal solve {gallery}/mug_hanger.fhl --render mug.png     solve, report and render in one go

The suffix of OUT picks the format: .png (three-quarter view, optionally front,
side and top views; parts labelled; the requested target frame as long axes,
the achieved one as short axes), .html (one self-contained page, works
offline), .glb / .obj / .stl (one node per part at its solved frame;
environments grey, the target orange). `--show requested` adds a see-through
copy of the target at its requested frame and, when the design falls apart,
a red ball on the connection that comes apart.

exit status: 0 solved and written, 1 the design falls apart or cannot be
solved (a falling design is still drawn), 2 a file could not be read or written.
"""


BENCH_EPILOG = """\
examples:
  fabhal bench                          every program in {gallery}/, 5 runs each
  fabhal bench -n 1 --no-process        a quick look: one run, no separate processes
  fabhal bench {gallery}/mug_hanger.fhl  one program
  python bench/run.py                   the same from a checkout

Per program: parse, check and solve times (median over the runs in one
process, round robin over the programs; the first includes importing the
solver), the wall time of whole `fabhal solve` processes (median of 3 with
Python's bytecode cache filled, as from a second run on; and one cold,
compiling fabhal first), and whether the targets are met: a process under 1 s,
the solve step under 200 ms (500 ms for programs with loops). The four
clip-light programs also run back to back as one row. Writes bench/results.json
when run from a checkout (or -o FILE). See bench/README.md.
"""


SEARCH_EPILOG = """\
examples:
  fabhal search {gallery}/clip_light_family.fhl        all 336 members, on every core
  fabhal search {gallery}/clip_light_family.fhl -D ring=RingS -D n=4   hold params: one row of it
  fabhal search family.fhl --sample 40 --seed 3        a random 40 of the members
  fabhal search family.fhl --inventory mine.toml       only what you own (`DoubleHook = 4` lines)
  fabhal search family.fhl --emit best/ --render best/ --plot errors.png
  fabhal search family.fhl --resume                    go on after an interruption
  fabhal search family.fhl --smooth                    neighbours share their settings: no jumps
  fabhal search family.fhl --executor dask://10.0.0.5:8786   on a Dask cluster

A family is every combination of the values of the program's `param`s
(`param n in 1 .. 4`, `param e in linspace(0, 45.7, 21)`, `param ring in
[RingS, RingM]`). Each member is checked (members the check or the inventory
rejects are counted by reason, with one example each), the rest are solved in
parallel and ranked: those that hang at rest by where the target settles
(position error, then rotation), then by number of parts. With a param whose
values are part types, the best member for each of them is reported too.

Every result is appended to the log (--log, default NAME.search.jsonl in the
working directory) as it finishes; after Ctrl-C, `--resume` solves only what
is missing. --emit writes the best members as programs with their params
bound (`fabhal solve` gives the same answer); --render draws them and a contact
sheet of them side by side; --plot draws the target error against the params.

Each member is solved on its own, so where the solver's choices (where a clip
grips a bar, where a hook sits on a rod) land in another valley, neighbouring
members can hang far apart. --smooth also solves each member from the solved
configuration of the member beside it (the previous and the next value of the
last param) and keeps whichever hangs nearer: a builder could reuse those
settings. Such a member's emitted program says so and lists the settings to
build; `fabhal solve` on it alone starts afresh and may settle elsewhere.

Dask: `pip install 'fabhal[dask]'` where you run this and on the workers,
start `dask scheduler` and `dask worker HOST:8786` (FabHaL must be importable
by every worker), then pass --executor dask://HOST:8786.

exit status: 0 at least one member hangs at rest, 1 none does (or the
program has errors), 2 a file could not be read or written (or an internal error).
"""


WATCH_EPILOG = """\
examples:
  fabhal watch my_hack.fhl                 solve on every save; open the address it prints
  fabhal watch my_hack.fhl --port 8765     a fixed port
  fabhal watch family.fhl -D n=3           one member of a family

Edit the program in any editor: each save of it (or of a file it imports)
checks and solves it again, and the page shows the new result in place
(the camera stays where you left it), with the status and the target error.
When a save has errors, the page keeps showing the last result that solved,
with the errors over it: click one to see its line. A solve still running
when a newer save arrives is abandoned. The terminal prints one line per
solve. The server listens on 127.0.0.1 only; Ctrl-C stops it.

exit status: 0 stopped with Ctrl-C, 2 the program could not be read at the
start, or the port is taken.
"""


DESIGN_EPILOG = """\
examples:
  fabhal design spec.fhl --inventory mine.toml                 the best designs from what you own
  fabhal design spec.fhl --inventory mine.toml --emit designs/ --render designs/
  fabhal design spec.fhl --inventory mine.toml --max-parts 3 --budget 20 --time-limit 30

The spec is a program with the environment(s) and the target (the object
to hang, with `target ... at ...`) and no connections; the inventory is a
TOML file, one `PartType = count` line per part you own (the format of
`fabhal search --inventory`). FabHaL grows every design those parts allow:
chains that hang the target from one support, and two-point hangs (a part
with three or more connectors, e.g. a hanger, hung from two supports by two
chains). Each connection is tried against the checker's rules as the design
grows (E401, E402, E404), a two-point hang whose chains cannot span its
supports is dropped (E420), and so is a chain too short to reach. The most
promising (--budget, by where chains hanging straight down would leave the
target) are solved in parallel and ranked by settled target error, then by
number of parts. --emit writes each as a program (`fabhal solve` reproduces
it exactly); --render draws them and a contact sheet.

exit status: 0 a design settles within --tolerance of the target, 1 none
does (the closest is reported), 2 a file could not be read.
"""


LSP_EPILOG = """\
Point your editor's LSP client at the command `fabhal lsp` for files ending
in .fhl. It reports `fabhal check`'s diagnostics as you type (the same codes,
spans and help), shows a part type's primitives, DoFs and mass on hover (and
a primitive's, on `s1.hook2`), completes part types, keywords and, after
`name.`, that part's primitives, jumps to the definition of a part type, an
assembly, a name or an imported file, and lists the program's symbols.

Neovim:   vim.lsp.start({ name = "fabhal", cmd = { "fabhal", "lsp" } })
Helix:    [language-server.fabhal] command = "fabhal", args = ["lsp"]
VS Code:  editors/vscode/ highlights .fhl; any generic LSP client extension
          can run `fabhal lsp`.
"""


GALLERY_EPILOG = """\
examples:
  fabhal gallery                               every program and sub-assembly, with what it is
  fabhal solve {gallery}/mug_hanger.fhl          solve one of them where it is installed
  cp {gallery}/mug_hanger.fhl my_hack.fhl        ... or copy it and make it yours

In your own program, `import "lib/s_hook_chain.fhl"` (or any lib/ file listed)
makes its assembly available: an import is looked up next to the importing
file, then in the part library, then in the gallery.
"""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"fabhal: error: {message}\n(run `{self.prog} --help` for examples)\n")


def _binding(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name.strip(), value.strip()


def _add_define(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "-D",
        "--define",
        action="append",
        type=_binding,
        default=[],
        metavar="NAME=VALUE",
        help="bind a `param` of the program (repeatable), e.g. -D n=3 -D Ring=RingM",
    )


def _add_solver_options(command: argparse.ArgumentParser) -> None:
    command.add_argument("--seed", type=int, default=0, help="seed for the random starts (default 0)")
    command.add_argument(
        "--time-limit",
        type=_seconds,
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
    _add_define(command)


def _seconds(text: str) -> float:
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


def _views(text: str) -> tuple[str, ...]:
    from fabhal.render.picture import VIEWS

    views = tuple(v.strip() for v in text.split(",") if v.strip())
    unknown = [v for v in views if v not in VIEWS]
    if not views or unknown:
        raise argparse.ArgumentTypeError(
            f"views are a comma-separated list of {', '.join(VIEWS)}; got {text!r}"
        )
    return views


def _size(text: str) -> tuple[int, int]:
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


def _add_drawing_options(command: argparse.ArgumentParser) -> None:
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
        type=_views,
        default=("iso",),
        metavar="LIST",
        help="PNG views, from iso,front,side,top (default iso)",
    )
    command.add_argument(
        "--size",
        type=_size,
        default=(1200, 900),
        metavar="WxH",
        help="PNG pixels per view (default 1200x900)",
    )


def _gallery_display() -> str:
    """Where the gallery is, as the user would type it: relative inside a
    checkout, the installed path otherwise (so `--help`'s examples run as printed)."""
    from fabhal.resources import display_name, gallery_dir

    return display_name(gallery_dir())


def default_jobs() -> int:
    from fabhal.search.executors import default_jobs as cores

    return cores()


def build_parser() -> argparse.ArgumentParser:
    formatter = argparse.RawDescriptionHelpFormatter
    gallery = _gallery_display()
    parser = _Parser(
        prog="fabhal",
        description="FabHaL: design fixture hacks from everyday objects.",
        epilog=MAIN_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    parser.add_argument("--version", action="version", version=f"fabhal {__version__}")
    parser.add_argument("--debug", action="store_true", help="show Python tracebacks of internal errors")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    check = commands.add_parser(
        "check",
        help="validate programs without solving them",
        description="Parse and check .fhl programs; report every problem found, sorted by position.",
        epilog=CHECK_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    check.add_argument("files", nargs="+", type=Path, metavar="FILE", help=".fhl program(s) to check")
    check.add_argument("--json", action="store_true", help="print diagnostics as a JSON array on stdout")
    _add_define(check)
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
    _add_solver_options(solve)
    solve.add_argument(
        "--render",
        type=Path,
        metavar="OUT",
        help="also draw the result (.png .html .glb .obj .stl, see `render`)",
    )
    _add_drawing_options(solve)
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
    _add_drawing_options(render)
    _add_solver_options(render)
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

    _add_search_command(commands, formatter, gallery)

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
    _add_solver_options(watch)
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
    designer.add_argument("--max-parts", type=_positive, default=4, metavar="N", help="parts per design (4)")
    designer.add_argument(
        "--budget", type=_positive, default=60, metavar="N", help="designs solved at most (60)"
    )
    designer.add_argument(
        "--tolerance", type=float, default=10.0, metavar="MM", help="near enough to the target, mm (10)"
    )
    designer.add_argument(
        "--time-limit", type=_seconds, metavar="SECONDS", help="stop solving after this long (default: none)"
    )
    designer.add_argument(
        "--top", type=_positive, default=5, metavar="K", help="show, emit, render the best K (5)"
    )
    _add_parallel_options(designer)
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


def _positive(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number of at least 1; got {text!r}")
    return int(text)


def _add_parallel_options(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "-j", "--jobs", type=_positive, default=default_jobs(), help="worker processes (default: all cores)"
    )
    command.add_argument("--executor", metavar="dask://HOST:PORT", help="solve on a Dask cluster instead")


def _add_search_command(commands: Any, formatter: Any, gallery: str) -> None:
    search = commands.add_parser(
        "search",
        help="solve every member of a program's family of designs and rank them",
        description="Enumerate every combination of a program's `param` values, check and solve the "
        "members in parallel, and rank them by where the target settles.",
        epilog=SEARCH_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    search.add_argument("file", type=Path, metavar="FILE", help=".fhl program with `param`s")
    search.add_argument("--sample", type=_positive, metavar="N", help="solve a random N of the members")
    _add_parallel_options(search)
    search.add_argument(
        "--inventory",
        type=Path,
        metavar="FILE.toml",
        help="reject members that use more of a part than this file lists (`PartType = count` lines)",
    )
    search.add_argument(
        "--smooth",
        action="store_true",
        help="also solve each member from its neighbours' results (the last param's values before and "
        "after): a member reuses a neighbour's settings where they hang it nearer; about 2x the time",
    )
    search.add_argument(
        "--top", type=_positive, default=10, metavar="K", help="show, emit, render the best K (10)"
    )
    search.add_argument("--json", action="store_true", help="print every member and the ranking as JSON")
    search.add_argument("--csv", type=Path, metavar="FILE", help="write every member as CSV")
    search.add_argument(
        "--log", type=Path, metavar="FILE", help="the results log (default NAME.search.jsonl)"
    )
    search.add_argument("--resume", action="store_true", help="keep the log's members, solve the rest")
    search.add_argument("--emit", type=Path, metavar="DIR", help="write the best K as .fhl programs")
    search.add_argument("--render", type=Path, metavar="DIR", help="draw the best K and a contact sheet")
    search.add_argument("--plot", type=Path, metavar="FILE.png", help="plot target error against the params")
    _add_solver_options(search)
    search.set_defaults(run=run_search)


def _print_diagnostics(diagnostics: Sequence[Diagnostic], sources: dict[str, SourceFile]) -> None:
    if diagnostics:
        text = render_all(diagnostics, sources)
        if sys.stderr.isatty() and "NO_COLOR" not in os.environ:  # https://no-color.org
            from fabhal.syntax.lexer import colour_source_lines

            text = colour_source_lines(text)
        print(text, file=sys.stderr)


def run_check(args: argparse.Namespace) -> int:
    from fabhal import api
    from fabhal.load import InputError

    status = EXIT_OK
    collected: list[dict[str, object]] = []
    for path in args.files:
        try:
            result = api.check(path, dict(args.define))
        except InputError as exc:
            collected.extend(to_json(d) for d in exc.diagnostics)
            if not args.json:
                _print_diagnostics(exc.diagnostics, {})
            status = EXIT_USAGE
            continue
        collected.extend(to_json(d) for d in result.diagnostics)
        if not args.json:
            _print_diagnostics(result.diagnostics, result.sources)
            if result.ok:
                print(f"{path}: ok" + _warning_count(result.diagnostics))
        if not result.ok:
            status = max(status, EXIT_DIAGNOSTICS)
    if args.json:
        print(json.dumps(collected, indent=2))
    return status


def run_solve(args: argparse.Namespace) -> int:
    from fabhal.report import solution as report
    from fabhal.resources import display_name

    result = _solved(args, args.render)
    if isinstance(result, int):
        return result
    name = display_name(args.file.resolve())
    data = report.to_dict(result, name)
    if args.output is not None:
        try:
            args.output.write_text(json.dumps(data, indent=2) + "\n")
        except OSError as exc:
            print(f"fabhal: cannot write {args.output}: {exc.strerror}", file=sys.stderr)
            return EXIT_USAGE
    if args.json:
        print(json.dumps(data, indent=2))
    else:
        _print_diagnostics(result.diagnostics, result.check.sources)
        console = _console()
        for renderable in report.renderables(result, name):
            console.print(renderable)
        if args.dofs and result.solution is not None:
            console.print(report.dofs_table(result.solution))
    return _finish(result, args.render, args, data)


def _solved(args: argparse.Namespace, render_to: Path | None) -> Any:
    """Refuse an unknown drawing format before any work, then solve: the
    result, or an exit code when the file cannot be read."""
    from fabhal.load import InputError

    if _unknown_format(render_to):
        return EXIT_USAGE
    try:
        return _solve_with_status(args)
    except InputError as exc:
        _print_diagnostics(exc.diagnostics, {})
        return EXIT_USAGE


def _finish(result: Any, render_to: Path | None, args: argparse.Namespace, summary: dict[str, Any]) -> int:
    """Draw the result if asked; the exit code of solve and render."""
    if render_to is not None:
        written = _render(result, render_to, args, summary)
        if written is not None:
            return written
    return EXIT_OK if result.status == "solved" else EXIT_DIAGNOSTICS


def _solve_with_status(args: argparse.Namespace) -> Any:
    """api.solve, with a status line on the terminal while it works (only when
    stderr is a terminal: pipes and JSON consumers see nothing extra)."""
    from fabhal import api

    solve_args = (args.file, dict(args.define), args.seed, args.time_limit, not args.no_gravity)
    if not sys.stderr.isatty():
        return api.solve(*solve_args, two_step=args.two_step)
    from rich.console import Console

    with Console(stderr=True).status(f"solving {args.file.name}: checking") as status:
        return api.solve(
            *solve_args,
            progress=lambda doing: status.update(f"solving {args.file.name}: {doing}"),
            two_step=args.two_step,
        )


def run_render(args: argparse.Namespace) -> int:
    from fabhal.report import solution as report
    from fabhal.resources import display_name

    result = _solved(args, args.output)
    if isinstance(result, int):
        return result
    _print_diagnostics(result.diagnostics, result.check.sources)
    return _finish(result, args.output, args, report.to_dict(result, display_name(args.file.resolve())))


_NOT_SOLVED = {
    "error": "the program has errors",
    "infeasible": "a loop of the design cannot close",
    "out_of_time": "the time limit ended before the loops were closed",
}


def _unknown_format(output: Path | None) -> bool:
    """Say so (before any solving) if `output`'s suffix is not a format `render` writes."""
    if output is None:
        return False  # without importing the renderer: `fabhal solve` starts faster
    from fabhal.render import FORMATS

    if output.suffix.lower() in FORMATS:
        return False
    print(
        f"fabhal: cannot render to `{output}`: the suffix picks the format, one of {' '.join(FORMATS)}",
        file=sys.stderr,
    )
    return True


def _render(result: Any, output: Path, args: argparse.Namespace, summary: dict[str, Any]) -> int | None:
    """Draw the solution to `output`; an exit code if that failed, else None."""
    from fabhal.render import RenderOptions, render

    if result.solution is None:
        print(
            f"fabhal: nothing to draw: {_NOT_SOLVED[result.status]} (see above)",
            file=sys.stderr,
        )
        return EXIT_DIAGNOSTICS
    options = RenderOptions(args.show == "requested", args.primitives, args.views, args.size)
    try:
        render(result.solution, args.file.stem, output, options, summary)
    except OSError as exc:
        print(f"fabhal: cannot write {output}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    print(f"wrote {output} ({result.status.replace('_', ' ')})", file=sys.stderr)
    return None


def run_search(args: argparse.Namespace) -> int:
    from fabhal import search as family
    from fabhal.load import InputError
    from fabhal.search.executors import ExecutorError
    from fabhal.search.log import LogError

    if args.no_gravity:
        print("fabhal: search ranks where each member hangs: --no-gravity does not apply", file=sys.stderr)
        return EXIT_USAGE
    try:
        wanted = family.SearchOptions(pinned=dict(args.define), sample=args.sample, seed=args.seed)
        plan = family.plan(args.file, wanted)
    except InputError as exc:
        _print_diagnostics(exc.diagnostics, {})
        return EXIT_USAGE
    if not plan.members:
        _print_diagnostics(plan.diagnostics, plan.program.sources)
        print(f"{args.file}: no members to solve", file=sys.stderr)
        return EXIT_DIAGNOSTICS
    options = _search_options(args, plan)
    if isinstance(options, int):
        return options
    log = args.log or Path(f"{args.file.stem}.search.jsonl")
    if not args.resume and log.is_file() and log.stat().st_size > 0:
        print(f"fabhal: starting {log} afresh (--resume would keep the members it has)", file=sys.stderr)
    try:
        outcome = _search_with_progress(plan, options, log, args)
    except (ExecutorError, LogError) as exc:
        print(f"fabhal: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:
        print(f"fabhal: cannot write the log {log}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    return _report_search(plan, outcome, options, log, args)


def _search_options(args: argparse.Namespace, plan: Any) -> Any:
    """The search's options, with the inventory read; an exit code if it cannot be."""
    from fabhal import search as family
    from fabhal.inventory import InventoryError, read_inventory
    from fabhal.library import build_library

    inventory = None
    if args.inventory is not None:
        try:
            inventory = read_inventory(args.inventory, build_library(plan.program)[0])
        except InventoryError as exc:
            sources = {exc.source.name: exc.source} if exc.source is not None else {}
            _print_diagnostics(exc.diagnostics, sources)
            return EXIT_USAGE
    return family.SearchOptions(
        pinned=dict(args.define),
        sample=args.sample,
        seed=args.seed,
        time_limit=args.time_limit,
        two_step=args.two_step,
        inventory=inventory,
        smooth=args.smooth,
        jobs=args.jobs,
        executor=args.executor,
    )


def _search_with_progress(plan: Any, options: Any, log: Path, args: argparse.Namespace) -> Any:
    """family.run with a progress bar (rate, ETA, best so far) on a terminal."""
    from fabhal import search as family

    if not sys.stderr.isatty():
        return family.run(plan, options, log, args.resume)
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    best = [math.inf]
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeRemainingColumn(),
        TextColumn("{task.fields[best]}"),
    )
    with Progress(*columns, console=Console(stderr=True)) as bar:
        task = bar.add_task(f"searching {args.file.name}", total=len(plan.members), rate="", best="")

        def advance(member: Any, done: int, total: int) -> None:
            if member.status == "solved" and member.position_mm is not None:
                best[0] = min(best[0], member.position_mm)
            speed = bar.tasks[0].speed
            bar.update(
                task,
                completed=done,
                rate=f"{speed:.1f}/s" if speed else "",
                best=f"best {best[0]:.1f} mm" if math.isfinite(best[0]) else "",
            )

        return family.run(plan, options, log, args.resume, advance)


def _report_search(plan: Any, outcome: Any, options: Any, log: Path, args: argparse.Namespace) -> int:
    from fabhal.resources import display_name
    from fabhal.search import rank
    from fabhal.search import report as search_report

    name = display_name(args.file.resolve())
    if args.csv is not None:
        try:
            search_report.write_csv(args.csv, plan, outcome.members)
        except OSError as exc:
            print(f"fabhal: cannot write {args.csv}: {exc.strerror}", file=sys.stderr)
            return EXIT_USAGE
    if args.json:
        print(json.dumps(search_report.to_json(plan, outcome, name, options.jobs), indent=2))
    else:
        _print_search_summary(plan, outcome, options, name, log, args)
    written = _search_outputs(plan, outcome, options, args)
    if written is not None:
        return written
    return EXIT_OK if any(m.status == "solved" for m in rank(outcome.members)) else EXIT_DIAGNOSTICS


def _print_search_summary(
    plan: Any, outcome: Any, options: Any, name: str, log: Path, args: argparse.Namespace
) -> None:
    from fabhal.search import report as search_report

    console = _console()
    print(f"{name}: {search_report.counts_line(plan, outcome)}")
    for line in search_report.rejection_lines(outcome):
        print(line)
    if any(m.position_mm is not None for m in outcome.members):
        console.print(search_report.ranked_table(plan, outcome, args.top))
    for line in search_report.best_per_lines(plan, outcome):
        print(line)
    solved_here = len(outcome.members) - outcome.resumed
    where = options.executor or f"{options.jobs} worker{'s' if options.jobs != 1 else ''}"
    resumed = f" ({outcome.resumed} read back from the log)" if outcome.resumed else ""
    members = f"{solved_here} member{'' if solved_here == 1 else 's'}"
    print(f"{members} in {outcome.elapsed_s:.1f} s on {where}{resumed}; log: {log}")
    if not outcome.complete:
        print(
            f"interrupted: {len(outcome.members)} of {len(plan.members)} members done; "
            f"run again with --resume to finish",
            file=sys.stderr,
        )


def _search_outputs(plan: Any, outcome: Any, options: Any, args: argparse.Namespace) -> int | None:
    """--emit, --render and --plot; an exit code if one could not be written."""
    from fabhal.search import rank

    best = rank(outcome.members)[: args.top]
    try:
        if args.emit is not None:
            from fabhal.search.emit import emit_member

            for place, member in enumerate(best, start=1):
                emit_member(plan.program, member, place, args.emit)
            print(f"wrote the best {len(best)} as programs to {args.emit}/", file=sys.stderr)
        if args.render is not None:
            _render_best(plan, outcome, best, options, args.render)
        if args.plot is not None:
            from fabhal.search.pictures import plot_errors

            plot_errors(plan, outcome.members, args.plot)
            print(f"wrote {args.plot}", file=sys.stderr)
    except OSError as exc:
        print(f"fabhal: cannot write {exc.filename or 'the output'}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    return None


def _render_best(plan: Any, outcome: Any, best: Any, options: Any, directory: Path) -> None:
    """The best K and their contact sheet; per name-valued param (a ring size), the
    winner of each value side by side (winners_PARAM.png), as the paper's figure."""
    from fabhal.search import best_by
    from fabhal.search.pictures import render_members
    from fabhal.search.report import categorical_params

    sheets = [(best, "contact_sheet.png")] + [
        (list(best_by(outcome.members, param).values()), f"winners_{param}.png")
        for param in categorical_params(plan)
    ]
    for members, name in sheets:
        if not sys.stderr.isatty():
            written = render_members(plan, members, options, directory, sheet_name=name)
        else:
            from rich.console import Console

            with Console(stderr=True).status("drawing") as status:
                written = render_members(
                    plan, members, options, directory, lambda i, n: status.update(f"drawing {i} of {n}"), name
                )
        print(f"drew {len(written) - 1} members and {written[-1]}", file=sys.stderr)


def run_watch(args: argparse.Namespace) -> int:
    import threading
    import time as clock

    from fabhal.watch.files import watch_files
    from fabhal.watch.server import LiveServer
    from fabhal.watch.session import LiveResult, LiveSession, SolveSettings

    if not args.file.is_file():
        print(f"fabhal: cannot watch {args.file}: no such file", file=sys.stderr)
        return EXIT_USAGE
    if args.no_gravity:
        print("fabhal: watch shows where the hack hangs: --no-gravity does not apply", file=sys.stderr)
        return EXIT_USAGE

    def report(result: LiveResult) -> None:
        print(f"{clock.strftime('%H:%M:%S')} {result.summary} ({result.elapsed_s:.2f} s)", flush=True)

    settings = SolveSettings(dict(args.define), args.seed, args.time_limit, args.two_step)
    session = LiveSession(args.file, settings, report)
    try:
        server = LiveServer(args.port, session, args.file.name)
    except OSError as exc:
        print(f"fabhal: cannot serve on 127.0.0.1:{args.port}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    stop = threading.Event()
    watcher = threading.Thread(
        target=watch_files, args=(lambda: session.dependencies, session.changed, stop), daemon=True
    )
    print(f"watching {args.file} and its imports; live view at {server.url} (Ctrl-C stops)", flush=True)
    session.start()
    watcher.start()
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        stop.set()
        session.stop()
        server.server_close()
    return EXIT_OK


def run_design(args: argparse.Namespace) -> int:
    from fabhal import api
    from fabhal import design as designer
    from fabhal.inventory import InventoryError, read_inventory
    from fabhal.load import InputError
    from fabhal.search.executors import ExecutorError

    try:
        inventory = read_inventory(args.inventory, api.part_library().library)
    except InventoryError as exc:
        _print_diagnostics(exc.diagnostics, {exc.source.name: exc.source} if exc.source else {})
        return EXIT_USAGE
    options = designer.DesignOptions(
        args.max_parts, args.budget, args.tolerance, args.seed, args.time_limit, args.jobs, args.executor
    )
    try:
        plan = designer.plan(args.file, inventory, options)
    except InputError as exc:
        _print_diagnostics(exc.diagnostics, {})
        return EXIT_USAGE
    if plan.diagnostics:
        _print_diagnostics(plan.diagnostics, {})
        return EXIT_DIAGNOSTICS
    try:
        outcome = _design_with_progress(plan, options, args)
    except ExecutorError as exc:
        print(f"fabhal: {exc}", file=sys.stderr)
        return EXIT_USAGE
    from fabhal.design import report as design_report

    if args.json:
        print(json.dumps(design_report.to_json(plan, outcome, options), indent=2))
    else:
        design_report.print_summary(plan, outcome, options, args.top, _console())
    try:
        design_report.write_outputs(plan, outcome, args.top, args.emit, args.render, options)
    except OSError as exc:
        print(f"fabhal: cannot write {exc.filename or 'the output'}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    return EXIT_OK if design_report.reaches(outcome, options) else EXIT_DIAGNOSTICS


def _design_with_progress(plan: Any, options: Any, args: argparse.Namespace) -> Any:
    from fabhal import design as designer

    if not sys.stderr.isatty():
        return designer.run(plan, options)
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    with Progress(*columns, console=Console(stderr=True)) as bar:
        task = bar.add_task(f"solving designs for {args.file.name}", total=len(plan.candidates))
        return designer.run(plan, options, lambda member, done, total: bar.update(task, completed=done))


def run_lsp(args: argparse.Namespace) -> int:
    try:
        from fabhal.lsp.server import main as serve
    except ImportError:
        print("fabhal: the language server needs pygls: pip install 'fabhal[lsp]'", file=sys.stderr)
        return EXIT_USAGE
    serve()
    return EXIT_OK


def run_bench(args: argparse.Namespace) -> int:
    from fabhal import bench, resources

    checkout = resources.stdlib_dir().parent
    programs = list(args.files) or sorted(resources.gallery_dir().glob("*.fhl"))
    if not programs:
        print("fabhal: no programs to benchmark (pass .fhl files)", file=sys.stderr)
        return EXIT_USAGE
    missing = [p for p in programs if not p.is_file()]
    if missing:
        print(f"fabhal: cannot read {missing[0]}: no such file", file=sys.stderr)
        return EXIT_USAGE
    if args.runs < 1:
        print("fabhal: --runs must be at least 1", file=sys.stderr)
        return EXIT_USAGE
    output = args.output
    if output is None and (checkout / "bench").is_dir():
        output = checkout / "bench" / "results.json"
    bench.run(programs, args.runs, output, whole_process=not args.no_process)
    return EXIT_OK


def run_parts(args: argparse.Namespace) -> int:
    from fabhal import api
    from fabhal.report import parts as report
    from fabhal.syntax.hints import did_you_mean

    result = api.part_library()
    if not result.ok:
        _print_diagnostics(result.diagnostics, result.sources)
        return EXIT_DIAGNOSTICS
    library = result.library
    if args.name is None:
        if args.json:
            print(json.dumps(report.list_json(library), indent=2))
        else:
            _console().print(report.list_table(library))
        return EXIT_OK
    if args.name not in library.parts:
        suggestion = did_you_mean(args.name, library.parts)
        hint = f"did you mean `{suggestion}`? " if suggestion else ""
        print(f"fabhal: no part named `{args.name}`; {hint}(`fabhal parts` lists them all)", file=sys.stderr)
        return EXIT_USAGE
    part_type = library.parts[args.name]
    spec = library.instantiate(args.name, {}, part_type.span)
    info = report.detail(part_type, spec)
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        console = _console()
        for renderable in report.detail_renderables(info):
            console.print(renderable)
    return EXIT_OK


def run_gallery(args: argparse.Namespace) -> int:
    from fabhal import resources
    from fabhal.report import gallery

    items = gallery.entries(resources.gallery_dir())
    if args.json:
        print(json.dumps(gallery.to_json(items), indent=2))
    else:
        _console().print(gallery.table(items, resources.gallery_dir()))
    return EXIT_OK


def _console() -> Any:
    from rich.console import Console

    return Console(width=None if sys.stdout.isatty() else 140)


def _warning_count(diagnostics: Sequence[Diagnostic]) -> str:
    counts = []
    for severity in (Severity.WARNING, Severity.NOTE):
        n = sum(1 for d in diagnostics if d.severity is severity)
        if n:
            counts.append(f"{n} {severity.value}{'s' if n != 1 else ''}")
    return f" ({', '.join(counts)})" if counts else ""


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
