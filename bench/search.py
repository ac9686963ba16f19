"""The clip-light family through `fabhal search` (issue 16):
`python bench/search.py [--jobs J] [--sample N]`.

Runs the search of programs/clip_light_family.fhl (4 ring sizes x n = 1..4 x
21 extensions: 336 members) on J local worker processes (default: every
core) and compares the cost per member (wall time x workers / members) with
a single solve of a member inside one warm process (the mean over 12 members
spread over the family). Targets (issue 16): the whole family under 30 s on
2 cores; the cost per member within 1.5x of a single solve. Prints the best
member per ring size. Results in bench/README.md ("The family search").
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout without installing

from fabhal import api, search  # noqa: E402
from fabhal.search.executors import default_jobs  # noqa: E402

FAMILY = HERE.parent / "programs" / "clip_light_family.fhl"
TARGET_S, TARGET_RATIO = 30.0, 1.5


def single_solve_s(family: search.SearchPlan, count: int = 12) -> float:
    members = family.members[:: max(1, len(family.members) // count)][:count]
    api.solve(family.program, members[0])  # warm: imports, library, contact grids
    started = time.perf_counter()
    for member in members:
        api.solve(family.program, member)
    return (time.perf_counter() - started) / len(members)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)"
    )
    parser.add_argument("--sample", type=int, help="a random subset of the members")
    args = parser.parse_args()
    options = search.SearchOptions(jobs=args.jobs, sample=args.sample)
    family = search.plan(FAMILY, options)
    single = single_solve_s(family)
    with tempfile.TemporaryDirectory() as scratch:
        outcome = search.run(family, options, Path(scratch) / "log.jsonl")
    per_member = outcome.elapsed_s * args.jobs / len(outcome.members)
    total_met = "met" if outcome.elapsed_s < TARGET_S else "missed"
    ratio_met = "met" if per_member < TARGET_RATIO * single else "missed"
    write = sys.stdout.write
    members, elapsed = len(outcome.members), outcome.elapsed_s
    write(f"{members} members on {args.jobs} workers: {elapsed:.1f} s ({total_met}: < {TARGET_S:.0f} s)\n")
    write(f"per member {per_member:.3f} s; a single solve in one process {single:.3f} s: ")
    write(f"{per_member / single:.2f}x ({ratio_met}: < {TARGET_RATIO}x)\n")
    for ring, member in search.best_by(outcome.members, "ring").items():
        write(f"best {ring}: {member.key}: {member.position_mm:.1f} mm, {member.rotation_deg:.1f} deg\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
