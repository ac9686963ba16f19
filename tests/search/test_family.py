"""A program's family (elaborate.family): every combination of its params'
values, in the order `fabhal search` solves and reports them."""

from __future__ import annotations

from pathlib import Path

from fabhal.elaborate import FAMILY_MEMBER_LIMIT, family
from fabhal.load import load_program
from tests.conftest import REPO

FAMILY = REPO / "programs" / "clip_light_family.fhl"


def members_of(text: str, tmp_path: Path, pinned: dict[str, str] | None = None):  # type: ignore[no-untyped-def]
    program = tmp_path / "family.fhl"
    program.write_text(text)
    return family(load_program(program), pinned)


def test_the_clip_light_study_is_336_members_the_last_param_fastest() -> None:
    members, problems = family(load_program(FAMILY))
    assert problems == []
    assert len(members) == 4 * 4 * 21
    assert members[0] == {"ring": "RingXS", "n": "1", "extension": "0"}
    assert members[1] == {"ring": "RingXS", "n": "1", "extension": "2.285"}
    assert members[-1] == {"ring": "RingL", "n": "4", "extension": "45.7"}
    # linspace values as a person writes them: 7 x 2.285 is 15.995, not 15.995000000000001
    assert members[7]["extension"] == "15.995"


def test_pinned_params_narrow_the_family_and_an_unknown_one_is_named() -> None:
    program = load_program(FAMILY)
    members, problems = family(program, {"ring": "RingS", "n": "4"})
    assert problems == [] and len(members) == 21
    assert {m["ring"] for m in members} == {"RingS"} and {m["n"] for m in members} == {"4"}
    members, problems = family(program, {"n": "9"})  # said once, not once per member
    assert members == [] and [(d.code, d.message) for d in problems] == [
        ("E310", "-D n=9 is outside the domain of `n`")
    ]
    members, problems = family(program, {"rings": "RingS"})
    assert members == []
    assert problems[0].code == "E310" and "`param rings`" in problems[0].message
    assert problems[0].help == "its parameters: ring, n, extension"


def test_a_domain_may_use_the_params_declared_above_it(tmp_path: Path) -> None:
    members, problems = members_of("param n in 1 .. 3\nparam k in 1 .. n\n", tmp_path)
    assert problems == []
    # 1 + 2 + 3 combinations with k at most n
    assert [(m["n"], m["k"]) for m in members] == [
        ("1", "1"), ("2", "1"), ("2", "2"), ("3", "1"), ("3", "2"), ("3", "3"),
    ]  # fmt: skip


def test_a_runaway_family_is_an_error_not_a_hang(tmp_path: Path) -> None:
    text = "param a in 1 .. 100\nparam b in 1 .. 100\nparam c in 1 .. 11\n"  # 110,000 members
    members, problems = members_of(text, tmp_path)
    assert members == [] and problems[0].code == "E312"
    assert f"more than {FAMILY_MEMBER_LIMIT:,} members" in problems[0].message
    assert "--sample" in (problems[0].help or "")


def test_a_program_without_params_is_one_member(tmp_path: Path) -> None:
    members, problems = members_of("environment rod = Rod(length: 100, radius: 2) at (0, 0, 0)\n", tmp_path)
    assert (members, problems) == ([{}], [])
