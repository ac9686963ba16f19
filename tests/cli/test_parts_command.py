"""`fabhal parts` and `fabhal parts NAME`."""

from __future__ import annotations

import json

import pytest

from tests.cli.test_check_command import fabhal


def test_list_as_json_has_every_part() -> None:
    run = fabhal("parts", "--json")
    assert run.returncode == 0, run.stderr
    parts = json.loads(run.stdout)
    assert len(parts) == 57  # the reference's 56 and LevelHulaHoop
    by_name = {p["name"]: p for p in parts}
    assert by_name["DoubleHook"]["primitives"] == ["hook1", "hook2"]
    assert by_name["ParamTurnbuckle"]["parameters"] == ["extension"]


def test_list_as_a_table() -> None:
    run = fabhal("parts")
    assert run.returncode == 0
    assert "DoubleHook" in run.stdout and "hook1 (hook)" in run.stdout


def test_one_part_in_full() -> None:
    run = fabhal("parts", "DoubleHook", "--json")
    assert run.returncode == 0, run.stderr
    info = json.loads(run.stdout)
    assert info["mass_g"] == pytest.approx(10.85, abs=0.01)
    assert info["material"] == "steel"
    hook1 = info["primitives"][0]
    assert hook1["name"] == "hook1" and hook1["variant"] == "HookFlex"
    assert [(d["name"], d["tag"]) for d in hook1["dofs"]] == [
        ("theta", "BOUNDED_AND_OPEN"),
        ("phi", "BOUNDED_AND_CLAMPED"),
    ]
    assert hook1["frame"] == {"pos": [0.0, 0.0, 11.6], "rot": [0.0, 0.0, 0.0]}
    human = fabhal("parts", "DoubleHook")
    assert "BOUNDED_AND_OPEN" in human.stdout and "10.85 g" in human.stdout


def test_a_part_whose_frame_lies_off_it_says_so() -> None:
    """HandleBasket's mesh has its origin outside the basket: its bounding box
    runs from (-94.9, 97.8, 131.7) to (32.1, 258.3, 300.3), so the origin is
    97.8 mm off in y and 131.7 mm in z, sqrt(97.8^2 + 131.7^2) = 164.0 mm
    away (x lies within). The S-hook's frame is at its middle (0 mm)."""
    info = json.loads(fabhal("parts", "HandleBasket", "--json").stdout)
    assert info["frame_outside_mm"] == pytest.approx(164.0, abs=0.1)
    human = fabhal("parts", "HandleBasket")
    assert "its own frame lies 164 mm outside it" in " ".join(human.stdout.split())
    assert json.loads(fabhal("parts", "DoubleHook", "--json").stdout)["frame_outside_mm"] == 0.0
    assert "its own frame lies" not in fabhal("parts", "DoubleHook").stdout


def test_unknown_part_suggests_a_name() -> None:
    run = fabhal("parts", "DoubleHok")
    assert run.returncode == 2
    assert "did you mean `DoubleHook`?" in run.stderr and "Traceback" not in run.stderr


def test_a_toss_rings_twist_is_said_to_act_in_loops_only() -> None:
    """A toss ring's twist about its contact (`flex`) is left out of hacks
    without loops, where it carries no load (fabhal/model.py `_twisting`):
    the part's listing says so at that DoF, and at no S-hook's flex."""
    ring = json.loads(fabhal("parts", "RingM", "--json").stdout)["primitives"][0]
    only_in_loops = {d["name"]: d["only_in_loops"] for d in ring["dofs"]}
    assert only_in_loops == {"theta": False, "phi": True, "spin": False}
    hook = json.loads(fabhal("parts", "DoubleHook", "--json").stdout)["primitives"][0]
    assert not any(d["only_in_loops"] for d in hook["dofs"])
    human = fabhal("parts", "RingM").stdout
    assert "loops only" in human and "loops" not in fabhal("parts", "DoubleHook").stdout
