"""Whole-pipeline fuzzing: `fabhal check` and `fabhal solve --time-limit 5` on
generated programs and on mutated gallery programs always end with a result or
diagnostics: never a traceback, an internal error, an exit status other than
0/1/2, a hang, or a NaN in the output.

A normal run tries a few dozen programs (seconds). The opt-in marker runs the
long campaign docs/robustness.md reports on:

    python3 -m pytest -m fuzz tests/test_robustness_fuzz.py     # 10,000 programs
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import signal
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from fabhal import api, cli
from tests.conftest import REPO

QUICK_EXAMPLES = 20  # per strategy, in every test run
# per strategy, with -m fuzz: 10,000 programs in all (FABHAL_FUZZ_EXAMPLES sets another number)
LONG_EXAMPLES = int(os.environ.get("FABHAL_FUZZ_EXAMPLES", "5000"))
HANG_SECONDS = 60  # a run that lasts this long under --time-limit 5 hangs

GALLERY = sorted((REPO / "programs").glob("*.fhl"))


@cache
def library() -> dict[str, list[str]]:
    """Every library part and its primitives' names."""
    parts = api.part_library().library.parts
    return {name: t.primitive_names() for name, t in sorted(parts.items()) if not t.parameters}


# ---------------------------------------------------------------- generated programs

EXTREME = st.sampled_from(["0", "1e6", "-1e6", "999999.9", "1e-9", "1e400", "1e308 * 10", "0.0001", "-720"])
# mostly what a user writes, now and then a mistake or an extreme
SIZES = st.one_of(st.integers(1, 600).map(str), st.integers(1, 600).map(str), EXTREME)
COORDINATES = st.one_of(st.integers(-500, 1500).map(str), st.integers(-500, 1500).map(str), EXTREME)
ANGLES = st.one_of(st.sampled_from(["0", "90", "180", "-90", "45"]), st.integers(-360, 360).map(str), EXTREME)
BARE = {
    "Rod": "radius: {a}, length: {b}",
    "Surface": "width: {a}, length: {b}",
    "Edge": "width: {a}, length: {b}, height: {c}",
    "Hemisphere": "radius: {a}",
}


def frame(draw: st.DrawFn) -> str:
    at = f"at ({draw(COORDINATES)}, {draw(COORDINATES)}, {draw(COORDINATES)})"
    return at + (f" rot ({draw(ANGLES)}, {draw(ANGLES)}, {draw(ANGLES)})" if draw(st.booleans()) else "")


@st.composite
def generated_program(draw: st.DrawFn) -> str:
    """A program as a user might write one: environments, parts hung one below
    another (each from an open end of what is already placed), a few extra
    connections that may close loops or be wrong, a loop, a parameter, an
    import, a target; numbers mostly sensible, now and then extreme."""
    parts = library()
    lines: list[str] = []
    placed: list[str] = []  # connectable ends of what hangs from an environment
    if draw(st.booleans()):
        kind = draw(st.sampled_from(sorted(BARE)))
        args = BARE[kind].format(a=draw(SIZES), b=draw(SIZES), c=draw(SIZES))
        lines.append(f"environment env = {kind}({args}) {frame(draw)}")
        placed.append("env")
    for k in range(draw(st.integers(0 if placed else 1, 2))):
        name = draw(st.sampled_from(sorted(parts)))
        lines.append(f"environment fixed{k} = {name}() {frame(draw)}")
        placed += [f"fixed{k}.{p}" for p in parts[name]]
    if draw(st.booleans()):
        lines.append(f"param n in 1 .. {draw(st.integers(0, 5))} = {draw(st.integers(0, 5))}")
        lines += ["link = " + placed[0], "for i in 1 .. n {", "  h[i] = DoubleHook()"]
        lines += ["  connect h[i].hook2 -- link", "  link = h[i].hook1", "}"]
    if draw(st.booleans()):
        lines.append('import "lib/s_hook_chain.fhl"')
        lines.append(f"chain = SHookChain(n: {draw(st.integers(0, 9))})")
        lines.append(f"connect chain.top -- {draw(st.sampled_from(placed))}")
        placed.append("chain.bottom")
    movable: list[str] = []
    for k in range(draw(st.integers(1, 4))):
        name = draw(st.sampled_from(sorted(parts)))
        lines.append(f"p{k} = {name}()")
        ends = [f"p{k}.{p}" for p in parts[name]]
        option = draw(st.sampled_from(["", "", " flip", " fixed"]))
        lines.append(f"connect {draw(st.sampled_from(ends))} -- {draw(st.sampled_from(placed))}{option}")
        placed += ends
        movable += ends
    for _ in range(draw(st.integers(0, 2))):  # loops, or mistakes
        lines.append(f"connect {draw(st.sampled_from(placed))} -- {draw(st.sampled_from(placed))}")
    lines.append(f"target {draw(st.sampled_from(movable))} {frame(draw)}")
    return "\n".join(draw(st.permutations(lines)) if draw(st.integers(0, 19)) == 0 else lines) + "\n"


