"""`fabhal render`: 3D files that reload, a picture that shows something, a page that renders."""

from __future__ import annotations

import io
import re
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabhal import api
from fabhal.render import RenderOptions, render
from fabhal.render.picture import HEADER
from fabhal.report.solution import to_dict
from tests.cli.test_check_command import fabhal
from tests.conftest import REPO


@pytest.fixture(scope="module")
def mug() -> Any:
    result = api.solve(REPO / "programs" / "mug_hanger.fhl")
    assert result.status == "solved"
    return result


def _render(result: Any, path: Path, **options: Any) -> None:
    render(result.solution, "mug_hanger", path, RenderOptions(**options), to_dict(result, "mug_hanger"))


def test_glb_reloads_with_one_node_per_part_at_its_solved_frame(mug: Any, tmp_path: Path) -> None:
    import trimesh

    path = tmp_path / "mug.glb"
    _render(mug, path)
    scene = trimesh.load(str(path))
    solution = mug.solution
    names = [part.name for part in solution.model.parts]
    assert sorted(scene.graph.nodes_geometry) == sorted(names)
    for i, name in enumerate(names):
        transform, _ = scene.graph[name]
        # GLB stores float32: 1e-3 mm on positions up to ~1 m, 1e-5 on rotation entries
        np.testing.assert_allclose(transform[:3, 3], solution.frames[i][:3, 3], atol=1e-3)
        np.testing.assert_allclose(transform[:3, :3], solution.frames[i][:3, :3], atol=1e-5)


def test_glb_with_the_requested_ghost_and_primitives_adds_named_nodes(mug: Any, tmp_path: Path) -> None:
    import trimesh

    path = tmp_path / "mug.glb"
    _render(mug, path, show_requested=True, primitives=True)
    nodes = set(trimesh.load(str(path)).graph.nodes_geometry)
    assert {"mug (requested)", "s3.hook1", "s3.hook2", "mug.hook"} <= nodes


@pytest.mark.parametrize("suffix", [".obj", ".stl"])
def test_obj_and_stl_hold_every_part_in_world_coordinates(mug: Any, tmp_path: Path, suffix: str) -> None:
    import trimesh

    path = tmp_path / f"mug{suffix}"
    _render(mug, path)
    mesh = trimesh.load(str(path), force="mesh")
    # the lowest point is the mug's bottom, below the requested hook height (50 mm), not a part at its origin
    assert mesh.bounds[0][2] < 0.0 and len(mesh.faces) > 10_000


def test_png_has_the_requested_size_and_shows_the_hack(mug: Any, tmp_path: Path) -> None:
    from PIL import Image

    path = tmp_path / "mug.png"
    _render(mug, path, views=("iso", "front"), size=(400, 300), show_requested=True)
    image = Image.open(io.BytesIO(path.read_bytes())).convert("RGB")
    assert image.size == (2 * 400, 300 + HEADER)
    pixels = np.asarray(image)[HEADER:].reshape(-1, 3).astype(int)
    background = np.abs(pixels - [250, 250, 248]).sum(axis=1) > 12
    assert background.mean() > 0.1  # the scene covers a real share of the picture
    orange = (pixels[:, 0] > 150) & (pixels[:, 1] > 60) & (pixels[:, 1] < 170) & (pixels[:, 2] < 80)
    assert orange.mean() > 0.01  # the target (the mug, orange) is visible
    assert len(np.unique(pixels, axis=0)) > 100  # shaded, not flat fills


def test_contacts_are_drawn_where_parts_rest_on_the_environment(tmp_path: Path) -> None:
    """The paper towel roll rests against the wall: the picture marks each
    contact (magenta, drawn over the bodies that hide it) at the contact's
    point, with an arrow along the wall's push on the roll, and the 3D file
    has it as a named node. (How many places of its line of contact the
    roll's points report, 2, 3 or 4, is the rounding's: issue 51.)"""
    import trimesh
    from PIL import Image

    from fabhal.render.picture import camera_for
    from fabhal.render.scene import CONTACT_COLOR, build_scene

    result = api.solve(REPO / "programs" / "paper_towel_holder.fhl")
    contacts = result.solution.contacts
    scene = build_scene(result.solution, "towel", RenderOptions())
    markers = [item for item in scene.items if item.role == "contact"]
    assert len(markers) == len(contacts) >= 1
    assert {c.part for c in contacts} == {result.solution.model.part_index("roll")}
    for marker, contact in zip(markers, contacts, strict=True):
        assert marker.name == f"roll rests on walls ({np.linalg.norm(contact.force):.1f} N)"
        np.testing.assert_allclose(marker.transform[:3, 3], contact.point)
        # the arrow's tip lies along the force from the contact point
        tip = marker.world_vertices()[np.argmax((marker.world_vertices() - contact.point) @ contact.force)]
        direction = (tip - contact.point) / np.linalg.norm(tip - contact.point)
        assert direction @ (contact.force / np.linalg.norm(contact.force)) > 0.99
    marker, contact = markers[0], contacts[0]

    path = tmp_path / "towel.png"
    render(result.solution, "towel", path, RenderOptions(size=(400, 300)), to_dict(result, "towel"))
    pixels = np.asarray(Image.open(io.BytesIO(path.read_bytes())).convert("RGB")).astype(int)[HEADER:]
    magenta = np.abs(pixels - np.array(CONTACT_COLOR) * 255).sum(axis=2) < 200
    assert magenta.sum() > 20  # shaded, so not exactly the colour; a few dozen pixels at 400 x 300
    focus = np.concatenate([item.world_vertices() for item in scene.items if item.role != "environment"])
    x, y = camera_for("iso", np.vstack([focus, scene.requested[None, :3, 3]]), 400, 300).project(
        contact.point[None]
    )[0, :2]
    rows, cols = np.nonzero(magenta)
    assert np.min(np.hypot(cols - x, rows - y)) < 3.0  # pixels: the dot sits on the contact point

    glb = tmp_path / "towel.glb"
    render(result.solution, "towel", glb, RenderOptions(), to_dict(result, "towel"))
    assert marker.name in set(trimesh.load(str(glb)).graph.nodes_geometry)


