"""Does the clip-light family's settled error jump between neighbouring members?
`python bench/family.py [--sizes RingXS,RingS,RingM,RingL] [--n 1,2,3,4] [--smooth] [--two-step]`.

Issue 15's rule: between neighbouring extensions (21 values over [0, 45.7] mm)
the settled target error may change by at most the change in chain length
(n turnbuckles x 2.285 mm) plus 5 mm. Runs `fabhal search` over
programs/clip_light_family.fhl (every core; `--smooth`: each member also
continued from its neighbours' results), prints each row of errors (mm) and
counts the steps that break the rule. Results in bench/README.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout without installing

from fabhal import search  # noqa: E402

FAMILY = HERE.parent / "programs" / "clip_light_family.fhl"
STEP_MM = 45.7 / 20
SLACK_MM = 5.0


def jumps(errors: list[float], n: int) -> int:
    allowed = n * STEP_MM + SLACK_MM
    steps = np.abs(np.diff(np.array(errors)))
    return int(np.sum(~(steps <= allowed)))  # a member not solved counts as a jump


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="RingXS,RingS,RingM,RingL", help="ring sizes (default all four)")
    parser.add_argument("--n", default="1,2,3,4", help="chain lengths (default 1,2,3,4)")
    parser.add_argument("--smooth", action="store_true", help="continue members from their neighbours")
    parser.add_argument("--two-step", action="store_true", help="without aiming, to compare")
    args = parser.parse_args()
    options = search.SearchOptions(smooth=args.smooth, two_step=args.two_step)
    family = search.plan(FAMILY, options)
    sizes, counts = args.sizes.split(","), args.n.split(",")
    wanted = [m for m in family.members if m["ring"] in sizes and m["n"] in counts]
    family = replace(family, members=tuple(wanted))
    with tempfile.TemporaryDirectory() as scratch:
        outcome = search.run(family, options, Path(scratch) / "log.jsonl")
    total = 0
    for size in sizes:
        for n in counts:
            errors = [
                m.position_mm if m.status == "solved" and m.position_mm is not None else float("nan")
                for m in outcome.members
                if (m.bindings["ring"], m.bindings["n"]) == (size, n)
            ]
            broken = jumps(errors, int(n))
            total += broken
            shown = " ".join(f"{e:5.1f}" for e in errors)
            sys.stdout.write(f"{size:6s} n={n} jumps={broken:2d} best={np.nanmin(errors):5.1f}  {shown}\n")
    elapsed = outcome.elapsed_s
    sys.stdout.write(f"steps breaking the rule: {total}; {elapsed:.0f} s of searching\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
