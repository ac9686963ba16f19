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
from fabhal.primitives import CONNECTABLE
from fabhal.syntax import ast
from tests.conftest import REPO

QUICK_EXAMPLES = 20  # per strategy, in every test run
# per strategy, with -m fuzz: 10,000 programs in all (FABHAL_FUZZ_EXAMPLES sets another number)
LONG_EXAMPLES = int(os.environ.get("FABHAL_FUZZ_EXAMPLES", "5000"))
HANG_SECONDS = 60  # a run that lasts this long under --time-limit 5 hangs

GALLERY = sorted((REPO / "programs").glob("*.fhl"))


@cache
def library() -> dict[str, list[tuple[str, str]]]:
    """Every library part without parameters: its primitives' (name, kind)."""
    parts = api.part_library().library.parts
    return {
        name: [(d.name, d.kind) for d in t.definition.items if isinstance(d, ast.PrimitiveDecl)]
        for name, t in sorted(parts.items())
        if not t.parameters
    }


# ---------------------------------------------------------------- generated programs

EXTREME = st.sampled_from(["0", "1e6", "-1e6", "999999.9", "1e-9", "1e400", "1e308 * 10", "0.0001", "-720"])


def mostly(sensible: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    """What a user writes, and one time in 40 a mistake or an extreme."""
    return st.integers(0, 39).flatmap(lambda k: EXTREME if k == 0 else sensible)


SIZES = mostly(st.integers(1, 600).map(str))
COORDINATES = mostly(st.integers(-500, 1500).map(str))
ANGLES = mostly(st.one_of(st.sampled_from(["0", "90", "180", "-90", "45"]), st.integers(-360, 360).map(str)))
BARE = {
    "Rod": "radius: {a}, length: {b}",
    "Surface": "width: {a}, length: {b}",
    "Edge": "width: {a}, length: {b}, height: {c}",
    "Hemisphere": "radius: {a}",
}
End = tuple[str, str]  # `part.primitive` as written, and the primitive's kind


def frame(draw: st.DrawFn) -> str:
    at = f"at ({draw(COORDINATES)}, {draw(COORDINATES)}, {draw(COORDINATES)})"
    return at + (f" rot ({draw(ANGLES)}, {draw(ANGLES)}, {draw(ANGLES)})" if draw(st.booleans()) else "")


def pair(draw: st.DrawFn, ends: list[End], placed: list[End]) -> tuple[str, str]:
    """Two ends to connect: nine times in ten a pair the connectivity table allows."""
    fitting = [(a, b) for a in ends for b in placed if frozenset((a[1], b[1])) in CONNECTABLE]
    if fitting and draw(st.integers(0, 9)):
        a, b = draw(st.sampled_from(fitting))
    else:
        a, b = draw(st.sampled_from(ends)), draw(st.sampled_from(placed))
    return a[0], b[0]


@st.composite
def generated_program(draw: st.DrawFn) -> str:
    """A program as a user might write one: environments, parts hung one below
    another (each from an end of what is already placed, mostly one that fits),
    a few extra connections that may close loops or be wrong, a loop, a
    parameter, an import, a target; numbers mostly sensible, now and then extreme."""
    parts = library()
    lines: list[str] = []
    placed: list[End] = []  # connectable ends of what hangs from an environment
    if draw(st.booleans()):
        kind = draw(st.sampled_from(sorted(BARE)))
        args = BARE[kind].format(a=draw(SIZES), b=draw(SIZES), c=draw(SIZES))
        lines.append(f"environment env = {kind}({args}) {frame(draw)}")
        placed.append(("env", kind.lower()))
    for k in range(draw(st.integers(0 if placed else 1, 2))):
        name = draw(st.sampled_from(sorted(parts)))
        lines.append(f"environment fixed{k} = {name}() {frame(draw)}")
        placed += [(f"fixed{k}.{p}", kind) for p, kind in parts[name]]
    if draw(st.booleans()) and any(kind == "rod" for _, kind in placed):
        lines.append(f"param n in 1 .. {draw(st.integers(0, 5))} = {draw(st.integers(1, 5))}")
        lines += ["link = " + next(e for e, kind in placed if kind == "rod"), "for i in 1 .. n {"]
        lines += ["  h[i] = DoubleHook()", "  connect h[i].hook2 -- link", "  link = h[i].hook1", "}"]
    if draw(st.booleans()):
        lines.append('import "lib/s_hook_chain.fhl"')
        lines.append(f"chain = SHookChain(n: {draw(st.integers(0, 9))})")
        lines.append(
            f"connect {pair(draw, [('chain.top', 'hook')], placed)[0]} -- {draw(st.sampled_from(placed))[0]}"
        )
        placed.append(("chain.bottom", "hook"))
    movable: list[str] = []
    for k in range(draw(st.integers(1, 4))):
        name = draw(st.sampled_from(sorted(parts)))
        lines.append(f"p{k} = {name}()")
        ends = [(f"p{k}.{p}", kind) for p, kind in parts[name]]
        a, b = pair(draw, ends, placed)
        lines.append(f"connect {a} -- {b}" + draw(st.sampled_from(["", "", "", " flip", " fixed"])))
        placed += ends
        movable += [e for e, _ in ends]
    for _ in range(draw(st.integers(0, 2))):  # loops, or mistakes
        a, b = pair(draw, placed, placed)
        lines.append(f"connect {a} -- {b}")
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
            primitive = draw(st.sampled_from(sorted({name for ps in library().values() for name, _ in ps})))
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
    assert result["status"] in ("solved", "falls_apart", "not_at_rest", "infeasible", "out_of_time", "error")
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
