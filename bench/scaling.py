"""How the solver scales with the number of parts (issue 15):
`python bench/scaling.py [--sizes 5,50,100] [--time-limit S]`.

Solves bench/programs/s_hook_chain.fhl for each chain length n (n S-hooks
hung from a rod) and bench/programs/hoop_12_chains.fhl (a hoop hung by 12
chains, 11 loops), each once in this process after a warm-up solve (so the
grids and the library are loaded), and prints the solve time, the status and
the number of DoFs. Targets (issue 15): 100 S-hooks and the 12-chain hoop
each under 2 s. Results in bench/README.md ("Scaling").
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a checkout without installing

from fabhal import api  # noqa: E402

TARGET_S = 2.0


def timed(path: Path, bindings: dict[str, str], time_limit: float) -> tuple[float, str, int]:
    started = time.perf_counter()
    result = api.solve(path, bindings, time_limit=time_limit)
    dofs = len(result.solution.model.variables) if result.solution is not None else 0
    return time.perf_counter() - started, result.status, dofs


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="5,50,100", help="chain lengths (default 5,50,100)")
    parser.add_argument("--time-limit", type=float, default=120.0, help="per solve, seconds (default 120)")
    args = parser.parse_args()
    chain = HERE / "programs" / "s_hook_chain.fhl"
    timed(chain, {"n": "2"}, args.time_limit)  # warm-up: library, grids
    cases = [(f"s_hook_chain n={n}", chain, {"n": n}) for n in args.sizes.split(",")]
    cases.append(("hoop_12_chains", HERE / "programs" / "hoop_12_chains.fhl", {}))
    sys.stdout.write(f"{'case':24s} {'DoFs':>5s} {'solve s':>8s}  status (target {TARGET_S:g} s)\n")
    for name, path, bindings in cases:
        seconds, status, dofs = timed(path, bindings, args.time_limit)
        sys.stdout.write(f"{name:24s} {dofs:5d} {seconds:8.2f}  {status}\n")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
