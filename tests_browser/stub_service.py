"""A scripted stand-in for ``robodcn serve``: the real console assets, canned JSON answers.

For what a real service cannot be made to do on demand — a move that ends ``degraded``, an
arm or a route that is not there yet (a yawed arm, a gripper) — the page is served the same
static files (``robodcn.web.assets``) and given the answers a test scripts: the OpenAPI
document, ``/v1/arm``, ``/v1/state``, moves, and SSE events pushed while the page listens.
Every POST/PUT is recorded with its JSON body.
"""

from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from robodcn.web import assets


class StubService:
    """``url``; ``get`` maps a path to its JSON answer; ``answers`` maps (method, path) to
    (status, JSON) for POST/PUT (default 200 ``{}``); ``requests`` lists (method, path,
    body) as received; :meth:`push` sends an SSE event to every listening page."""

    def __init__(self, get: dict[str, Any]) -> None:
        self.get = dict(get)
        self.answers: dict[tuple[str, str], tuple[int, Any]] = {}
        self.requests: list[tuple[str, str, Any]] = []
        self.events: list[tuple[str, Any]] = []
        self._changed = threading.Condition()
        self._closed = False
        stub = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:
                pass

            def _send(self, status: int, body: bytes, ctype: str,
                      headers: dict[str, str] | None = None) -> None:
                self.send_response(status)
                self.send_header("Content-Type", ctype)
                self.send_header("Content-Length", str(len(body)))
                for key, value in (headers or {}).items():
                    self.send_header(key, value)
                self.end_headers()
                self.wfile.write(body)

            def _json(self, status: int, data: Any) -> None:
                self._send(status, json.dumps(data).encode(), "application/json")

            def do_GET(self) -> None:
                path = self.path.split("?")[0]
                if path == "/v1/events":
                    stub._stream(self)
                    return
                if path in stub.get:
                    self._json(200, stub.get[path])
                    return
                name = "" if path == "/" else path.removeprefix("/static/")
                found = assets.answer(name) if path == "/" or path.startswith("/static/") else None
                if found is None:
                    self._json(404, {"error": {"code": "not_found", "message": f"no {path}",
                                               "field": None}})
                    return
                status, body, ctype, headers = found
                self._send(status, body, ctype, headers)

            def _write(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                raw = self.rfile.read(length) if length else b""
                path = self.path.split("?")[0]
                stub.requests.append((self.command, path, json.loads(raw) if raw else None))
                self._json(*stub.answers.get((self.command, path), (200, {})))

            do_POST = do_PUT = _write

        self._server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self._server.server_address[1]}"
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)

    def start(self) -> StubService:
        self._thread.start()
        return self

    def stop(self) -> None:
        with self._changed:
            self._closed = True
            self._changed.notify_all()
        self._server.shutdown()
        self._server.server_close()

    def push(self, name: str, data: Any) -> None:
        """Send ``event: name`` with ``data`` to every page listening (and later ones)."""
        with self._changed:
            self.events.append((name, data))
            self._changed.notify_all()

    def posted(self, path: str) -> list[Any]:
        """The JSON bodies POSTed or PUT to ``path``, in order."""
        return [body for _, p, body in self.requests if p == path]

    def _stream(self, handler: BaseHTTPRequestHandler) -> None:
        handler.send_response(200)
        handler.send_header("Content-Type", "text/event-stream")
        handler.send_header("Cache-Control", "no-cache")
        handler.end_headers()
        sent = 0
        try:
            while True:
                with self._changed:
                    if self._closed:
                        return
                    pending = self.events[sent:]
                    sent = len(self.events)
                    if not pending:
                        self._changed.wait(0.5)
                chunks = [f"event: {n}\ndata: {json.dumps(d)}\n\n" for n, d in pending]
                handler.wfile.write(("".join(chunks) or ": keep-alive\n\n").encode())
                handler.wfile.flush()
                time.sleep(0.01)
        except (BrokenPipeError, ConnectionResetError):
            return
