"""`fabhal search` end to end: the table, JSON, CSV, inventory, emitted
programs, pictures, exit codes, and the Dask executor on a LocalCluster.

The family is tests/data/search/mug_family.fhl (see tests/search/test_search.py):
a mug on n = 1..3 S-hooks of two sizes from a rod of radius 2 or 40 mm; the
S-hooks' 19.2 mm opening does not fit the 80 mm thick rod (E404)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from fabhal import api
from tests.cli.test_check_command import fabhal
from tests.conftest import REPO, assert_golden

FAMILY = "tests/data/search/mug_family.fhl"
GOLDEN = REPO / "tests" / "cli" / "golden"


def search(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return fabhal("search", FAMILY, "-j", "1", "--log", str(tmp_path / "log.jsonl"), *args)


def test_the_table_ranks_the_solved_and_counts_the_rejected(tmp_path: Path) -> None:
    run = search(tmp_path, "-D", "hook=DoubleHook")
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert out.startswith(f"{FAMILY}: 6 members (radius 2 x hook 1 x n 3): solved 3, rejected 3\n")
    assert "rejected 3 by E404, e.g. radius=40 hook=DoubleHook n=1:" in out
    assert "mug_family.fhl:16:1: error[E404]" in out  # the example points at the line
    assert "the best 3 by settled target error" in out
    assert "best with hook=DoubleHook: radius=2 n=2:" in out
    assert "6 members in" in out and "on 1 worker; log:" in out
    assert run.stderr == ""  # not a terminal: no progress bar


def test_json_and_csv_hold_every_member(tmp_path: Path) -> None:
    table = tmp_path / "members.csv"
    run = search(tmp_path, "-D", "radius=2", "-D", "hook=DoubleHook", "--json", "--csv", str(table))
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["params"] == ["radius", "hook", "n"] and data["family_size"] == 3
    assert data["complete"] is True and data["resumed"] == 0 and data["rejections"] == []
    errors = {m["key"]: m["position_mm"] for m in data["members"]}
    assert data["ranking"] == sorted(errors, key=errors.__getitem__)
    assert data["best_per"] == {"hook": {"DoubleHook": data["ranking"][0]}}
    rows = list(csv.DictReader(table.open()))
    assert [r["n"] for r in rows] == ["1", "2", "3"]
    assert all(r["status"] == "solved" for r in rows)
    assert {float(r["position_mm"]) for r in rows} == set(errors.values())  # repr round trip: exact


def test_outputs_go_to_new_folders_and_an_impossible_one_stops_before_solving(tmp_path: Path) -> None:
    """A CSV asked for in a folder that does not exist yet is written there (it
    used to end a whole search with "No such file or directory"); a place that
    cannot be a folder (under a plain file) is refused before any member is
    solved: the log stays unwritten."""
    table = tmp_path / "out" / "deeper" / "members.csv"
    run = search(tmp_path, "-D", "radius=2", "-D", "hook=DoubleHook", "-D", "n=1", "--csv", str(table))
    assert run.returncode == 0, run.stderr
    assert [r["n"] for r in csv.DictReader(table.open())] == ["1"]
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    (tmp_path / "log.jsonl").unlink()
    run = search(tmp_path, "-D", "radius=2", "--plot", str(blocker / "errors.png"))
    assert run.returncode == 2
    assert f"cannot make the folder {blocker}" in run.stderr
    assert not (tmp_path / "log.jsonl").exists()


def test_a_family_the_check_rejects_entirely_exits_one(tmp_path: Path) -> None:
    run = search(tmp_path, "-D", "radius=40")
    assert run.returncode == 1
    assert "solved" not in run.stdout.splitlines()[0] and "rejected 6 by E404" in run.stdout


def test_the_inventory_rejects_members_that_need_more_than_owned(tmp_path: Path) -> None:
    inventory = tmp_path / "mine.toml"
    inventory.write_text("DoubleHook = 2  # the S-hooks in the drawer\nDoubleHookMedium = 1\n")
    run = search(tmp_path, "-D", "radius=2", "--inventory", str(inventory), "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    rejected = {m["key"]: m["reason"] for m in data["members"] if m["status"] == "rejected"}
    # 3 DoubleHooks, and 2 or 3 DoubleHookMediums, are more than owned
    assert rejected == {
        "radius=2 hook=DoubleHook n=3": "E602",
        "radius=2 hook=DoubleHookMedium n=2": "E602",
        "radius=2 hook=DoubleHookMedium n=3": "E602",
    }
    (reason,) = data["rejections"]
    assert "uses 3 DoubleHook but the inventory has 2" in reason["example"]


def test_a_wrong_inventory_is_shown_at_its_line(tmp_path: Path) -> None:
    (tmp_path / "mine.toml").write_text("DoubleHook = 4\nSHook = 2\nRingM = -1\n")
    run = fabhal("search", str(REPO / FAMILY), "--inventory", "mine.toml", cwd=tmp_path)
    assert run.returncode == 2 and run.stdout == ""
    assert_golden(run.stderr, GOLDEN / "search_bad_inventory.txt")
    (tmp_path / "mine.toml").write_text("DoubleHook = = 4\n")
    run = fabhal("search", str(REPO / FAMILY), "--inventory", "mine.toml", cwd=tmp_path)
    assert run.returncode == 2 and "mine.toml:1:" in run.stderr and "not valid TOML" in run.stderr


def test_usage_mistakes_are_said_plainly(tmp_path: Path) -> None:
    run = search(tmp_path, "--executor", "tcp://127.0.0.1:8786")
    assert run.returncode == 2 and "--executor takes dask://HOST:PORT" in run.stderr
    run = search(tmp_path, "--no-gravity")
    assert run.returncode == 2 and "--no-gravity does not apply" in run.stderr
    run = search(tmp_path, "-D", "rings=RingM")
    assert run.returncode == 1 and "the program has no `param rings`" in run.stderr
    run = fabhal("search", "--help")
    assert "fabhal search" in run.stdout and "--resume" in run.stdout and "dask scheduler" in run.stdout


def test_an_emitted_member_solves_to_the_answer_the_search_ranked(tmp_path: Path) -> None:
    run = search(
        tmp_path,
        "-D",
        "radius=2",
        "-D",
        "hook=DoubleHook",
        "--json",
        "--emit",
        str(tmp_path / "best"),
        "--top",
        "2",
    )
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    emitted = sorted((tmp_path / "best").glob("*.fhl"))
    assert [p.name for p in emitted] == [
        f"0{place}_mug_family_{key.replace(' ', '_').replace('=', '-')}.fhl"
        for place, key in enumerate(data["ranking"][:2], start=1)
    ]
    text = emitted[0].read_text()
    assert text.startswith(f"# Member {data['ranking'][0]} of ")
    solved = api.solve(emitted[0])
    best = next(m for m in data["members"] if m["key"] == data["ranking"][0])
    # the same program text and values: the same answer, to the last digit (JSON keeps repr)
    assert (solved.status, solved.solution.target_errors()[0]) == ("solved", best["position_mm"])


def test_emitting_rewrites_imports_found_beside_the_family(tmp_path: Path) -> None:
    family = tmp_path / "family"
    (family / "parts").mkdir(parents=True)
    (family / "parts" / "two.fhl").write_text(
        "assembly Two(hook = DoubleHook) {\n  a = hook()\n  b = hook()\n  connect b.hook2 -- a.hook1\n"
        "  port top = a.hook2\n  port bottom = b.hook1\n}\n"
    )
    (family / "mine.fhl").write_text(
        'import "parts/two.fhl"\n\nparam hook in [DoubleHook, DoubleHookMedium]\n\n'
        "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200) rot (90, 0, 90)\n"
        "chain = Two(hook: hook)\nmug = Mug()\nconnect chain.top -- rod\nconnect mug.hook -- chain.bottom\n"
        "target mug.hook at (0, 0, 80) rot (-35, 0, -90)\n"
    )
    out = tmp_path / "elsewhere"
    run = fabhal(
        "search", str(family / "mine.fhl"), "-j", "1", "--emit", str(out), "--top", "1", cwd=tmp_path
    )
    assert run.returncode == 0, run.stderr
    (emitted,) = out.glob("*.fhl")
    assert 'import "../family/parts/two.fhl"' in emitted.read_text()
    assert "param hook in [DoubleHook, DoubleHookMedium] = Double" in emitted.read_text()  # bound
    assert fabhal("solve", str(emitted)).returncode == 0


def test_render_draws_the_best_and_a_contact_sheet_and_plot_the_errors(tmp_path: Path) -> None:
    pictures, plot = tmp_path / "pictures", tmp_path / "errors.png"
    run = search(tmp_path, "-D", "radius=2", "--render", str(pictures), "--top", "2", "--plot", str(plot))
    assert run.returncode == 0, run.stderr
    members = sorted(p.name for p in pictures.glob("0*.png"))
    assert len(members) == 2 and members[0].startswith("01_mug_family_radius-2_")
    with Image.open(pictures / "contact_sheet.png") as sheet:
        assert sheet.size == (2 * 480, 360 + 44)  # two tiles side by side, each captioned
    with Image.open(pictures / "winners_hook.png") as winners:
        assert winners.size == (2 * 480, 360 + 44)  # the best with each hook type, as the paper's figure
    with Image.open(plot) as image:
        assert image.size == (2 * 560, 380)  # a panel per hook type, side by side
    assert "drew 2 members" in run.stderr and f"wrote {plot}" in run.stderr


def test_dask_is_imported_only_when_asked_for(tmp_path: Path) -> None:
    log = str(tmp_path / "l.jsonl")
    code = (
        "import sys; from fabhal.cli import main; "
        f"rc = main(['search', {FAMILY!r}, '-j', '1', '-D', 'radius=40', '--log', {log!r}]); "
        "assert 'distributed' not in sys.modules and 'dask' not in sys.modules, 'dask imported'; print(rc)"
    )
    run = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().endswith("1")


def test_a_dask_cluster_solves_the_family_as_local_workers_do(tmp_path: Path) -> None:
    """A LocalCluster started here (one in-process worker over TCP, no
    dashboard) behind `--executor dask://HOST:PORT`: the same members, the same
    ranking and the same numbers as one local process."""
    distributed = pytest.importorskip("distributed", reason="the [dask] extra is not installed")
    from fabhal.cli import main

    local = search(tmp_path, "-D", "radius=2", "--json")
    expected = json.loads(local.stdout)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address.removeprefix("tcp://")
        out = tmp_path / "dask.json"
        args = ["search", str(REPO / FAMILY), "-D", "radius=2", "--json", "--log", str(tmp_path / "d.jsonl")]
        code = main([*args, "--executor", f"dask://{address}", "--csv", str(out)])
    assert code == 0
    rows = {r["n"] + r["hook"]: float(r["position_mm"]) for r in csv.DictReader(out.open())}
    alone = {m["bindings"]["n"] + m["bindings"]["hook"]: m["position_mm"] for m in expected["members"]}
    assert rows == alone


def test_on_a_terminal_a_progress_bar_counts_the_members(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """The paper's clip-light study, reduced to two members of ring size M
    (n = 3), as a user at a terminal runs it: the bar counts 2/2 and shows the
    best error so far; the best member per ring size is reported."""
    from fabhal.cli import main

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    family = str(REPO / "programs" / "clip_light_family.fhl")
    pinned = ["-D", "ring=RingM", "-D", "n=3", "--sample", "2", "-j", "1"]
    assert main(["search", family, *pinned, "--log", str(tmp_path / "log.jsonl")]) == 0
    out, err = capsys.readouterr()
    assert "searching clip_light_family.fhl" in err and "2/2" in err and "best " in err
    assert out.splitlines()[0].endswith("21 members (ring 1 x n 1 x extension 2) (a sample of 2): solved 2")
    assert "best with ring=RingM: n=3 extension=" in out
