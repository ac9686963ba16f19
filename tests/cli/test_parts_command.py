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


def test_unknown_part_suggests_a_name() -> None:
    run = fabhal("parts", "DoubleHok")
    assert run.returncode == 2
    assert "did you mean `DoubleHook`?" in run.stderr and "Traceback" not in run.stderr
