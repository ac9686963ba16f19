"""`fabhal gallery` and importing the gallery's sub-assemblies from anywhere."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli.test_check_command import fabhal
from tests.conftest import REPO


def test_gallery_lists_programs_and_importable_assemblies() -> None:
    run = fabhal("gallery", "--json")
    assert run.returncode == 0, run.stderr
    entries = {e["name"]: e for e in json.loads(run.stdout)}
    assert entries["mug_hanger.fhl"]["kind"] == "program"
    assert entries["mug_hanger.fhl"]["summary"].startswith("Mug hanger: hang a mug under a thin rod")
    chain = entries["lib/s_hook_chain.fhl"]
    assert (
        chain["kind"] == "assembly" and Path(chain["path"]) == REPO / "programs" / "lib" / "s_hook_chain.fhl"
    )
    assert len([e for e in entries.values() if e["kind"] == "program"]) == len(
        list((REPO / "programs").glob("*.fhl"))
    )


def test_a_program_outside_the_gallery_imports_its_sub_assembly(tmp_path: Path) -> None:
    (tmp_path / "hack.fhl").write_text(
        'import "lib/s_hook_chain.fhl"\n'
        "environment rod = Rod(length: 400, radius: 3) at (0, 0, 300) rot (90, 0, 90)\n"
        "chain = SHookChain(n: 4)\nmug = Mug()\n"
        "connect chain.top -- rod\nconnect mug.hook -- chain.bottom\n"
        "target mug.hook at (0, 0, 200) rot (0, 0, 0)\n"
    )
    run = fabhal("check", "hack.fhl", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "hack.fhl: ok" in run.stdout


def test_a_missing_import_says_where_it_looked(tmp_path: Path) -> None:
    (tmp_path / "hack.fhl").write_text('import "lib/no_such_chain.fhl"\n')
    run = fabhal("check", "hack.fhl", cwd=tmp_path)
    assert run.returncode == 1
    assert "hack.fhl:1:1: error[E003]" in run.stderr
    assert "the part library or the gallery (`fabhal gallery` lists what it has)" in run.stderr
