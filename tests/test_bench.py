"""The benchmark harness runs and records what it measured (no speed is asserted here:
speed targets are read off `fabhal bench`, never timed in tests)."""

from __future__ import annotations

import json
from pathlib import Path

from fabhal import bench
from tests.cli.test_check_command import fabhal
from tests.conftest import REPO


def test_bench_records_each_stage_and_the_targets(tmp_path: Path) -> None:
    out = tmp_path / "results.json"
    rows = bench.run([REPO / "programs" / "charger_holder.fhl"], runs=2, output=out, whole_process=True)
    (row,) = rows
    assert (row.program, row.loops, row.status) == ("charger_holder", 1, "solved")
    assert row.solve_target_s == bench.SOLVE_WITH_LOOPS_TARGET_S  # it has a loop
    assert 0 < row.parse_s and 0 < row.check_s and 0 < row.solve_s
    assert row.process_s is not None and row.process_s > row.solve_s  # a process also starts Python
    assert row.cold_process_s is not None and row.cold_process_s > row.solve_s
    data = json.loads(out.read_text())
    assert data["runs"] == 2 and data["machine"]["cpus"] >= 1
    (recorded,) = data["rows"]
    assert recorded["program"] == "charger_holder" and recorded["meets_targets"] == row.meets_targets


def test_the_clip_light_family_is_one_extra_row(tmp_path: Path) -> None:
    programs = [REPO / "programs" / f"{name}.fhl" for name in bench.FAMILY]
    rows = bench.run(programs, runs=1, output=None, whole_process=False)
    assert [r.program for r in rows[:4]] == list(bench.FAMILY)
    family = rows[4]
    assert family.program.startswith("clip_light_*")
    # the family row solves the same four programs again: about their sum (within 3x either way)
    single = sum(r.solve_s for r in rows[:4])
    assert single / 3 < family.solve_s < single * 3


def test_bench_command_prints_the_table(tmp_path: Path) -> None:
    out = tmp_path / "b.json"
    run = fabhal("bench", "-n", "1", "--no-process", "programs/demo.fhl", "-o", str(out))
    assert run.returncode == 0, run.stderr
    assert "demo" in run.stdout and "solve ms" in run.stdout
    recorded = json.loads(out.read_text())["rows"][0]
    assert recorded["process_s"] is None and recorded["cold_process_s"] is None


def test_bench_command_refuses_a_missing_program() -> None:
    run = fabhal("bench", "programs/nope.fhl")
    assert run.returncode == 2 and "cannot read programs/nope.fhl" in run.stderr
