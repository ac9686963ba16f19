"""Inputs a new user writes by mistake: each gets a located diagnostic and exit 1,
never an internal error, and no NaN or infinity reaches any output."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fabhal import api
from tests.cli.test_check_command import fabhal

ROD = "environment rod = Rod(length: {length}, radius: 2) at (0, 0, {z}) rot (90, 0, 90)\n"
HACK = "s1 = DoubleHook()\nconnect s1.hook2 -- rod\ntarget s1.hook1 at (0, 0, 50)\n"


def program(length: str = "500", z: str = "200", rest: str = HACK) -> str:
    return ROD.format(length=length, z=z) + rest


@pytest.mark.parametrize(
    ("text", "code", "column"),
    [
        (program(z="1e400"), "E224", 57),  # overflows to infinity as a literal
        (program(z="1e400 - 1e400"), "E224", 57),  # inf - inf would be NaN: the literal is caught first
        (program(z="1e308 * 10"), "E224", 57),  # finite literals, infinite product
        (program(z="1e300"), "E224", 57),  # finite, but its square is not
        (program(z="tan(90)"), "E224", 57),  # 1.6e16: the tangent's pole
        (program(length="1e400"), "E224", 31),
        (program(z="nan"), "E220", 57),  # not a number literal: an unknown name
        (program(z="inf"), "E220", 57),
    ],
)
def test_numbers_out_of_range_are_errors_where_written(
    tmp_path: Path, text: str, code: str, column: int
) -> None:
    path = tmp_path / "p.fhl"
    path.write_text(text)
    result = api.check(path)
    assert not result.ok
    (problem,) = [d for d in result.diagnostics if d.severity.value == "error"]
    assert (problem.code, problem.span.line, problem.span.column) == (code, 1, column)


def test_solve_of_an_overflowing_program_exits_1_without_nan(tmp_path: Path) -> None:
    (tmp_path / "p.fhl").write_text(program(length="1e400", z="1e400 - 1e400"))
    run = fabhal("solve", "--json", "p.fhl", cwd=tmp_path)
    assert run.returncode == 1
    assert "internal error" not in run.stderr
    data = json.loads(run.stdout)  # strict JSON: NaN or Infinity would not parse with this hook
    json.loads(run.stdout, parse_constant=lambda c: pytest.fail(f"{c} in the output"))
    assert data["status"] == "error" and {d["code"] for d in data["diagnostics"]} == {"E224"}


def test_a_binding_that_is_not_a_number_is_outside_every_domain(tmp_path: Path) -> None:
    (tmp_path / "p.fhl").write_text("param h in linspace(100, 300, 5) = 200\n" + program(z="h"))
    for value in ("nan", "inf", "1e400"):
        result = api.check(tmp_path / "p.fhl", {"h": value})
        assert [d.code for d in result.diagnostics] == ["E310"], value


def test_a_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    (tmp_path / "p.fhl").write_bytes(b"\xef\xbb\xbf" + program().encode())
    result = api.check(tmp_path / "p.fhl")
    assert result.ok, result.diagnostics
    broken = program().replace("--", "")
    (tmp_path / "bad.fhl").write_bytes(b"\xef\xbb\xbf" + broken.encode())
    (tmp_path / "plain.fhl").write_text(broken)
    (with_mark, *_) = api.check(tmp_path / "bad.fhl").diagnostics
    (without, *_) = api.check(tmp_path / "plain.fhl").diagnostics
    assert with_mark.code == "E101"
    assert (with_mark.span.line, with_mark.span.column) == (without.span.line, without.span.column)


def test_targeting_an_environment_is_an_error_that_says_why(tmp_path: Path) -> None:
    (tmp_path / "p.fhl").write_text(
        program(rest="s1 = DoubleHook()\nconnect s1.hook2 -- rod\ntarget rod at (0, 0, 0)\n")
    )
    result = api.check(tmp_path / "p.fhl")
    assert [(d.code, d.span.line) for d in result.diagnostics] == [("E417", 4)]
    assert "is an environment" in result.diagnostics[0].message


def test_a_runaway_loop_is_an_error_not_a_hang(tmp_path: Path) -> None:
    loop = (
        "link = rod\nfor i in 1 .. 1000000 {\n  s[i] = DoubleHook()\n"
        "  connect s[i].hook2 -- link\n  link = s[i].hook1\n}\n"
    )
    (tmp_path / "p.fhl").write_text(program(rest=loop + "target s[1].hook1 at (0, 0, 50)\n"))
    result = api.check(tmp_path / "p.fhl")
    assert ("E312", 3, 10) in [(d.code, d.span.line, d.span.column) for d in result.diagnostics]


def test_nested_loops_share_one_budget(tmp_path: Path) -> None:
    """50 x 50 = 2,500 passes of the inner loop, over the 2,000 of the budget, although
    each loop alone is short."""
    loops = "for i in 1 .. 50 {\n  for j in 1 .. 50 {\n    x = rod\n  }\n}\n"
    (tmp_path / "p.fhl").write_text(program(rest=HACK + loops))
    assert "E312" in [d.code for d in api.check(tmp_path / "p.fhl").diagnostics]


def test_a_huge_param_domain_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "p.fhl").write_text("param e in linspace(0, 1, 100000) = 0\n" + program())
    (problem,) = api.check(tmp_path / "p.fhl").diagnostics
    assert (problem.code, problem.span.line, problem.span.column) == ("E312", 1, 27)


def test_an_assembly_that_contains_itself_is_an_error(tmp_path: Path) -> None:
    text = "assembly Chain {\n  link = Chain()\n}\n" + program() + "c = Chain()\n"
    (tmp_path / "p.fhl").write_text(text)
    codes = [(d.code, d.span.line) for d in api.check(tmp_path / "p.fhl").diagnostics]
    assert ("E313", 2) in codes


def test_a_problem_inside_a_loop_is_reported_once_with_its_pass_count(tmp_path: Path) -> None:
    text = (
        "environment ceiling = CeilingHook() at (0, 0, 1000)\nlink = ceiling.hook\n"
        "for i in 1 .. 3 {\n  tb[i] = Turnbuckle(extension: 10)\n  r[i] = RingS()\n"
        "  connect tb[i].hook1 -- link\n  connect r[i].ring -- tb[i].hook2\n  link = r[i].ring\n}\n"
        "target r[3].ring at (0, 0, 500)\n"
    )
    (tmp_path / "p.fhl").write_text(text)
    (problem,) = api.check(tmp_path / "p.fhl").diagnostics
    assert (problem.code, problem.span.line, problem.span.column) == ("E211", 4, 22)
    assert "reached 3 times" in problem.notes[0]
    assert "`ParamTurnbuckle` takes `extension` (0 .. 45.7)" in (problem.help or "")
