"""The benchmark: how long each gallery program takes to parse, check and solve.

For every program: the median over N runs in one process (round robin over
the programs) of each stage's time
(as `fabhal.api.solve` measures it: parse = reading and parsing the program
and the part library, check = elaboration and every rule, solve = the
solver), plus the wall time of whole `fabhal solve` processes: the median of
PROCESS_RUNS with Python's bytecode cache filled (as from a user's second
run on), and one cold run that compiles every module first. The four
clip-light programs solved back to back form one extra row. Targets (issue 8):
a whole process under 1 s; the solve step under 200 ms without loops and
under 500 ms with them. Run `python bench/run.py` or `fabhal bench`; results
go to bench/results.json. See bench/README.md.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from fabhal import api

PROCESS_TARGET_S = 1.0
SOLVE_TARGET_S = 0.2  # without loops
SOLVE_WITH_LOOPS_TARGET_S = 0.5
FAMILY = ("clip_light_xs", "clip_light_s", "clip_light_m", "clip_light_l")
PROCESS_RUNS = 3  # single process times vary by +-30 % on a shared 2-core machine
STAGES = ("parse_s", "check_s", "solve_s")
Timing = dict[str, float]


@dataclass(frozen=True)
class Row:
    program: str
    loops: int
    status: str
    parse_s: float  # medians over the runs
    check_s: float
    solve_s: float
    process_s: float | None  # whole `fabhal solve` processes, bytecode cached: median wall time
    solve_target_s: float
    cold_process_s: float | None = None  # one process compiling every module first

    @property
    def meets_targets(self) -> bool:
        within_process = self.process_s is None or self.process_s < PROCESS_TARGET_S
        return within_process and self.solve_s < self.solve_target_s


def program_row(path: Path, timings: Sequence[Timing], last: api.SolveResult, whole_process: bool) -> Row:
    """One program's row from its in-process timings, plus its whole-process runs."""
    cold = process_wall_time(path, cold=True) if whole_process else None
    warm = statistics.median(process_wall_time(path) for _ in range(PROCESS_RUNS)) if whole_process else None
    model = last.check.model
    loops = len(model.closures) if model is not None else 0
    parse_s, check_s, solve_s = _medians(timings)
    target = SOLVE_WITH_LOOPS_TARGET_S if loops else SOLVE_TARGET_S
    return Row(path.stem, loops, last.status, parse_s, check_s, solve_s, warm, target, cold)


def _medians(timings: Sequence[Timing]) -> tuple[float, float, float]:
    parse_s, check_s, solve_s = (statistics.median(t[k] for t in timings) for k in STAGES)
    return parse_s, check_s, solve_s


def process_wall_time(path: Path, cold: bool = False) -> float:
    """Wall time of `fabhal solve --json PATH` in a fresh Python process: with
    fabhal's bytecode compiled beforehand (Python caches it on a first run,
    unless PYTHONDONTWRITEBYTECODE is set), or `cold`: fabhal's bytecode cache
    emptied and not written, so every fabhal module is compiled first."""
    import compileall
    import shutil

    package = Path(__file__).parent
    environment = {**os.environ}
    if cold:
        for cache in package.rglob("__pycache__"):
            shutil.rmtree(cache, ignore_errors=True)
        environment["PYTHONDONTWRITEBYTECODE"] = "1"
    else:
        compileall.compile_dir(package, quiet=1)
    started = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "fabhal", "solve", "--json", str(path)],
        capture_output=True,
        check=False,
        env=environment,
    )
    return time.perf_counter() - started


def run(programs: Sequence[Path], runs: int, output: Path | None, whole_process: bool = True) -> list[Row]:
    """Time every program `runs` times in this process, round robin (a slow spell
    of a shared machine then costs every program a little instead of one
    program a lot), the clip-light family as one more member of each round;
    then each program's whole processes. Prints the table, writes `output`."""
    from rich.console import Console
    from rich.progress import Progress

    console = Console(stderr=True)
    paths = list(programs)
    members = [p for p in paths if p.stem in FAMILY]
    family = sorted(members, key=lambda p: FAMILY.index(p.stem)) if len(members) == len(FAMILY) else []
    timings: dict[Path, list[Timing]] = {p: [] for p in paths}
    family_timings: list[Timing] = []
    last: dict[Path, api.SolveResult] = {}
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("benchmarking", total=runs * (len(paths) + 1) + len(paths))
        for round_number in range(max(runs, 1)):
            progress.update(task, description=f"round {round_number + 1} of {runs}")
            for path in paths:
                last[path] = api.solve(path)
                timings[path].append(last[path].timing)
                progress.advance(task)
            if family:  # a preview of searching a family of designs (each member re-parsed, re-checked)
                solved = [api.solve(p).timing for p in family]
                family_timings.append({k: sum(t[k] for t in solved) for k in STAGES})
            progress.advance(task)
        rows = []
        for path in paths:
            progress.update(task, description=f"whole processes: {path.stem}")
            rows.append(program_row(path, timings[path], last[path], whole_process))
            progress.advance(task)
    if family:
        label = "clip_light_* (4, back to back)"
        rows.append(Row(label, 0, "-", *_medians(family_timings), None, 4 * SOLVE_TARGET_S))
    Console(width=max(Console().width, 120)).print(table(rows, runs))
    if output is not None:
        output.write_text(json.dumps(results_json(rows, runs), indent=2) + "\n")
        console.print(f"wrote {output}")
    return rows


def table(rows: Sequence[Row], runs: int) -> object:
    from rich.table import Table

    out = Table(
        title=f"stages: median of {runs} runs in one process; process: whole `fabhal solve`, "
        f"median of {PROCESS_RUNS} (target < 1000 ms), and one cold (compiling every module)"
    )
    for column in (
        "program",
        "loops",
        "status",
        "parse ms",
        "check ms",
        "solve ms",
        "target",
        "process ms",
        "cold ms",
        "targets",
    ):
        out.add_column(column, justify="left" if column in ("program", "status") else "right")
    for row in rows:
        process = f"{row.process_s * 1000:.0f}" if row.process_s is not None else "-"
        cold = f"{row.cold_process_s * 1000:.0f}" if row.cold_process_s is not None else "-"
        verdict = "[green]met[/green]" if row.meets_targets else "[red]missed[/red]"
        out.add_row(
            row.program,
            str(row.loops),
            row.status,
            f"{row.parse_s * 1000:.0f}",
            f"{row.check_s * 1000:.0f}",
            f"{row.solve_s * 1000:.0f}",
            f"< {row.solve_target_s * 1000:.0f}",
            process,
            cold,
            verdict,
        )
    return out


def results_json(rows: Sequence[Row], runs: int) -> dict[str, object]:
    return {
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "platform": platform.platform(),
        },
        "runs": runs,
        "process_runs": PROCESS_RUNS,
        "targets_s": {
            "process": PROCESS_TARGET_S,
            "solve_without_loops": SOLVE_TARGET_S,
            "solve_with_loops": SOLVE_WITH_LOOPS_TARGET_S,
        },
        "rows": [{**asdict(row), "meets_targets": row.meets_targets} for row in rows],
    }
