"""The console's static files (package data under ``robodcn/web/static``), with ETags.

Only files that are in the static directory are served: a name is looked up in the list of
shipped files, never joined onto a path, so ``..`` or an encoded slash cannot escape it.
"""

from __future__ import annotations

import functools
import hashlib
from importlib import resources
from typing import Any

#: Content types by file suffix; anything else is not served.
CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".png": "image/png",
    ".svg": "image/svg+xml",
}
INDEX = "index.html"


@functools.cache
def _files() -> dict[str, tuple[bytes, str, str]]:
    """Every shipped asset: name → (bytes, content type, ETag), read once."""
    out = {}
    for entry in resources.files("robodcn.web").joinpath("static").iterdir():
        suffix = "." + entry.name.rsplit(".", 1)[-1] if "." in entry.name else ""
        if entry.is_file() and suffix in CONTENT_TYPES:
            data = entry.read_bytes()
            etag = '"' + hashlib.sha256(data).hexdigest()[:16] + '"'
            out[entry.name] = (data, CONTENT_TYPES[suffix], etag)
    return out


def asset(path: str) -> tuple[bytes, str] | None:
    """The bytes and content type of the asset ``path`` ("" or "/" is the page), or None."""
    found = _files().get(path.strip("/") or INDEX)
    return None if found is None else found[:2]


def etag(path: str) -> str | None:
    """The strong ETag of the asset ``path`` (a hash of its bytes), or None when unknown."""
    found = _files().get(path.strip("/") or INDEX)
    return None if found is None else found[2]


def serve_asset(handler: Any, path: str) -> bool:
    """Answer ``handler``'s GET/HEAD with the asset ``path``; False (nothing sent) if unknown.

    ``Cache-Control: no-cache`` with an ETag: the browser revalidates on every load and gets a
    body-less 304 while the file is unchanged, so an upgraded package is never served stale.
    """
    found = _files().get(path.strip("/") or INDEX)
    if found is None:
        return False
    data, ctype, tag = found
    not_modified = tag in (handler.headers.get("If-None-Match") or "")
    handler.send_response(304 if not_modified else 200)
    handler.send_header("ETag", tag)
    handler.send_header("Cache-Control", "no-cache")
    if not not_modified:
        handler.send_header("Content-Type", ctype)
        handler.send_header("Content-Length", str(len(data)))
        handler.send_header("X-Content-Type-Options", "nosniff")
        if ctype.startswith("text/html"):
            # Everything the page loads comes from this server.
            handler.send_header("Content-Security-Policy", "default-src 'self'; "
                                "img-src 'self' data:; object-src 'none'; "
                                "frame-ancestors 'none'")
    handler.end_headers()
    if not not_modified and handler.command != "HEAD":
        handler.wfile.write(data)
    return True
