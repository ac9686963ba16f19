"""Every `fhl` block in the README and docs/language.md runs and does what its text
says. A whole program (an environment and a target) is solved and must carry an
`<!-- expect: ... -->` comment after its block, which is asserted; a fragment is
checked and may only lack what the rest of a program would give it (docs/errors.md
has its own test: each example produces the code it documents)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fabhal import api
from tests.conftest import REPO

DOCUMENTS = [REPO / "README.md", REPO / "docs" / "language.md"]
BLOCK = re.compile(r"```fhl\n(.*?)```(?:\n<!-- expect: (.*?) -->)?", re.S)
CLAIM = re.compile(r"(solved|falls_apart), within ([\d.]+) mm and ([\d.]+) degrees?$")
# what a fragment lacks by being a fragment: a target, an environment, the
# declarations of names it uses, connections to what is elsewhere
INCOMPLETE = {"E302", "E406", "E408", "E409", "E410", "W411", "W413"}


def blocks() -> list[tuple[str, str, str | None]]:
    found = []
    for document in DOCUMENTS:
        text = document.read_text()
        for match in BLOCK.finditer(text):
            line = text[: match.start()].count("\n") + 1
            found.append((f"{document.name}:{line}", match.group(1), match.group(2)))
    return found


def is_whole_program(code: str) -> bool:
    return bool(re.search(r"^environment ", code, re.M) and re.search(r"^target ", code, re.M))


EXAMPLES = blocks()


@pytest.mark.parametrize(("where", "code", "claim"), EXAMPLES, ids=[w for w, _, _ in EXAMPLES])
def test_example(where: str, code: str, claim: str | None, tmp_path: Path) -> None:
    program = tmp_path / "example.fhl"
    program.write_text(code)
    if not is_whole_program(code):
        assert claim is None, f"{where}: a fragment cannot be solved, so it states no result"
        result = api.check(program)
        unexpected = [d for d in result.diagnostics if d.code not in INCOMPLETE]
        assert not unexpected, f"{where}: {unexpected}"
        return
    assert claim is not None, f"{where}: a whole program states what it does in <!-- expect: ... -->"
    parsed = CLAIM.match(claim.strip())
    assert parsed, f"{where}: cannot read the claim {claim!r}"
    status, position_mm, rotation_deg = parsed.group(1), float(parsed.group(2)), float(parsed.group(3))
    solved = api.solve(program)
    assert solved.status == status, f"{where}: {solved.diagnostics}"
    assert solved.solution is not None
    position, rotation = solved.solution.target_errors()  # type: ignore[attr-defined]
    assert position <= position_mm and rotation <= rotation_deg, (
        f"{where}: {position:.2f} mm, {rotation:.2f} deg"
    )
    assert not [d for d in solved.diagnostics if d.is_error or d.severity.value == "warning"], where


def test_there_are_examples_of_both_kinds() -> None:
    assert sum(1 for _, code, _ in EXAMPLES if is_whole_program(code)) >= 2
    assert sum(1 for _, code, _ in EXAMPLES if not is_whole_program(code)) >= 10
