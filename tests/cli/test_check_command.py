"""`fabhal check` end to end, as a subprocess: exit codes, output, never a traceback."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.conftest import REPO

GOLDEN = REPO / "tests" / "syntax" / "golden"


def fabhal(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fabhal", *args], cwd=cwd, capture_output=True, text=True, timeout=60
    )


def test_clean_program_exits_zero() -> None:
    run = fabhal("check", "programs/mug_hanger.fhl")
    assert run.returncode == 0, run.stderr
    assert "programs/mug_hanger.fhl: ok" in run.stdout
    assert run.stderr == ""


def test_syntax_errors_exit_one_with_located_messages() -> None:
    run = fabhal("check", str(GOLDEN.relative_to(REPO) / "several_errors.fhl"))
    assert run.returncode == 1
    assert "tests/syntax/golden/several_errors.fhl:3:18: error[E101]" in run.stderr
    assert "help:" in run.stderr
    assert "Traceback" not in run.stderr + run.stdout


def test_json_output_lists_every_diagnostic_with_its_position() -> None:
    run = fabhal("check", "--json", str(GOLDEN / "several_errors.fhl"))
    assert run.returncode == 1
    diagnostics = json.loads(run.stdout)
    assert [d["code"] for d in diagnostics] == ["E103", "E111", "E101", "E110"]
    first = diagnostics[0]
    expected_keys = {
        "severity",
        "code",
        "message",
        "file",
        "line",
        "column",
        "end_line",
        "end_column",
        "help",
    }
    assert expected_keys <= set(first)
    assert (first["line"], first["column"], first["end_line"], first["end_column"]) == (1, 1, 1, 7)


def test_missing_file_is_a_usage_error(tmp_path: Path) -> None:
    run = fabhal("check", str(tmp_path / "nope.fhl"))
    assert run.returncode == 2
    assert "no such file" in run.stderr and "Traceback" not in run.stderr


def test_non_utf8_file_is_an_io_error(tmp_path: Path) -> None:
    bad = tmp_path / "latin1.fhl"
    bad.write_bytes("s1 = DoubleHook() # caf\xe9\n".encode("latin-1"))
    run = fabhal("check", str(bad))
    assert run.returncode == 2
    assert "not UTF-8" in run.stderr


def test_directory_is_an_io_error(tmp_path: Path) -> None:
    run = fabhal("check", str(tmp_path))
    assert run.returncode == 2 and "is a directory" in run.stderr


def test_missing_import_points_at_the_import_line(tmp_path: Path) -> None:
    program = tmp_path / "p.fhl"
    program.write_text('s1 = DoubleHook()\nimport "lib/nothing.fhl"\n')
    run = fabhal("check", str(program))
    assert run.returncode == 1
    assert f"{program}:2:1: error[E003]" in run.stderr


def test_imports_resolve_relative_to_the_importing_file(tmp_path: Path) -> None:
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "chain.fhl").write_text('import "../p.fhl"\n')  # a cycle is fine
    program = tmp_path / "p.fhl"
    program.write_text('import "lib/chain.fhl"\n' + (REPO / "programs" / "demo.fhl").read_text())
    run = fabhal("check", str(program))
    assert run.returncode == 0, run.stderr


def test_usage_errors_exit_two_and_teach() -> None:
    run = fabhal("check")
    assert run.returncode == 2
    assert "--help" in run.stderr


def test_help_teaches_by_example() -> None:
    run = fabhal("check", "--help")
    assert run.returncode == 0
    assert "examples:" in run.stdout and "fabhal check programs/mug_hanger.fhl" in run.stdout
    top = fabhal("--help")
    assert "examples:" in top.stdout and "check" in top.stdout


def test_define_binds_a_parameter(tmp_path: Path) -> None:
    program = tmp_path / "family.fhl"
    program.write_text(
        "param n in 1 .. 4 = 2\nenvironment ceiling = CeilingHook() at (0, 0, 1000)\nlink = ceiling.hook\n"
        "for i in 1 .. n {\n  s[i] = DoubleHook()\n  connect s[i].hook2 -- link\n  link = s[i].hook1\n}\n"
        "target s[1].hook1 at (0, 0, 900)\n"
    )
    assert fabhal("check", "-D", "n=3", str(program)).returncode == 0
    bad = fabhal("check", "-D", "n=9", str(program))
    assert bad.returncode == 1
    assert "error[E310]: -D n=9 is outside the domain of `n`" in bad.stderr
    assert bad.stderr.count("error[") == 1  # no cascade from the rejected value
    assert fabhal("check", "-D", "n", str(program)).returncode == 2
