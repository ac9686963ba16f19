"""The live view: a standard-library HTTP server on the loopback address.

`/` is the viewer page of `fabhal render x.html` with the latest scene and a
panel for the live status; `/events` streams each new result as a
server-sent event (the page swaps the scene in place, keeping the camera);
`/state.json` is the latest result, for tools and tests."""

from __future__ import annotations

import json
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

from fabhal.render.viewer import page_html
from fabhal.watch.session import LiveSession

KEEPALIVE_S = 15.0  # a comment line this often keeps proxies and the browser from closing the stream

_LIVE_PANEL = """<div id="live">
<style>
  #live .summary {{ margin: 4px 0 8px; }} #live .problems {{ padding-left: 16px; }}
  #source {{ font-size: 12px; background: #f6f6f4; border: 1px solid #ddd; padding: 6px;
             max-height: 260px; overflow: auto; white-space: pre; }}
  #source .marked {{ background: #fde2e2; }}
</style>
<div class="dofs">live: <code>{program}</code> (fabhal watch)</div>
<div class="connection dofs"></div>
<div class="summary status">solving ...</div>
<ul class="problems"></ul>
<div id="source" hidden></div>
<hr>
</div>"""


def empty_scene(title: str) -> dict[str, Any]:
    """A scene with nothing in it, for a program that has never solved yet."""
    identity = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    summary: dict[str, Any] = {
        "status": "error",
        "diagnostics": [],
        "connections": [],
        "parts": {},
        "target": None,
    }
    return {
        "title": title,
        "items": [],
        "requested": identity,
        "achieved": identity,
        "tree": [],
        "summary": summary,
    }


class LiveServer(ThreadingHTTPServer):
    daemon_threads = True  # an open event stream never holds up the end of the command

    def __init__(self, port: int, session: LiveSession, program: str) -> None:
        self.session = session
        self.program = program
        super().__init__(("127.0.0.1", port), _Handler)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}/"

    def page(self) -> str:
        _, scene = self.session.latest()
        script = resources.files("fabhal.watch").joinpath("live.js").read_text(encoding="utf-8")
        live = _LIVE_PANEL.format(program=self.program)
        return page_html(scene or empty_scene(self.program), live, f"<script>\n{script}\n</script>")


class _Handler(BaseHTTPRequestHandler):
    server: LiveServer

    def do_GET(self) -> None:
        if self.path in ("/", "/index.html"):
            self._send(self.server.page().encode(), "text/html; charset=utf-8")
        elif self.path == "/state.json":
            latest, _ = self.server.session.latest()
            body = json.dumps(latest.to_json() if latest is not None else None).encode()
            self._send(body, "application/json")
        elif self.path == "/events":
            self._stream()
        else:
            self.send_error(HTTPStatus.NOT_FOUND, "fabhal watch serves /, /events and /state.json")

    def log_message(self, format: str, *args: Any) -> None:
        pass  # the terminal shows the solves, not every request

    def _send(self, body: bytes, kind: str) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _stream(self) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        seen = 0
        try:
            while True:
                result = self.server.session.wait_for(seen, KEEPALIVE_S)
                if result is None:
                    self.wfile.write(b": keepalive\n\n")
                else:
                    seen = result.generation
                    data = json.dumps(result.to_json(), separators=(",", ":"))
                    self.wfile.write(f"id: {seen}\nevent: result\ndata: {data}\n\n".encode())
                self.wfile.flush()
        except (BrokenPipeError, ConnectionResetError):
            return  # the page was closed or reloaded
