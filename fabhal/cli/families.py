"""The commands over many designs: `fabhal search` (a family) and `fabhal design` (an inventory)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from fabhal.cli.common import (
    EXIT_DIAGNOSTICS,
    EXIT_OK,
    EXIT_USAGE,
    add_parallel_options,
    add_solver_options,
    positive,
    prepare_outputs,
    print_diagnostics,
    terminal,
)
from fabhal.cli.epilogs import SEARCH_EPILOG


def add_search_command(commands: Any, formatter: Any, gallery: str) -> None:
    search = commands.add_parser(
        "search",
        help="solve every member of a program's family of designs and rank them",
        description="Enumerate every combination of a program's `param` values, check and solve the "
        "members in parallel, and rank them by where the target settles.",
        epilog=SEARCH_EPILOG.format(gallery=gallery),
        formatter_class=formatter,
    )
    search.add_argument("file", type=Path, metavar="FILE", help=".fhl program with `param`s")
    search.add_argument("--sample", type=positive, metavar="N", help="solve a random N of the members")
    add_parallel_options(search)
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
        "--top", type=positive, default=10, metavar="K", help="show, emit, render the best K (10)"
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
    add_solver_options(search)
    search.set_defaults(run=run_search)


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
        print_diagnostics(exc.diagnostics, {})
        return EXIT_USAGE
    if not plan.members:
        print_diagnostics(plan.diagnostics, plan.program.sources)
        print(f"{args.file}: no members to solve", file=sys.stderr)
        return EXIT_DIAGNOSTICS
    options = _search_options(args, plan)
    if isinstance(options, int):
        return options
    log = args.log or Path(f"{args.file.stem}.search.jsonl")
    unwritable = prepare_outputs([log, args.csv, args.plot], [args.emit, args.render])
    if unwritable is not None:
        return unwritable
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
            print_diagnostics(exc.diagnostics, sources)
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

    console = terminal()
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


def run_design(args: argparse.Namespace) -> int:
    from fabhal import api
    from fabhal import design as designer
    from fabhal.inventory import InventoryError, read_inventory
    from fabhal.load import InputError
    from fabhal.search.executors import ExecutorError

    try:
        inventory = read_inventory(args.inventory, api.part_library().library)
    except InventoryError as exc:
        print_diagnostics(exc.diagnostics, {exc.source.name: exc.source} if exc.source else {})
        return EXIT_USAGE
    options = designer.DesignOptions(
        args.max_parts, args.budget, args.tolerance, args.seed, args.time_limit, args.jobs, args.executor
    )
    try:
        plan = designer.plan(args.file, inventory, options)
    except InputError as exc:
        print_diagnostics(exc.diagnostics, {})
        return EXIT_USAGE
    if plan.diagnostics:
        print_diagnostics(plan.diagnostics, dict(plan.sources))
        return EXIT_DIAGNOSTICS
    unwritable = prepare_outputs([], [args.emit, args.render])
    if unwritable is not None:
        return unwritable
    try:
        outcome = _design_with_progress(plan, options, args)
    except ExecutorError as exc:
        print(f"fabhal: {exc}", file=sys.stderr)
        return EXIT_USAGE
    from fabhal.design import report as design_report

    if args.json:
        print(json.dumps(design_report.to_json(plan, outcome, options), indent=2))
    else:
        design_report.print_summary(plan, outcome, options, args.top, terminal())
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
