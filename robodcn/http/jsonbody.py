"""Request bodies as JSON: UTF-8 only (RFC 8259 §8.1), bounded depth, numbers a float holds.

The decoder never raises anything but :class:`~robodcn.http.framing.HTTPError`: malformed
JSON (NaN and Infinity included), another encoding (a UTF-16 body, a BOM) or nesting deeper
than :data:`~robodcn.http.limits.MAX_JSON_DEPTH` are 400. Numbers stay as JSON gives them:
an integer too large for a float (``1`` followed by 400 zeros) or ``1e400`` (inf) is refused
by the contract's field checks, naming the field (422).

Every POST, PUT, PATCH and DELETE carries a JSON body (:func:`require_json`, checked before
its operation runs): ``Content-Type: application/json`` and at least ``{}``, 415 otherwise;
an empty body is never read as ``{}``.
"""

from __future__ import annotations

import json
from typing import Any

from robodcn.http.framing import HTTPError, Request
from robodcn.http.limits import MAX_JSON_DEPTH


def _reject_constant(name: str) -> None:
    raise ValueError(f"{name} is not valid JSON")


def _depth(value: Any, limit: int) -> int:
    """Nesting depth of ``value``, iteratively (no recursion), stopping past ``limit``."""
    deepest = 0
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            deepest = max(deepest, depth)
            if deepest > limit:
                return deepest
            children = item.values() if isinstance(item, dict) else item
            stack.extend((child, depth + 1) for child in children)
    return deepest


#: The methods that change something: each needs a JSON body (and the token, when set).
CHANGING = frozenset({"POST", "PUT", "PATCH", "DELETE"})


def check_media(content_type: str | None) -> None:
    """HTTPError 415 unless ``content_type`` is ``application/json`` (charset UTF-8, if
    one is named)."""
    media, _, params = (content_type or "").partition(";")
    if media.strip().lower() != "application/json":
        raise HTTPError(415, "unsupported_media_type", f"Content-Type must be "
                        f"application/json, got {content_type or 'none'!r}", "Content-Type")
    for param in params.split(";"):
        key, _, value = param.partition("=")
        if key.strip().lower() == "charset" and \
                value.strip().strip('"').lower() not in ("utf-8", "utf8"):
            raise HTTPError(415, "unsupported_media_type", f"JSON over HTTP is UTF-8 "
                            f"(RFC 8259); charset {value.strip()!r} is not accepted",
                            "Content-Type")


def decode_json(body: bytes, content_type: str | None) -> Any:
    """``body`` (the bytes of a request declared ``application/json``) → Python values.

    Raises HTTPError 415 when the media type is not JSON or names another charset, 400 when
    the bytes are not UTF-8 JSON or nest deeper than MAX_JSON_DEPTH.
    """
    check_media(content_type)
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise HTTPError(400, "malformed_json", f"the body is not UTF-8 (JSON over HTTP is "
                        f"UTF-8, RFC 8259): byte {exc.start}", "body") from None
    if text.startswith("\ufeff"):
        raise HTTPError(400, "malformed_json", "the body starts with a byte-order mark; send "
                        "plain UTF-8 JSON", "body")
    try:
        value = json.loads(text, parse_constant=_reject_constant)
    except RecursionError:
        raise HTTPError(400, "malformed_json", f"the body nests deeper than "
                        f"{MAX_JSON_DEPTH} levels", "body") from None
    except ValueError as exc:
        raise HTTPError(400, "malformed_json", f"the body is not valid JSON: {exc}",
                        "body") from None
    if _depth(value, MAX_JSON_DEPTH) > MAX_JSON_DEPTH:
        raise HTTPError(400, "malformed_json", f"the body nests deeper than "
                        f"{MAX_JSON_DEPTH} levels", "body")
    return value


def require_json(request: Request) -> None:
    """A POST/PUT/PATCH/DELETE carries ``Content-Type: application/json`` and a non-empty
    body (``{}`` for an operation without fields): 415 otherwise, 411 without a
    Content-Length. Nothing else reaches an operation, so no request a foreign page can
    send without a CORS preflight (a form post, a ``no-cors`` fetch: text/plain, form
    data, no body) ever acts (:mod:`robodcn.http.gate`). Other methods pass."""
    if request.method not in CHANGING:
        return
    check_media(request.headers.get("content-type"))
    if "content-length" not in request.headers and not request.body:
        raise HTTPError(411, "length_required", "a JSON body with Content-Length is "
                        "required", "Content-Length")
    if not request.body.strip():
        raise HTTPError(415, "unsupported_media_type", f"{request.method} {request.path} "
                        "needs a JSON body: an empty body is not one (send {} for an "
                        "operation without fields)", "body")


def read_json(request: Request) -> Any:
    """The request body as JSON (:func:`require_json`'s 411 and 415; 400 from
    :func:`decode_json`)."""
    require_json(request)
    return decode_json(request.body, request.headers.get("content-type"))