# ---------------------------------------------------------------- mutated gallery programs

NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e-?\d+)?")


@st.composite
def mutated_gallery_program(draw: st.DrawFn) -> tuple[str, str]:
    path = draw(st.sampled_from(GALLERY))
    lines = path.read_text().splitlines()
    for _ in range(draw(st.integers(1, 3))):
        if not lines:
            break
        k = draw(st.integers(0, len(lines) - 1))
        action = draw(st.sampled_from(["delete", "duplicate", "swap primitive", "extreme number", "flip"]))
        if action == "delete":
            del lines[k]
        elif action == "duplicate":
            lines.insert(k, lines[k])
        elif action == "swap primitive":
            primitive = draw(st.sampled_from(sorted({p for ps in library().values() for p in ps})))
            lines[k] = re.sub(r"\.(\w+)\b", "." + primitive, lines[k], count=1)
        elif action == "extreme number":
            extreme = draw(st.sampled_from(["0", "-1", "1e6", "-1e6", "1e400", "0.000001", "45.7001", "99"]))
            lines[k] = NUMBER.sub(extreme, lines[k], count=1)
        elif lines[k].startswith("connect"):
            lines[k] += " flip"
    return path.name, "\n".join(lines) + "\n"


# ---------------------------------------------------------------- the property


@contextlib.contextmanager
def hang_alarm(seconds: int) -> Iterator[None]:
    def hung(signum: int, frame: object) -> None:
        raise TimeoutError(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def run_fabhal(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), hang_alarm(HANG_SECONDS):
        status = cli.main(list(args))
    return status, out.getvalue(), err.getvalue()


def assert_ends_well(text: str, directory: Path) -> None:
    program = directory / "fuzz.fhl"
    program.write_text(text)
    status, out, err = run_fabhal("check", "--json", str(program))
    assert status in (0, 1), err
    assert "internal error" not in err, f"{err}\n--- program:\n{text}"
    json.loads(out, parse_constant=lambda c: pytest.fail(f"{c} in check output"))
    status, out, err = run_fabhal("solve", "--json", "--time-limit", "5", str(program))
    assert status in (0, 1), f"exit {status}: {err}\n--- program:\n{text}"
    assert "internal error" not in err, f"{err}\n--- program:\n{text}"
    result = json.loads(out, parse_constant=lambda c: pytest.fail(f"{c} in solve output:\n{text}"))
    assert result["status"] in ("solved", "falls_apart", "infeasible", "out_of_time", "error")
    assert (status == 0) == (result["status"] == "solved")
    event(f"solve: {result['status']}")  # the campaign's statistics (--hypothesis-show-statistics)
    for code in sorted({d["code"] for d in result["diagnostics"]}):
        event(f"diagnostic {code}")


def quick(examples: int) -> settings:
    return settings(
        max_examples=examples,
        deadline=None,
        derandomize=examples == QUICK_EXAMPLES,  # the everyday run tries the same programs each time
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


@quick(QUICK_EXAMPLES)
@given(generated_program())
def test_generated_programs_end_well(tmp_path: Path, text: str) -> None:
    assert_ends_well(text, tmp_path)


@quick(QUICK_EXAMPLES)
@given(mutated_gallery_program())
def test_mutated_gallery_programs_end_well(tmp_path: Path, case: tuple[str, str]) -> None:
    assert_ends_well(case[1], tmp_path)


@pytest.mark.fuzz
@quick(LONG_EXAMPLES)
@given(generated_program())
def test_generated_programs_end_well_long(tmp_path: Path, text: str) -> None:
    assert_ends_well(text, tmp_path)


@pytest.mark.fuzz
@quick(LONG_EXAMPLES)
@given(mutated_gallery_program())
def test_mutated_gallery_programs_end_well_long(tmp_path: Path, case: tuple[str, str]) -> None:
    assert_ends_well(case[1], tmp_path)
