"""Benchmark every gallery program: `python bench/run.py [-n RUNS] [PROGRAM ...]`.

The same as `fabhal bench`; see bench/README.md for what the numbers mean.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from fabhal.cli import main

if __name__ == "__main__":
    raise SystemExit(main(["bench", *sys.argv[1:]]))
