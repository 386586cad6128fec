"""Binding the service: :func:`make_server` checks its options and listens, or says why not.

:class:`ListenError` (exit code 6) when the address cannot be bound; a non-loopback address
needs a token (:mod:`robodcn.http.auth`). ``processes=N`` above 1 binds N sockets on the
address for a plan-only service in N worker processes (:mod:`robodcn.http.prefork`).
"""

from __future__ import annotations

import errno
import logging
from typing import Any

from robodcn._checks import is_int, is_real
from robodcn.config import Arm
from robodcn.controller import ArmController
from robodcn.errors import InputError, RobodcnError
from robodcn.http import limits
from robodcn.http.answer import Operation
from robodcn.http.auth import TOKEN_ENV, check_token, is_loopback
from robodcn.http.gate import Gate
from robodcn.http.prefork import PreforkServer, bind_group
from robodcn.http.routes import ROUTES, Route
from robodcn.http.server import RobodcnHTTPServer

log = logging.getLogger("robodcn.http")


class ListenError(RobodcnError):
    """The service cannot listen on its TCP address (in use, not local): exit code 6."""

    code = "cannot_listen"
    exit_code = 6


def _positive_int(name: str, value: Any) -> None:
    if not is_int(value) or value < 1:
        raise InputError(f"{name} must be a positive integer, got {value!r}", field=name,
                         value=value)


def check_processes(processes: Any, *, arm_attached: bool) -> None:
    """``processes`` is a positive integer, and 1 when an arm is attached (InputError naming
    ``processes``): a second process would not own the arm's bus."""
    _positive_int("processes", processes)
    if processes > 1 and arm_attached:
        raise InputError(f"processes={processes} needs a plan-only service: with an arm "
                         "attached only one process may own its bus", field="processes",
                         value=processes)


def make_server(arm: Arm, controller: ArmController | None, *, host: str = "127.0.0.1",
                port: int = 0, token: str | None = None, allow_hosts: tuple[str, ...] = (),
                request_timeout: float = limits.REQUEST_TIMEOUT,
                max_connections: int = limits.MAX_CONNECTIONS,
                max_per_client: int = limits.MAX_PER_CLIENT,
                workers: int = limits.WORKERS, stream_slots: int = limits.STREAM_SLOTS,
                routes: tuple[Route, ...] = ROUTES,
                operations: dict[str, Operation] | None = None,
                processes: int = 1) -> RobodcnHTTPServer | PreforkServer:
    """A bound, not yet serving, HTTP server for ``arm`` (call ``serve_forever()``).

    Parameters
    ----------
    arm : Arm
    controller : robodcn.controller.ArmController, or None for a plan-only service (the
        move, stop and state endpoints then answer 503)
    host, port : address to bind; port 0 picks a free port (``server.server_address``)
    token : bearer token every POST, PUT and DELETE must carry (visible ASCII); required
        when ``host`` is not loopback
    allow_hosts : host names (or addresses) the service answers to besides 127.0.0.1,
        localhost, [::1] and the bound address: the ``Host`` allow-list and the origins
        ``http://NAME:port`` (:mod:`robodcn.http.gate`)
    request_timeout : seconds from a connection being ready for a request to the request's
        last byte (an absolute deadline)
    max_connections, max_per_client : open connections in all and from one address
    workers : threads for the ordinary operations
    stream_slots : long-lived (``pool="stream"``) responses at once
    routes, operations : the route table and extra operations by route name (a later
        endpoint adds its Route and its function here, or in routes.ROUTES/ops.OPERATIONS)
    processes : worker processes answering on the address (a plan-only service only:
        ``controller`` None): above 1 a :class:`~robodcn.http.prefork.PreforkServer`, whose
        ``serve_forever()`` forks them (every other option and limit holds per process)

    Raises
    ------
    InputError
        A non-loopback host without a token, a malformed token, a bad port or timeout, an
        ``allow_hosts`` entry that is not a host name (field ``allow_host``);
        ``processes`` not a positive integer, or above 1 with a controller.
    ListenError
        The address cannot be bound (in use, not local): exit code 6.
    """
    check_token(token)
    if not is_loopback(host) and token is None:
        raise InputError(f"binding {host} exposes the arm to the network: give a token "
                         f"(--token or {TOKEN_ENV}) that every POST, PUT and DELETE must "
                         "carry",
                         field="token", value=None)
    if not is_int(port) or not 0 <= port <= 65535:
        raise InputError(f"port must be an integer 0..65535, got {port!r}", field="port",
                         value=port)
    for name, value in (("max_connections", max_connections),
                        ("max_per_client", max_per_client), ("workers", workers),
                        ("stream_slots", stream_slots)):
        _positive_int(name, value)
    if not is_real(request_timeout) or not request_timeout > 0:
        raise InputError(f"request_timeout must be a positive number of seconds, got "
                         f"{request_timeout!r}", field="request_timeout",
                         value=request_timeout)
    check_processes(processes, arm_attached=controller is not None)
    Gate.of(host, port, tuple(allow_hosts))  # InputError naming allow_host, before binding
    if host in ("0.0.0.0", "::") and not allow_hosts:
        log.warning("serving on every address of this machine (%s), but only requests "
                    "naming 127.0.0.1, localhost or [::1] are answered: give --allow-host "
                    "NAME for each name or address other machines use to reach it", host)

    def server(sock: Any = None) -> RobodcnHTTPServer:
        return RobodcnHTTPServer((host, port), arm, controller, token=token,
                                 request_timeout=float(request_timeout),
                                 max_connections=max_connections,
                                 max_per_client=max_per_client, workers=workers,
                                 stream_slots=stream_slots, routes=routes,
                                 operations=operations, sock=sock,
                                 allow_hosts=tuple(allow_hosts))
    try:
        if processes == 1:
            return server()
        return PreforkServer(arm, bind_group(host, port, processes), server)
    except OSError as exc:
        reason = "address in use" if exc.errno == errno.EADDRINUSE else \
            (exc.strerror or str(exc)).lower()
        raise ListenError(f"cannot listen on {host}:{port}: {reason}", field="port",
                          value=port) from exc
