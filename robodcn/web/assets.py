"""The console's static files (package data under ``robodcn/web/static``), with ETags.

Only files that are in the static directory are served: a name is looked up in the list of
shipped files, never joined onto a path, so ``..`` or an encoded slash cannot escape it.
"""

from __future__ import annotations

import functools
import hashlib
from importlib import resources

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


#: Headers of the page itself: everything it loads comes from this server.
PAGE_HEADERS = {"Content-Security-Policy": "default-src 'self'; img-src 'self' data:; "
                                           "object-src 'none'; frame-ancestors 'none'"}


def answer(path: str, if_none_match: str | None = None
           ) -> tuple[int, bytes, str, dict[str, str]] | None:
    """(status, body, content type, headers) of a GET of the asset ``path``, or None if
    there is no such asset.

    ``Cache-Control: no-cache`` with an ETag: the browser revalidates on every load and gets a
    body-less 304 while the file is unchanged, so an upgraded package is never served stale.
    """
    found = _files().get(path.strip("/") or INDEX)
    if found is None:
        return None
    data, ctype, tag = found
    headers = {"ETag": tag, "Cache-Control": "no-cache"}
    if tag in (if_none_match or ""):
        return 304, b"", ctype, headers
    headers["X-Content-Type-Options"] = "nosniff"
    if ctype.startswith("text/html"):
        headers.update(PAGE_HEADERS)
    return 200, data, ctype, headers
