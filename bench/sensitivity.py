"""Does an answer survive rounding? Each program solved as written and with the
whole world moved by a nanometre.
`python bench/sensitivity.py [--shift MM] [programs ...]` (default: the gallery).

Moving every environment and the target by the same small shift (default
1e-6 mm) along x, then y, then z poses the same hack: only the rounding of
each number changes. A robust answer's target error stays within a hair of the
program's own; where the settled rest is one of many in a flat valley (a long
loop resting on the world), the rounding picks which one, and the error
moves by millimetres. Prints each program's target errors (mm, degrees) per
shift, their spread, and the range of the rests' potential energies (J:
which of two rests is the lower; measured from z = 0, so a large --shift
moves them by the weight times the shift along z); results in
bench/README.md.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout without installing

from fabhal import api  # noqa: E402
from fabhal.load import load_program  # noqa: E402

GALLERY = HERE.parent / "programs"
# an environment's or the target's placement: `at (x, y, z)` on its line
PLACED = re.compile(r"^(\s*(?:environment|target)\b[^#\n]*?\bat\s*\()([^)]*)(\))", re.MULTILINE)


def moved(text: str, axis: int, shift: float) -> str:
    """The program's text with every environment and the target moved by `shift`
    mm along `axis` (ValueError where a placement is not three numbers)."""

    def move(match: re.Match[str]) -> str:
        numbers = [float(value) for value in match.group(2).split(",")]
        numbers[axis] += shift
        return match.group(1) + ", ".join(repr(value) for value in numbers) + match.group(3)

    return PLACED.sub(move, text)


def write(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def errors(path: Path, text: str) -> tuple[str, float, float, float]:
    """Status, target errors (mm, degrees) and potential energy (J) of the program's solve."""
    result = api.solve(load_program(path, text))
    solution: Any = result.solution
    if solution is None:
        return result.status, float("nan"), float("nan"), float("nan")
    position, rotation = solution.target_errors()
    return result.status, position, rotation, solution.energy


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("programs", nargs="*", type=Path, help="programs (default: the gallery)")
    parser.add_argument("--shift", type=float, default=1e-6, help="how far the world moves (mm; 1e-6)")
    args = parser.parse_args()
    programs = args.programs or sorted(GALLERY.glob("*.fhl"))
    columns = ["as written", "x", "y", "z", "spread"]
    write(f"{'program':26s} {' '.join(f'{c:>15s}' for c in columns)} {'J':>13s}     s")
    for path in programs:
        text = path.read_text()
        if not PLACED.search(text):
            write(f"{path.stem:26s} nothing placed to move")
            continue
        try:
            shifted = [moved(text, axis, args.shift) for axis in range(3)]
        except ValueError:
            write(f"{path.stem:26s} placed by expressions, not numbers: not moved")
            continue
        started = time.perf_counter()
        runs = [errors(path, program) for program in (text, *shifted)]
        seconds = time.perf_counter() - started
        _, positions, rotations, energies = zip(*runs, strict=True)
        cells = [f"{p:7.2f} {r:6.2f}" + ("" if status == "solved" else "*") for status, p, r, _ in runs]
        spread = f"{max(positions) - min(positions):7.2f} {max(rotations) - min(rotations):6.2f}"
        row = " ".join(f"{c:>15s}" for c in [*cells, spread])
        lowest = f"{min(energies):.3f}-{max(energies):.3f}"
        write(f"{path.stem:26s} {row} {lowest:>13s} {seconds:5.1f}")
    write("(mm and degrees from the request; * not solved; J: the rests' energies; s: the four solves)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