def test_held_connections_are_marked_where_they_grip(tmp_path: Path) -> None:
    """Clip light M: the light's clip grips the hanger's bar (a held connection,
    its settings chosen by aiming, N506). The scene has one held marker, a
    cube centred on that connection's point, named after the connection; the
    picture shows it: near-black pixels around where that point projects."""
    from PIL import Image

    from fabhal.render.picture import camera_for
    from fabhal.render.scene import HELD_COLOR, HELD_MARK_MM, build_scene

    result = api.solve(REPO / "programs" / "clip_light_m.fhl")
    solution = result.solution
    scene = build_scene(solution, "clip", RenderOptions())
    (marker,) = [item for item in scene.items if item.role == "held"]
    assert marker.name == "held: light.clip -- hanger.rod"
    (joint,) = [j for j in solution.model.joints if j.held]
    where = solution.model.connector_frame(joint.a, solution.x, solution.frames)[:3, 3]
    np.testing.assert_allclose(marker.world_vertices().mean(axis=0), where, atol=1e-6)
    assert np.ptp(marker.vertices, axis=0) == pytest.approx([HELD_MARK_MM] * 3)

    path = tmp_path / "clip.png"
    render(solution, "clip", path, RenderOptions(size=(900, 600)), to_dict(result, "clip"))
    pixels = np.asarray(Image.open(io.BytesIO(path.read_bytes())).convert("RGB")).astype(int)[HEADER:]
    dark = np.abs(pixels - np.array(HELD_COLOR) * 255).sum(axis=2) < 60
    focus = np.concatenate([item.world_vertices() for item in scene.items if item.role != "environment"])
    x, y = camera_for("iso", np.vstack([focus, scene.requested[None, :3, 3]]), 900, 600).project(where[None])[
        0, :2
    ]
    rows, cols = np.nonzero(dark)
    near = np.hypot(cols - x, rows - y) < 4.0  # pixels: the cube's face around its centre
    assert near.sum() > 10


# ---------------------------------------------------------------- the browser viewer

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",  # WebGL on the CPU
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--virtual-time-budget=8000",
    "--window-size=1000,700",
]


