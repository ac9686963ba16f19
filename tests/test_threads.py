"""FabHaL pins the numeric libraries to one thread before numpy loads (see
fabhal/__init__.py): faster on small matrices, and the same result whatever
thread settings the user's environment has."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.cli.test_check_command import fabhal
from tests.conftest import REPO

MANY_THREADS = {**os.environ, "OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"}


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc (Linux)")
def test_numpy_loaded_by_fabhal_runs_one_thread() -> None:
    """OpenBLAS starts its thread pool when it loads; with the pin the process has
    its main thread only, even when the environment asks for more."""
    count = "import os; print(len(os.listdir('/proc/self/task')))"
    pinned = subprocess.run(
        [sys.executable, "-c", f"import fabhal, numpy; {count}"],
        env=MANY_THREADS,
        capture_output=True,
        text=True,
    )
    assert pinned.stdout.strip() == "1", pinned.stderr
    unpinned = subprocess.run(
        [sys.executable, "-c", f"import numpy; {count}"], env=MANY_THREADS, capture_output=True, text=True
    )
    assert int(unpinned.stdout) > 1  # the check above can tell the difference


def test_results_do_not_depend_on_the_environments_thread_settings() -> None:
    # the most DoFs (65), the largest matrices; step 1 and the check only (its settle takes 12 s)
    program = "programs/reading_nook.fhl"
    default = fabhal("solve", "--json", "--no-gravity", program)
    many = subprocess.run(
        [sys.executable, "-m", "fabhal", "solve", "--json", "--no-gravity", program],
        cwd=REPO,
        env=MANY_THREADS,
        capture_output=True,
        text=True,
        timeout=120,
    )
    timing = re.compile(r'"timing": \{[^}]*\}')
    assert timing.sub("", default.stdout) == timing.sub("", many.stdout)


SOLVED_X = """\
import sys
{first}
from pathlib import Path
from fabhal import api
from threadpoolctl import threadpool_info
result = api.solve(Path("bench/programs/hoop_12_chains.fhl"))
print(max(pool["num_threads"] for pool in threadpool_info()))
print(result.status, result.solution.x.tobytes().hex())
"""


def test_numpy_loaded_before_fabhal_runs_one_thread_too() -> None:
    """A script or a test run that imports numpy first has its BLAS threaded
    before FabHaL's variables can say otherwise; FabHaL then limits it
    (threadpoolctl). The hoop on twelve chains (131 DoFs: matrices large
    enough for OpenBLAS to split) solved that way differed from the command
    line's by 144 degrees in one turn; now both run one thread and agree to
    the bit."""
    outputs = []
    for first in ("import numpy", ""):
        run = subprocess.run(
            [sys.executable, "-c", SOLVED_X.format(first=first)],
            cwd=REPO,
            env=MANY_THREADS,
            capture_output=True,
            text=True,
            timeout=300,
        )
        threads, solved = run.stdout.split("\n")[:2]
        assert threads == "1", run.stderr
        outputs.append(solved)
    assert outputs[0] == outputs[1]
