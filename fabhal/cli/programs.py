"""The commands on one program or the library: check, solve, render, bench, parts, gallery."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from fabhal.cli.common import (
    EXIT_DIAGNOSTICS,
    EXIT_OK,
    EXIT_USAGE,
    prepare_outputs,
    print_diagnostics,
    terminal,
    warning_count,
)
from fabhal.diagnostics import to_json


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
                print_diagnostics(exc.diagnostics, {})
            status = EXIT_USAGE
            continue
        collected.extend(to_json(d) for d in result.diagnostics)
        if not args.json:
            print_diagnostics(result.diagnostics, result.sources)
            if result.ok:
                print(f"{path}: ok" + warning_count(result.diagnostics))
        if not result.ok:
            status = max(status, EXIT_DIAGNOSTICS)
    if args.json:
        print(json.dumps(collected, indent=2))
    return status


def run_solve(args: argparse.Namespace) -> int:
    from fabhal.report import solution as report
    from fabhal.resources import display_name

    result = _solved(args, args.render, args.output)
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
        print_diagnostics(result.diagnostics, result.check.sources)
        console = terminal()
        for renderable in report.renderables(result, name):
            console.print(renderable)
        if args.dofs and result.solution is not None:
            console.print(report.dofs_table(result.solution))
    return _finish(result, args.render, args, data)


def _solved(args: argparse.Namespace, render_to: Path | None, json_to: Path | None = None) -> Any:
    """Refuse an unknown drawing format and make the outputs' folders before any
    work, then solve: the result, or an exit code when the file cannot be read."""
    from fabhal.load import InputError

    if _unknown_format(render_to):
        return EXIT_USAGE
    unwritable = prepare_outputs([render_to, json_to])
    if unwritable is not None:
        return unwritable
    try:
        return _solve_with_status(args)
    except InputError as exc:
        print_diagnostics(exc.diagnostics, {})
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
    print_diagnostics(result.diagnostics, result.check.sources)
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
        print_diagnostics(result.diagnostics, result.sources)
        return EXIT_DIAGNOSTICS
    library = result.library
    if args.name is None:
        if args.json:
            print(json.dumps(report.list_json(library), indent=2))
        else:
            terminal().print(report.list_table(library))
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
        console = terminal()
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
        terminal().print(gallery.table(items, resources.gallery_dir()))
    return EXIT_OK
