"""What the user owns: an inventory file, and whether a design uses more than it.

The one format everywhere FabHaL takes an inventory (`fabhal search`, and
`fabhal design` after it) is TOML, one line per part type:

    DoubleHook = 4      # S-hooks
    RingM = 2

A design may use up to `count` parts of each type listed and none of a type
not listed. Environments (the rod, the wall) are the place and the target
(the mug) is what is hung, not parts the user spends: they are never counted.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import tomllib

from fabhal.diagnostics import Diagnostic, FabhalError, error
from fabhal.elaborate import FlatProgram
from fabhal.library import Library
from fabhal.source import SourceFile, Span
from fabhal.syntax.hints import did_you_mean

_AT = re.compile(r"\(at line (\d+), column (\d+)\)")


@dataclass(frozen=True)
class Inventory:
    counts: Mapping[str, int]  # part type -> how many the user owns
    file: str


class InventoryError(FabhalError):
    """The inventory file cannot be used; `source` (if it was read) shows the lines."""

    def __init__(self, diagnostics: list[Diagnostic], source: SourceFile | None):
        super().__init__(diagnostics)
        self.source = source


def read_inventory(path: Path, library: Library) -> Inventory:
    """Read and check an inventory file; raises InventoryError with every
    problem as a diagnostic at its line (E601)."""
    name = str(path)
    try:
        source = SourceFile.read(path, name)
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or "not UTF-8 text"
        raise InventoryError(
            [error("E601", f"cannot read the inventory {name}: {reason}", None, "check the path")], None
        ) from None
    try:
        data = tomllib.loads(source.text)
    except tomllib.TOMLDecodeError as exc:
        raise InventoryError([_not_toml(source, str(exc))], source) from None
    problems = [
        problem
        for part_type, count in data.items()
        if (problem := _entry_problem(source, part_type, count, library)) is not None
    ]
    if problems:
        raise InventoryError(problems, source)
    return Inventory(MappingProxyType(dict(data)), name)


def parts_used(flat: FlatProgram) -> Counter[str]:
    """How many parts of each type a design uses (environments and targets excluded)."""
    held = {target.part for target in flat.targets}
    return Counter(part.type_name for part in flat.parts if not part.environment and part.name not in held)


def over_inventory(inventory: Inventory, flat: FlatProgram) -> Diagnostic | None:
    """E602 when the design needs more of some part than the user owns (the first such type)."""
    for part_type, used in sorted(parts_used(flat).items()):
        owned = inventory.counts.get(part_type, 0)
        if used > owned:
            return error(
                "E602",
                f"uses {used} {part_type} but the inventory has {owned}",
                None,
                f"add `{part_type} = {used}` to {inventory.file} if you own them, or choose a "
                f"design with fewer",
            )
    return None


def _entry_problem(source: SourceFile, part_type: str, count: object, library: Library) -> Diagnostic | None:
    span = _line_of(source, part_type)
    if isinstance(count, dict):
        return error(
            "E601",
            f"`[{part_type}]`: an inventory has no tables",
            span,
            "write one `PartType = count` line per part, e.g. `DoubleHook = 4`",
        )
    if part_type not in library.parts:
        guess = did_you_mean(part_type, library.parts)
        return error(
            "E601",
            f"`{part_type}` is not a part in the library",
            span,
            (f"did you mean `{guess}`? " if guess else "") + "`fabhal parts` lists every part type",
        )
    if isinstance(count, bool) or not isinstance(count, int) or count < 0:
        return error(
            "E601",
            f"`{part_type} = {count!r}`: a count is a whole number, 0 or more",
            span,
            f"write how many you own, e.g. `{part_type} = 2`",
        )
    return None


def _line_of(source: SourceFile, key: str) -> Span | None:
    pattern = re.compile(rf'^\s*"?{re.escape(key)}"?\s*=')
    for number, line in enumerate(source.text.splitlines(), start=1):
        if pattern.match(line) or line.strip() == f"[{key}]":
            return Span(source.name, number, 1, number, len(line) + 1)
    return None


def _not_toml(source: SourceFile, message: str) -> Diagnostic:
    found = _AT.search(message)
    span = None
    if found:
        line, column = int(found.group(1)), int(found.group(2))
        span = Span(source.name, line, column, line, column + 1)
    return error(
        "E601",
        f"the inventory is not valid TOML: {_AT.sub('', message).strip()}",
        span,
        "write one `PartType = count` line per part you own, e.g. `DoubleHook = 4`",
    )
