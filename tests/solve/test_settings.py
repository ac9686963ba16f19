"""Settings the program writes (`set (...)` on a connection): held at their
values through every step, never chosen by the solver, listed as written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fabhal.report.solution import dof_rows
from tests.conftest import REPO
from tests.solve.test_physics import S_HOOK_ON_ROD, connector_world, solve_text


def test_a_written_place_on_a_rod_is_where_the_hook_hangs(tmp_path: Path) -> None:
    """An S-hook on a level 500 mm rod, its place written as t = 0.25: the
    contact is (0.25 - 0.5) x 500 = -125 mm along the rod from its middle,
    whatever the target asks (straight below the middle: the target then hangs
    125 mm from it, as a builder who hung it there would see). A level rod
    pulls nothing along it, so it is at rest there. Tolerance 1e-6 mm: the value
    is held exactly, the rod's frame is exact."""
    text = S_HOOK_ON_ROD.format(length=500, extra="", roll=90).replace(
        "connect s.hook2 -- rod", "connect s.hook2 -- rod set (rod.t: 0.25)"
    )
    result = solve_text(tmp_path, text)
    assert result.status == "solved"
    solution = result.solution
    rod_axis = np.array([1.0, 0.0, 0.0])  # rot (90, 0, 90): the rod's z along world x
    contact = connector_world(solution, 0, "b")[:3, 3]
    assert contact @ rod_axis == pytest.approx(-125.0, abs=1e-6)
    assert np.linalg.norm(solution.target_frame()[:3, 3] - np.array([0.0, 0.0, 260.0])) == pytest.approx(
        125.0, abs=0.5
    )
    (row,) = [r for r in dof_rows(solution) if r["name"] == "rod.rod.t"]
    assert row["role"] == "written" and row["value"] == 0.25


def test_a_written_grip_is_kept_and_not_aimed(tmp_path: Path) -> None:
    """The gallery's clip light M with the clip written at 0.3 along the
    hanger's bar: the solver aims the rest (the clip's own place on its jaw, the
    turn on the bar) but leaves the written value exactly, and its note of what
    it chose (N506) never names it."""
    program = Path(__file__).resolve().parents[2] / "programs" / "clip_light_m.fhl"
    text = program.read_text().replace(
        "connect light.clip -- hanger.rod fixed",
        "connect light.clip -- hanger.rod fixed set (hanger.rod.t: 0.3)",
    )
    (tmp_path / "lib").mkdir()
    for lib in (program.parent / "lib").glob("*.fhl"):
        (tmp_path / "lib" / lib.name).write_text(lib.read_text())
    result = solve_text(tmp_path, text)
    solution = result.solution
    index = next(i for i, v in enumerate(solution.model.variables) if v.name == "hanger.rod.t")
    assert solution.x[index] == 0.3
    aimed = [d for d in result.diagnostics if d.code == "N506"]
    assert all("along hanger.rod" not in d.message + d.help for d in aimed)


def test_what_aiming_chose_can_be_written_back(tmp_path: Path) -> None:
    """The demo: aiming places the S-hook on the hanger's bar (N506). Its help
    gives the line to write to keep that choice; written on the connection,
    the solve holds the value exactly and the hack hangs as the aimed one did
    (the rest is aimed again from there; within 1 mm of the aimed result's
    0.7 mm, as the same settings give the same rest)."""
    text = (REPO / "programs" / "demo.fhl").read_text()
    aimed = solve_text(tmp_path, text)
    (note,) = [d for d in aimed.diagnostics if d.code == "N506"]
    written = note.help.split("write it on its line: `")[1].split("`")[0]
    assert written.startswith("set (hanger.rod.t: ")
    line = "connect s.hook1 -- hanger.rod"
    kept = solve_text(tmp_path, text.replace(line, f"{line} {written}"))
    assert kept.status == "solved"
    solution = kept.solution
    index = next(i for i, v in enumerate(solution.model.variables) if v.name == "hanger.rod.t")
    assert solution.x[index] == float(written.split(": ")[1].rstrip(")"))
    requested = aimed.solution.goal.requested[:3, 3]
    offsets = [np.linalg.norm(r.solution.target_frame()[:3, 3] - requested) for r in (aimed, kept)]
    assert abs(offsets[1] - offsets[0]) < 1.0


def test_written_places_of_parts_sharing_a_rod_are_kept(tmp_path: Path) -> None:
    """Two S-hooks on one rod, written at t = 0.2 and 0.7: the solver spreads
    parts that share a primitive before fitting (all would start in its
    middle), and must spread only those the program leaves open. Found with a
    newcomer's hack: both written places were overwritten by the spread (0.331
    and 0.669) while --dofs said "written". On a 500 mm level rod the hooks
    hang 250 mm apart, (0.7 - 0.2) x 500, exactly."""
    result = solve_text(
        tmp_path,
        """\
environment rod = Rod(length: 500, radius: 2) at (0, 0, 300) rot (90, 0, 90)
s1 = DoubleHook()
s2 = DoubleHook()
connect s1.hook2 -- rod set (rod.t: 0.2)
connect s2.hook2 -- rod set (rod.t: 0.7)
target s1.hook1 at (0, 0, 260)
""",
    )
    assert result.status == "solved"
    solution = result.solution
    contacts = [connector_world(solution, j.index, "b")[:3, 3] for j in solution.model.joints]
    assert sorted(float(c[0]) for c in contacts) == pytest.approx([-150.0, 100.0], abs=1e-6)
