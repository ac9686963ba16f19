"""Does the clip-light family's settled error jump between neighbouring members?
`python bench/family.py [--sizes xs,s,m,l] [--n 1,2,3,4] [--two-step]`.

Issue 15's rule: between neighbouring extensions (21 values over [0, 45.7] mm)
the settled target error may change by at most the change in chain length
(n turnbuckles x 2.285 mm) plus 5 mm. Solves every member of
programs/clip_light_<size>.fhl for each n, prints each row of errors (mm)
and counts the steps that break the rule. Results in bench/README.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout without installing

from fabhal import api  # noqa: E402

EXTENSIONS = np.linspace(0.0, 45.7, 21)
SLACK_MM = 5.0


def row(program: Path, n: int, two_step: bool) -> list[float]:
    errors = []
    for extension in EXTENSIONS:
        bindings = {"n": str(n), "extension": repr(float(extension))}
        result = api.solve(program, bindings, two_step=two_step)
        held = result.solution is not None and result.status == "solved"
        errors.append(result.solution.target_errors()[0] if held else float("nan"))
    return errors


def jumps(errors: list[float], n: int) -> int:
    allowed = n * (EXTENSIONS[1] - EXTENSIONS[0]) + SLACK_MM
    steps = np.abs(np.diff(np.array(errors)))
    return int(np.sum(~(steps <= allowed)))  # a member not solved counts as a jump


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="xs,s,m,l", help="ring sizes (default xs,s,m,l)")
    parser.add_argument("--n", default="1,2,3,4", help="chain lengths (default 1,2,3,4)")
    parser.add_argument("--two-step", action="store_true", help="without aiming, to compare")
    args = parser.parse_args()
    total = 0
    for size in args.sizes.split(","):
        program = HERE.parent / "programs" / f"clip_light_{size}.fhl"
        for n in (int(v) for v in args.n.split(",")):
            errors = row(program, n, args.two_step)
            broken = jumps(errors, n)
            total += broken
            shown = " ".join(f"{e:5.1f}" for e in errors)
            sys.stdout.write(f"{size:2s} n={n} jumps={broken:2d} best={np.nanmin(errors):5.1f}  {shown}\n")
            sys.stdout.flush()
    sys.stdout.write(f"steps breaking the rule: {total}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