def test_html_viewer_renders_the_scene_in_headless_chromium(mug: Any, tmp_path: Path, chromium: str) -> None:
    path = tmp_path / "mug.html"
    _render(mug, path, show_requested=True)
    page = path.read_text()
    assert "http://" not in page and "https://" not in page  # nothing to fetch: works offline
    run = subprocess.run(
        [chromium, *CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom", path.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
    )
    body = re.search(r"<body([^>]*)>", run.stdout)
    assert body is not None, run.stderr[-2000:]
    attributes = dict(re.findall(r'data-(\w+)="([^"]*)"', body.group(1)))
    assert attributes.get("errors") == "", attributes  # no exceptions, no console errors
    # the canvas (1000 - 340 px panel) x 700: the scene covers more than 5 % of it
    assert int(attributes.get("rendered", "0")) > 0.05 * 660 * 700
    assert "mug.hook -- s3.hook2" in run.stdout  # the panel's connections...
    assert "mug.hook  &lt;-  s3.hook2" in run.stdout  # ...and the tree of what holds what
    # ...and the design's degrees of freedom, as a builder would set them (`fabhal solve --dofs`)
    assert 'id="dofs"' in run.stdout and "s3.hook2.theta</code>: at " in run.stdout


# ---------------------------------------------------------------- the commands


def test_render_command_writes_the_file_and_says_so(tmp_path: Path) -> None:
    out = tmp_path / "demo.png"
    run = fabhal("render", "programs/demo.fhl", "-o", str(out), "--size", "300x200")
    assert run.returncode == 0, run.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {out} (solved)" in run.stderr


def test_solve_with_render_reports_and_draws(tmp_path: Path) -> None:
    out = tmp_path / "mug.glb"
    run = fabhal("solve", "programs/mug_hanger.fhl", "--render", str(out))
    assert run.returncode == 0, run.stderr
    assert "how it hangs" in run.stdout and out.stat().st_size > 10_000


def test_render_refuses_an_unknown_format_before_solving(tmp_path: Path) -> None:
    run = fabhal("render", "programs/demo.fhl", "-o", str(tmp_path / "demo.jpg"))
    assert run.returncode == 2
    assert "the suffix picks the format, one of .glb .obj .stl .png .html" in run.stderr
    assert not (tmp_path / "demo.jpg").exists()


def test_render_of_a_program_with_errors_draws_nothing(tmp_path: Path) -> None:
    program = tmp_path / "broken.fhl"
    program.write_text(
        "environment rod = Rod(length: 500, radius: 3) at (0, 0, 0)\nmug = Mug()\nconnect mug.hook -- rodd\n"
    )
    run = fabhal("render", str(program), "-o", str(tmp_path / "out.png"))
    assert run.returncode == 1
    assert "nothing to draw" in run.stderr and "rodd" in run.stderr
    assert not (tmp_path / "out.png").exists()


def _dump_dom(chromium: str, page: Path, profile: Path, *extra: str) -> str:
    run = subprocess.run(
        [chromium, *CHROMIUM_FLAGS, *extra, f"--user-data-dir={profile}", "--dump-dom", page.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert "<body" in run.stdout, run.stderr[-2000:]
    return run.stdout


def test_html_viewer_names_each_value_by_its_part_and_primitive(
    mug: Any, tmp_path: Path, chromium: str
) -> None:
    path = tmp_path / "mug.html"
    _render(mug, path)
    dom = _dump_dom(chromium, path, tmp_path / "profile")
    lines = re.findall(r'<div class="dofs">([^<]*)</div>', dom)
    # the rod's side: its slide as a fraction of its length, its tilt and its spin in degrees
    assert any(re.fullmatch(r"rod: t 0\.\d{3} along, phi \d+\.\d°, spin \d+\.\d°", line) for line in lines), (
        lines
    )
    for line in lines:
        owner, _, values = line.partition(": ")
        assert owner in {"rod", "chain.s[1].hook2", "chain.s[1].hook1", "chain.s[2].hook2"} | {
            "chain.s[2].hook1",
            "s3.hook1",
            "s3.hook2",
            "mug.hook",
        }, line
        for angle in re.findall(r"(-?[\d.]+)°", values):
            assert 0.0 <= float(angle) < 360.0, line


def test_html_viewer_without_webgl_says_so(mug: Any, tmp_path: Path, chromium: str) -> None:
    path = tmp_path / "mug.html"
    _render(mug, path)
    dom = _dump_dom(chromium, path, tmp_path / "profile", "--disable-webgl", "--disable-3d-apis")
    assert 'data-webgl="unavailable"' in dom
    assert "This browser cannot show the 3D view" in dom
    assert "mug.hook -- s3.hook2" in dom  # the panel still has the result


def test_json_angles_lie_in_their_ranges() -> None:
    """Periodic DoFs (spins, ring thetas) are reported within [0, 360): the solver
    may hold them anywhere (449.8 is 89.8, -65 is 295). The reading nook's periodic
    DoFs moved by whole turns (+-360, +720: the same configuration) report the same
    (step 1's result: the report does not care where the DoFs came from)."""
    from dataclasses import replace

    result = api.solve(REPO / "programs" / "reading_nook.fhl", gravity=False)
    solution = result.solution
    periodic = [i for i, v in enumerate(solution.model.variables) if v.dof.periodic]
    assert len(periodic) >= 10
    turned = solution.x.copy()
    turned[periodic] += np.resize([360.0, -360.0, 720.0], len(periodic))
    reported = to_dict(result, "reading_nook")["connections"]
    shifted = to_dict(replace(result, solution=replace(solution, x=turned)), "reading_nook")["connections"]
    for joint, plain, moved in zip(solution.model.joints, reported, shifted, strict=True):
        for side, end in ((joint.a, joint.connection.a), (joint.b, joint.connection.b)):
            for dof in side.primitive.dofs:
                if dof.periodic:
                    name = f"{end}.{dof.name}"
                    assert 0.0 <= moved["dofs"][name] < 360.0, (name, moved["dofs"][name])
                    assert moved["dofs"][name] == pytest.approx(plain["dofs"][name], abs=1e-5)
