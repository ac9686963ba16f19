"""The inventory file (fabhal/inventory.py): read, checked line by line, and
compared with what a design uses."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal import api
from fabhal.inventory import InventoryError, over_inventory, parts_used, read_inventory
from tests.conftest import REPO

MUG = REPO / "programs" / "mug_hanger.fhl"  # 3 DoubleHooks under a rod, holding a mug


def library():  # type: ignore[no-untyped-def]
    return api.part_library().library


def problems(tmp_path: Path, text: str) -> list[tuple[str, int | None, str]]:
    path = tmp_path / "mine.toml"
    path.write_text(text)
    with pytest.raises(InventoryError) as raised:
        read_inventory(path, library())
    return [(d.code, d.span.line if d.span else None, d.message) for d in raised.value.diagnostics]


def test_counts_are_read_per_part_type(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text("# what is in the drawer\nDoubleHook = 4\nRingM = 0\n")
    inventory = read_inventory(path, library())
    assert dict(inventory.counts) == {"DoubleHook": 4, "RingM": 0}


def test_every_wrong_line_is_reported_at_its_line(tmp_path: Path) -> None:
    found = problems(tmp_path, 'DoubleHook = 4\nSHook = 2\nRingM = 1.5\n"RingS" = true\n[Mug]\n')
    assert found == [
        ("E601", 2, "`SHook` is not a part in the library"),
        ("E601", 3, "`RingM = 1.5`: a count is a whole number, 0 or more"),
        ("E601", 4, "`RingS = True`: a count is a whole number, 0 or more"),
        ("E601", 5, "`[Mug]`: an inventory has no tables"),
    ]
    ((code, line, message),) = problems(tmp_path, "DoubleHook = 4\nRingM 2\n")
    assert (code, line) == ("E601", 2) and message.startswith("the inventory is not valid TOML")


def test_a_design_over_the_inventory_is_e602_and_the_target_is_not_spent(tmp_path: Path) -> None:
    flat = api.check(MUG).flat
    assert dict(parts_used(flat)) == {"DoubleHook": 3}  # the rod, the wall and the mug are not spent
    path = tmp_path / "mine.toml"
    path.write_text("DoubleHook = 3\n")
    assert over_inventory(read_inventory(path, library()), flat) is None
    path.write_text("DoubleHook = 2\nRingM = 5\n")
    found = over_inventory(read_inventory(path, library()), flat)
    assert found is not None and found.code == "E602"
    assert found.message == "uses 3 DoubleHook but the inventory has 2"
