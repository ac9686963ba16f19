"""A single self-contained HTML page showing the solved scene in WebGL 2.

Everything is inside the file: the meshes (world coordinates, base64 float32
positions and uint32 indices), the viewer script (viewer.js, no libraries)
and the solve summary. Opening it needs no network. Orbit with the left
button, pan with the right button (or shift + left), zoom with the wheel;
hovering a part shows its name; the side panel shows status, target error
and the connection tree.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from typing import Any

import numpy as np

from fabhal.render.scene import Scene


def scene_payload(scene: Scene, summary: dict[str, Any]) -> dict[str, Any]:
    """What viewer.js draws: the meshes in world coordinates, the target frames,
    the connection tree and the solve summary (JSON-ready)."""
    items = [
        {
            "name": item.name,
            "role": item.role,
            "color": [round(c, 4) for c in item.color],
            "opacity": item.opacity,
            "positions": _b64(item.world_vertices().astype(np.float32)),
            "indices": _b64(item.faces.astype(np.uint32)),
        }
        for item in scene.items
    ]
    return {
        "title": scene.title,
        "items": items,
        "requested": np.round(scene.requested, 6).tolist(),
        "achieved": np.round(scene.achieved, 6).tolist(),
        "tree": [{"depth": depth, "line": line} for depth, line in scene.tree],
        "summary": summary,
    }


def viewer_html(scene: Scene, summary: dict[str, Any]) -> str:
    return page_html(scene_payload(scene, summary))


def page_html(payload: dict[str, Any], live: str = "", live_script: str = "") -> str:
    """The page around a payload; `fabhal watch` adds its panel lines (`live`,
    HTML) and the script that takes new payloads from the server."""
    script = resources.files("fabhal.render").joinpath("viewer.js").read_text(encoding="utf-8")
    # "</" cannot appear inside a <script> element: escape it in the embedded JSON
    data = json.dumps(payload, separators=(",", ":")).replace("</", "<\\/")
    return _PAGE.format(
        title=html.escape(payload["title"]), payload=data, script=script, live=live, live_script=live_script
    )


def _b64(array: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title} - FabHaL</title>
<style>
  html, body {{ margin: 0; height: 100%; font: 14px system-ui, sans-serif;
                color: #222; background: #fafaf8; }}
  #view {{ position: absolute; left: 0; top: 0; right: 340px; bottom: 0; }}
  canvas {{ width: 100%; height: 100%; display: block; cursor: grab; }}
  #panel {{ position: absolute; top: 0; right: 0; width: 340px; bottom: 0; overflow: auto;
            border-left: 1px solid #ddd; background: #fff; padding: 14px; box-sizing: border-box; }}
  #panel h1 {{ font-size: 18px; margin: 0 0 6px; }}
  .status {{ font-weight: 600; }} .solved {{ color: #1e823c; }}
  .falls_apart, .not_at_rest, .infeasible, .error {{ color: #c81e1e; }}
  #panel ul {{ padding-left: 16px; margin: 4px 0; }} #panel li {{ margin: 2px 0; }}
  code {{ font-size: 12px; }}
  .dofs {{ color: #555; font-size: 12px; }}
  #no-webgl {{ margin: 80px 40px; padding: 16px; border: 1px solid #c81e1e; border-radius: 6px;
               color: #c81e1e; background: #fff; max-width: 460px; }}
  #tip {{ position: absolute; pointer-events: none; background: #222; color: #fff; padding: 3px 7px;
          border-radius: 4px; font-size: 13px; display: none; white-space: nowrap; }}
  #help {{ position: absolute; left: 10px; bottom: 8px; color: #777; font-size: 12px; }}
</style>
</head>
<body>
<div id="view"><canvas id="canvas"></canvas><div id="tip"></div>
<div id="help">drag: orbit &middot; right-drag or shift-drag: pan &middot;
  wheel: zoom &middot; hover: part name</div></div>
<div id="panel">{live}</div>
<script type="application/json" id="scene-data">{payload}</script>
<script>
{script}
</script>
{live_script}
</body>
</html>
"""
