"""Which requests reach the service at all: the ``Host`` allow-list and the ``Origin`` check.

A service on 127.0.0.1 is reachable by every web page the user's browser opens. Two kinds
of request carry a page's intent to it, and both are refused here, before any operation
runs (the same rules as Jupyter Server, geth and the MCP transport spec for loopback
services):

- **DNS rebinding**: a page on ``evil.example`` re-points its name at 127.0.0.1 and then
  talks to the service as "same-origin"; its requests name the attacker's host
  (``Host: evil.example:8080``). Only ``Host`` values naming the loopback address and the
  bound port are served (``127.0.0.1:P``, ``localhost:P``, ``[::1]:P``; the bound address
  itself when it is a specific one; more with ``serve --allow-host NAME``): anything else,
  a missing ``Host`` included, is 403 ``host_not_allowed``.
- **Cross-site requests**: a foreign page's form post or ``fetch`` carries its own origin
  (``Origin: http://evil.example``). A request whose ``Origin`` is present and is not the
  service's own (``http://`` + an allowed host + ``:P``) is 403 ``origin_not_allowed`` on
  every route but GET (and HEAD) of the console's files (:attr:`Route.public
  <robodcn.http.routes.Route.public>`), which a page may link.

With every POST/PUT/DELETE needing ``Content-Type: application/json``
(:func:`robodcn.http.jsonbody.require_json`), a foreign page cannot send a control request
without a CORS preflight, which this service never grants; the bearer token
(:mod:`robodcn.http.auth`) guards the same methods when one is set.
"""

from __future__ import annotations

import ipaddress
import re
from dataclasses import dataclass
from typing import Any

from robodcn.errors import InputError
from robodcn.http.framing import HTTPError, Request
from robodcn.http.routes import Route

#: The names of this machine every loopback service answers to (IPv6 without brackets).
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
#: A DNS name (RFC 1123 labels, letters, digits and hyphens, dot-separated).
_DNS_NAME = re.compile(r"^(?=.{1,253}$)[a-z0-9]([a-z0-9-]{0,61}[a-z0-9])?"
                       r"(\.[a-z0-9]([a-z0-9-]{0,61}[a-z0-9])?)*\.?$")
_WILDCARDS = ("0.0.0.0", "::", "")


def host_name(name: Any, field: str = "allow_host") -> str:
    """``name`` (a DNS name or an IP address, IPv6 with or without brackets, no port) in
    the form :class:`Gate` compares: lower case, IPv6 without brackets. InputError naming
    ``field`` for anything else (a port, a scheme, a wildcard)."""
    if isinstance(name, str):
        text = name.strip().lower()
        bare = text[1:-1] if text.startswith("[") and text.endswith("]") else text
        try:
            return str(ipaddress.ip_address(bare))
        except ValueError:
            if bare == text and _DNS_NAME.match(text):
                return text.rstrip(".")
    raise InputError(f"{field} must be a host name or an IP address without a port or "
                     f"scheme (e.g. robot.local, 192.168.1.5), got {name!r}", field=field,
                     value=name)


def _split(authority: str) -> tuple[str, int | None] | None:
    """``name[:port]`` or ``[v6][:port]`` → (name as :func:`host_name` gives it, port or
    None); None when malformed."""
    text = authority.strip().lower()
    if text.startswith("["):
        end = text.find("]")
        if end < 0:
            return None
        name, rest = text[:end + 1], text[end + 1:]
        if rest and not rest.startswith(":"):
            return None
        port_text = rest[1:] if rest else None
    else:
        name, sep, port_text = text.rpartition(":")
        if not sep:
            name, port_text = text, None
        elif ":" in name:  # a bare IPv6 address is not a valid Host
            return None
    if port_text is not None and not (port_text.isascii() and port_text.isdigit()
                                      and len(port_text) <= 5):
        return None
    try:
        return host_name(name), (int(port_text) if port_text is not None else None)
    except InputError:
        return None


@dataclass(frozen=True)
class Gate:
    """The hosts (lower case, IPv6 without brackets) and the port this service answers as.

    Build it with :meth:`of`; :meth:`check` refuses what does not pass (HTTPError 403).
    """

    port: int
    hosts: frozenset[str]

    @classmethod
    def of(cls, bound_host: str, port: int, allow_hosts: tuple[str, ...] = ()) -> Gate:
        """The gate of a service bound to ``(bound_host, port)``: the loopback names, the
        bound address when it is a specific one (not 0.0.0.0 or ::) and ``allow_hosts``
        (InputError naming ``allow_host`` for a malformed one)."""
        hosts = set(LOOPBACK_NAMES) | {host_name(h) for h in allow_hosts}
        if bound_host not in _WILDCARDS:
            hosts.add(host_name(bound_host, "host"))
        return cls(port, frozenset(hosts))

    def allows(self, authority: str) -> bool:
        """``authority`` (``name[:port]``, as in Host) names an allowed host on this port
        (no port: 80, the http default)."""
        parts = _split(authority)
        return parts is not None and parts[0] in self.hosts and \
            (80 if parts[1] is None else parts[1]) == self.port

    def origin_allowed(self, origin: str) -> bool:
        """``origin`` (``scheme://authority``) is this service's own: http and an allowed
        host on this port."""
        scheme, sep, authority = origin.strip().partition("://")
        return bool(sep) and scheme.lower() == "http" and "/" not in authority \
            and self.allows(authority)

    def check(self, request: Request, route: Route | None) -> None:
        """403 unless ``request``'s Host is allowed and its Origin, when present, is the
        service's own (any Origin on a GET/HEAD of a ``public`` route). ``route`` None: the
        path matched none (only the Host is checked: the answer is a 404/405 anyway)."""
        host = request.headers.get("host")
        if host is None or not self.allows(host):
            raise HTTPError(403, "host_not_allowed", (
                f"Host {host!r} is not this service's" if host is not None else
                "the request has no Host header") + f": it answers as 127.0.0.1:{self.port}, "
                f"localhost:{self.port} or [::1]:{self.port} (start serve with --allow-host "
                "NAME to answer to another name)", "Host")
        origin = request.headers.get("origin")
        if origin is None or route is None or self.origin_allowed(origin):
            return
        if route.public and request.method in ("GET", "HEAD"):
            return
        raise HTTPError(403, "origin_not_allowed", f"requests from pages of origin "
                        f"{origin!r} are refused: only this service's own console "
                        f"(http://127.0.0.1:{self.port} and its other names) may call it",
                        "Origin")
