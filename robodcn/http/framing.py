"""HTTP/1.1 message framing: an incremental request reader with strict limits, and responses.

The reader is fed bytes as they arrive (by the server's selector loop, without a thread per
connection) and yields a :class:`Request` only once its request line, headers and body are
all in; every malformed or oversized part is an :class:`HTTPError` with its status, so the
server can always answer with a proper status line. Rules (RFC 9112):

- the request line is ``METHOD SP target SP HTTP/1.x``; a line without a version (HTTP/0.9),
  binary bytes (a TLS hello) or anything else malformed is 400; ``HTTP/2.0`` and other
  versions are 505. A request is never acted on before it is fully framed.
- ``Content-Length`` is ASCII digits only; several different values are 400; a
  ``Transfer-Encoding`` is 411 (bodies must carry a length) — with Content-Length it is 400.
- request line over :data:`~robodcn.http.limits.MAX_REQUEST_LINE` is 414, head over
  :data:`~robodcn.http.limits.MAX_HEAD` is 431, a body over ``max_body`` is 413 before it is
  read.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from http import HTTPStatus
from typing import Any

from robodcn.http.limits import MAX_BODY, MAX_HEAD, MAX_REQUEST_LINE

_TOKEN = re.compile(rb"^[!#$%&'*+\-.^_`|~0-9A-Za-z]+$")
_TARGET = re.compile(rb"^[\x21-\x7e]+$")
_VERSION = re.compile(rb"^HTTP/(\d)\.(\d)$")
_DIGITS = re.compile(r"^[0-9]{1,19}$", re.ASCII)


class HTTPError(Exception):
    """A refusal at the HTTP layer: status, JSON error body and extra headers.

    ``close`` asks the server to close the connection after answering (framing errors:
    the rest of the stream cannot be trusted).
    """

    def __init__(self, status: int, code: str, message: str, field: str | None = None,
                 headers: dict[str, str] | None = None, *, close: bool = False) -> None:
        super().__init__(message)
        self.status = status
        self.body = {"code": code, "message": message, "field": field}
        self.headers = headers or {}
        self.close = close


@dataclass
class Request:
    """One fully framed request. Header names are lower-case; values are latin-1 text."""

    method: str
    target: str
    version: tuple[int, int]
    headers: dict[str, str]
    body: bytes = b""
    client: str = ""
    #: For a streaming route only: the connection's (blocking) socket, which the operation
    #: writes itself (:func:`stream_head`, then its events) until it returns.
    socket: Any = None

    @property
    def path(self) -> str:
        return self.target.split("?", 1)[0]

    @property
    def keep_alive(self) -> bool:
        tokens = {t.strip().lower() for t in self.headers.get("connection", "").split(",")}
        if self.version >= (1, 1):
            return "close" not in tokens
        return "keep-alive" in tokens


def _bad(message: str, status: int = 400, code: str = "bad_request",
         field: str | None = None) -> HTTPError:
    return HTTPError(status, code, message, field, close=True)


@dataclass
class RequestReader:
    """Accumulates bytes of one connection and frames requests out of them.

    Call :meth:`feed` with new bytes, then :meth:`next_request` until it returns None.
    ``wants_continue`` is set once the head of a request with ``Expect: 100-continue`` is
    in and acceptable: the server sends ``100 Continue`` and clears it.
    """

    max_body: int = MAX_BODY
    buffer: bytearray = field(default_factory=bytearray)
    wants_continue: bool = False
    _head: Request | None = None
    _length: int = 0
    _continued: bool = False

    def feed(self, data: bytes) -> None:
        self.buffer += data

    @property
    def started(self) -> bool:
        """Some bytes of a request have arrived (an idle keep-alive connection has none)."""
        return bool(self.buffer.strip(b"\r\n")) or self._head is not None

    def next_request(self) -> Request | None:
        """The next complete request, or None when more bytes are needed.

        Raises HTTPError for a malformed, oversized or unsupported request.
        """
        if self._head is None:
            # RFC 9112 §2.2: ignore empty lines before a request line.
            while self.buffer[:2] == b"\r\n":
                del self.buffer[:2]
            while self.buffer[:1] == b"\n":
                del self.buffer[:1]
            if self.buffer and not self.buffer[:1].isalpha():
                raise _bad("this is not an HTTP/1.1 request (a binary or TLS client?); "
                           "speak plain HTTP/1.1")
            end = self.buffer.find(b"\r\n\r\n")
            if end < 0:
                line_end = self.buffer.find(b"\r\n")
                if (line_end < 0 and len(self.buffer) > MAX_REQUEST_LINE) or \
                        line_end > MAX_REQUEST_LINE:
                    raise _bad(f"the request line is over {MAX_REQUEST_LINE} bytes", 414,
                               "uri_too_long")
                if line_end >= 0:
                    self._request_line(bytes(self.buffer[:line_end]))  # fail early
                if len(self.buffer) > MAX_HEAD:
                    raise _bad(f"the request head is over {MAX_HEAD} bytes", 431,
                               "headers_too_large")
                return None
            if end + 4 > MAX_HEAD:
                raise _bad(f"the request head is over {MAX_HEAD} bytes", 431,
                           "headers_too_large")
            head = bytes(self.buffer[:end])
            del self.buffer[:end + 4]
            self._head, self._length = self._parse_head(head)
            self._continued = False
        if len(self.buffer) < self._length:
            if not self._continued and "100-continue" in \
                    self._head.headers.get("expect", "").lower():
                self.wants_continue = self._continued = True
            return None
        request = self._head
        request.body = bytes(self.buffer[:self._length])
        del self.buffer[:self._length]
        self._head = None
        return request

    @staticmethod
    def _request_line(line: bytes) -> tuple[str, str, tuple[int, int]]:
        parts = line.split(b" ")
        if len(parts) == 2 and _TOKEN.match(parts[0]):
            raise _bad("HTTP/0.9 requests (no version) are not served; use HTTP/1.1")
        if len(parts) != 3 or not _TOKEN.match(parts[0]) or not _TARGET.match(parts[1]):
            raise _bad("malformed request line: expected 'METHOD /path HTTP/1.1'")
        version = _VERSION.match(parts[2])
        if version is None:
            raise _bad(f"malformed HTTP version {parts[2].decode('latin-1')!r}")
        major, minor = int(version[1]), int(version[2])
        if major != 1:
            raise _bad(f"HTTP/{major}.{minor} is not supported; use HTTP/1.1", 505,
                       "http_version_not_supported")
        return parts[0].decode("ascii"), parts[1].decode("ascii"), (major, minor)

    def _parse_head(self, head: bytes) -> tuple[Request, int]:
        line, *lines = head.split(b"\r\n")
        method, target, version = self._request_line(line)
        headers: dict[str, str] = {}
        lengths: set[str] = set()
        for raw in lines:
            name, sep, value = raw.partition(b":")
            if not sep or not _TOKEN.match(name):
                raise _bad(f"malformed header line {raw[:60].decode('latin-1')!r}")
            key = name.decode("ascii").lower()
            text = value.strip(b" \t").decode("latin-1")
            if key == "content-length":
                lengths.update(v.strip() for v in text.split(","))
            headers[key] = f"{headers[key]}, {text}" if key in headers else text
        if "transfer-encoding" in headers:
            if lengths:
                raise _bad("both Transfer-Encoding and Content-Length given",
                           field="Transfer-Encoding")
            raise HTTPError(411, "length_required", "chunked or encoded bodies are not "
                            "accepted; send Content-Length", "Content-Length", close=True)
        length = 0
        if lengths:
            if len(lengths) > 1:
                raise _bad(f"conflicting Content-Length values {sorted(lengths)}",
                           field="Content-Length")
            raw_length = lengths.pop()
            if not _DIGITS.match(raw_length):
                raise _bad(f"Content-Length {raw_length!r} is not a number of bytes "
                           "(ASCII digits)", field="Content-Length")
            length = int(raw_length)
            if length > self.max_body:
                raise HTTPError(413, "too_large", f"the body is {length} bytes; the limit is "
                                f"{self.max_body}", "body", close=True)
        return Request(method, target, version, headers), length


@dataclass
class Reply:
    """An answer that is not JSON (a page, a CSV file) or needs its own headers: an
    operation returns ``(status, Reply(...))`` instead of a JSON-ready object."""

    body: bytes
    content_type: str = "application/json"
    headers: dict[str, str] = field(default_factory=dict)


def dumps(obj: Any) -> bytes:
    """Compact JSON bytes (UTF-8)."""
    return json.dumps(obj, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False).encode()


def error_body(status: int, code: str, message: str, field: str | None = None) -> bytes:
    return dumps({"error": {"code": code, "message": message, "field": field}})


def stream_head(status: int = 200, content_type: str = "text/event-stream", *,
                headers: dict[str, str] | None = None, server: str = "robodcn") -> bytes:
    """The head of a long-lived response (no Content-Length: it ends when the connection
    closes), e.g. Server-Sent Events."""
    phrase = HTTPStatus(status).phrase
    lines = [f"HTTP/1.1 {status} {phrase}", f"Server: {server}", f"Content-Type: {content_type}",
             "Cache-Control: no-store", "Connection: close"]
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1")


def response(status: int, body: bytes, *, headers: dict[str, str] | None = None,
             close: bool = False, head_only: bool = False, server: str = "robodcn",
             content_type: str = "application/json") -> bytes:
    """A complete HTTP/1.1 response (no body bytes for HEAD; a 304 has no body headers).

    ``Cache-Control: no-store`` unless ``headers`` set their own."""
    phrase = HTTPStatus(status).phrase if status in HTTPStatus._value2member_map_ else "Error"
    lines = [f"HTTP/1.1 {status} {phrase}", f"Server: {server}"]
    if status != 304:
        lines += [f"Content-Type: {content_type}", f"Content-Length: {len(body)}"]
    if "Cache-Control" not in (headers or {}):
        lines.append("Cache-Control: no-store")
    if close:
        lines.append("Connection: close")
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    head = ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1")
    return head if head_only or status == 304 else head + body
