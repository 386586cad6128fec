"""Who may drive the arm: the bearer token every POST, PUT and DELETE carries when one is set.

Binding a non-loopback address needs a token (:func:`robodcn.http.listen.make_server`); a
token is visible ASCII so that the header's bytes compare exactly (RFC 6750's b64token).
"""

from __future__ import annotations

import hmac
import ipaddress
from typing import Any

from robodcn.errors import InputError
from robodcn.http.framing import HTTPError, Request
from robodcn.http.jsonbody import CHANGING

#: The environment variable ``robodcn serve`` takes its token from.
TOKEN_ENV = "ROBODCN_TOKEN"


def is_loopback(host: str) -> bool:
    """``host`` names this machine only (``localhost``, 127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_token(token: Any) -> None:
    """A token is 1..256 visible ASCII characters (RFC 6750 b64token-like): clients send
    headers as bytes, so anything else could not be compared reliably. Raises InputError."""
    if token is None:
        return
    if not isinstance(token, str) or not token or len(token) > 256 \
            or not all("\x21" <= c <= "\x7e" for c in token):
        raise InputError("the token must be 1 to 256 visible ASCII characters (letters, "
                         "digits, punctuation; no spaces or non-ASCII)", field="token",
                         value=None)


def authorize(token: str | None, request: Request) -> None:
    """401 unless a request that changes anything (POST, PUT, PATCH, DELETE:
    :data:`~robodcn.http.jsonbody.CHANGING`) carries ``Authorization: Bearer <token>``
    (when a token is set). GET and HEAD read only and need none.

    Tokens are visible ASCII (checked at startup), so the header's bytes compare exactly.
    """
    if token is None or request.method not in CHANGING:
        return
    given = request.headers.get("authorization", "")
    scheme, _, value = given.partition(" ")
    if scheme.lower() != "bearer" or not hmac.compare_digest(
            value.strip().encode("latin-1"), token.encode("ascii")):
        raise HTTPError(401, "unauthorized", "this server needs 'Authorization: Bearer "
                        "<token>' on every POST, PUT and DELETE" + (" (the token given is wrong)"
                                                    if given else ""),
                        "Authorization", {"WWW-Authenticate": "Bearer"})
