"""The server: one selector thread frames requests, bounded worker pools answer them.

Why not ``ThreadingHTTPServer``: a thread per connection lets idle or slow clients (one
header line every few seconds) hold every thread, ``POST /v1/stop`` included. Here:

- **Framing without threads.** One selector thread reads every connection and frames its
  requests (:class:`~robodcn.http.framing.RequestReader`); a connection costs a socket, not a
  thread, until a whole request (head and body) is in.
- **An absolute deadline** of ``request_timeout`` seconds from the moment a connection is
  ready for a request (opened, or its previous response sent) to the request's last byte:
  not reset per byte. A late request gets 408 and is closed; an idle one is closed.
- **Caps per address and in all**: beyond ``max_per_client`` connections from one address,
  or ``max_connections`` in all, the newcomer is served and the *oldest connection still
  waiting for its request* (from that address, or from the address holding most) is closed
  with 503 — so a flood of slow connections cannot keep a new client, and its stop, out.
  Only when every connection is inside a worker is the newcomer refused (503, Retry-After).
- **Worker pools per route** (:attr:`Route.pool`): ``work`` (plans, moves; ``workers``
  threads, a bounded queue, 503 beyond it), ``read`` (state, health, move status),
  ``control`` (stop: threads nothing else may use) and ``stream`` (long-lived responses, a
  thread each out of ``stream_slots``; exempt from the deadline once their head is in).

Every request is logged (one INFO line on ``robodcn.http``: client, method, path, status,
milliseconds). :func:`robodcn.http.listen.make_server` binds it (a non-loopback address
needs a token, :mod:`robodcn.http.auth`); :func:`robodcn.http.answer.answer` runs an
operation and makes its reply.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import queue
import selectors
import socket
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import robodcn
from robodcn.config import Arm
from robodcn.controller import ArmController
from robodcn.http import limits
from robodcn.http.answer import Operation, answer
from robodcn.http.framing import (
    HTTPError,
    Reply,
    Request,
    RequestReader,
    dumps,
    error_body,
    response,
)
from robodcn.http.gate import Gate
from robodcn.http.openapi import openapi
from robodcn.http.ops import OPERATIONS
from robodcn.http.routes import ROUTES, Route, match
from robodcn.web.events import EventHub

log = logging.getLogger("robodcn.http")

_SERVER = f"robodcn/{robodcn.__version__}"


@dataclass(eq=False)
class Connection:
    sock: socket.socket
    client: str
    reader: RequestReader
    deadline: float
    opened: float = field(default_factory=time.monotonic)
    busy: bool = False       # a worker holds it
    closing: bool = False    # answered and half-closed: draining until EOF or deadline


def _listen(address: tuple[str, int]) -> socket.socket:
    host, port = address
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(128)
    except OSError:
        sock.close()
        raise
    return sock


def url_of(address: tuple) -> str:
    """The http:// URL of a bound (host, port[, …]) address (an IPv6 host in brackets)."""
    host, port = address[:2]
    if ":" in host:
        host = f"[{host}]"
    return f"http://{host}:{port}"


class RobodcnHTTPServer:
    """The HTTP service for ``arm`` (and ``controller``, or None to plan only).

    Use :func:`robodcn.http.listen.make_server`; then ``serve_forever()`` in one thread,
    ``shutdown()`` from another, ``server_close()`` at the end. ``sock``: a listening socket
    to serve on instead of binding ``address`` (a worker of
    :class:`~robodcn.http.prefork.PreforkServer`). ``allow_hosts``: more names it answers
    to (:class:`~robodcn.http.gate.Gate`; the loopback names and the bound address always).
    """

    def __init__(self, address: tuple[str, int], arm: Arm, controller: ArmController | None, *,
                 token: str | None, request_timeout: float,
                 max_connections: int = limits.MAX_CONNECTIONS,
                 max_per_client: int = limits.MAX_PER_CLIENT,
                 workers: int = limits.WORKERS, control_workers: int = limits.CONTROL_WORKERS,
                 stream_slots: int = limits.STREAM_SLOTS,
                 routes: tuple[Route, ...] = ROUTES,
                 operations: dict[str, Operation] | None = None,
                 sock: socket.socket | None = None,
                 allow_hosts: tuple[str, ...] = ()) -> None:
        self.arm = arm
        self.controller = controller
        self.token = token
        self.request_timeout = request_timeout
        self.max_connections = max_connections
        self.max_per_client = max_per_client
        self.routes = routes
        #: Route name → operation (robodcn.http.ops.OPERATIONS and any given here).
        self.operations = {**OPERATIONS, **(operations or {})}
        #: Small plans take turns on plan_lock, large ones on large_plan_lock (ops).
        self.plan_lock = threading.Lock()
        self.large_plan_lock = threading.Lock()
        self.openapi_bytes = dumps(openapi(arm, token=token is not None, routes=routes))
        #: The console's ``GET /v1/events`` streams: one shared sampler of the controller.
        self.events = EventHub(controller)
        self.socket = _listen(address) if sock is None else sock
        self.socket.setblocking(False)
        self.server_address = self.socket.getsockname()
        #: Which Host and Origin values are served (403 otherwise), checked before dispatch.
        self.gate = Gate.of(self.server_address[0], self.server_address[1], allow_hosts)
        self._pools = {"work": ThreadPoolExecutor(workers, "robodcn-http-work"),
                       "read": ThreadPoolExecutor(control_workers, "robodcn-http-read"),
                       "control": ThreadPoolExecutor(control_workers, "robodcn-http-control")}
        # Each connection has at most one request in a pool: a read or stop queue is bounded
        # by the connections, the work queue by WORK_QUEUE.
        self._queue_cap = {"work": workers + limits.WORK_QUEUE,
                           "read": control_workers + 4 * max_per_client,
                           "control": control_workers + 4 * max_per_client}
        self._in_pool = collections.Counter[str]()
        self._stream_slots = threading.BoundedSemaphore(stream_slots)
        self._lock = threading.Lock()
        self._conns: dict[socket.socket, Connection] = {}
        self._returned: queue.SimpleQueue[Connection] = queue.SimpleQueue()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._selector = selectors.DefaultSelector()
        self._stop = threading.Event()
        self._stopped = threading.Event()
        self._stopped.set()

    @property
    def stopping(self) -> bool:
        """Shutdown was requested: streaming operations end their streams."""
        return self._stop.is_set()

    @property
    def url(self) -> str:
        return url_of(self.server_address)

    # -- the selector loop ---------------------------------------------------------------------

    def serve_forever(self, poll_interval: float = 0.5) -> None:
        """Accept, frame and dispatch until :meth:`shutdown`."""
        self._stopped.clear()
        self._selector.register(self.socket, selectors.EVENT_READ, "listen")
        self._selector.register(self._wake_r, selectors.EVENT_READ, "wake")
        try:
            while not self._stop.is_set():
                for key, _ in self._selector.select(self._timeout(poll_interval)):
                    if key.data == "listen":
                        self._accept()
                    elif key.data == "wake":
                        with contextlib.suppress(OSError):
                            self._wake_r.recv(4096)
                    else:
                        self._on_readable(key.data)
                while True:
                    try:
                        conn = self._returned.get_nowait()
                    except queue.Empty:
                        break
                    self._resume(conn)
                self._expire()
        finally:
            for sock in (self.socket, self._wake_r):
                with contextlib.suppress(KeyError, ValueError):
                    self._selector.unregister(sock)
            self._stopped.set()

    def shutdown(self) -> None:
        """Stop :meth:`serve_forever` and wait for it (call from another thread)."""
        self._stop.set()
        self._wake()
        self._stopped.wait()

    def server_close(self) -> None:
        """End the event streams, close every socket and stop the pools (workers in flight
        finish on their own)."""
        self._stop.set()
        self.events.close()
        with self._lock:
            conns = list(self._conns.values())
            self._conns.clear()
        for conn in conns:
            self._close(conn)
        for pool in self._pools.values():
            pool.shutdown(wait=False, cancel_futures=True)
        with contextlib.suppress(OSError):
            self.socket.close()
        for sock in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                sock.close()
        with contextlib.suppress(Exception):
            self._selector.close()

    def _wake(self) -> None:
        with contextlib.suppress(OSError):
            self._wake_w.send(b"\0")

    def _timeout(self, poll_interval: float) -> float:
        now = time.monotonic()
        with self._lock:
            waiting = [c.deadline for c in self._conns.values() if not c.busy]
        nearest = min(waiting, default=now + poll_interval) - now
        return max(0.0, min(poll_interval, nearest))

    def _accept(self) -> None:
        while True:
            try:
                sock, address = self.socket.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                log.warning("accept failed", exc_info=True)
                return
            sock.setblocking(False)
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            conn = Connection(sock, str(address[0]), RequestReader(),
                              time.monotonic() + self.request_timeout)
            if not self._make_room(conn.client):
                log.info("%s refused: every connection is in use", conn.client)
                self._send_and_close(conn, 503, "too_many_connections", "the server has too "
                                     "many requests in progress; retry later",
                                     {"Retry-After": "1"}, drain=False)
                continue
            with self._lock:
                self._conns[sock] = conn
            self._selector.register(sock, selectors.EVENT_READ, conn)

    def _make_room(self, client: str) -> bool:
        """Close the oldest waiting connection when ``client`` or the server is at its cap;
        False when nothing can be closed (every connection is inside a worker)."""
        with self._lock:
            conns = list(self._conns.values())
        per_client = collections.Counter(c.client for c in conns)
        if per_client[client] >= self.max_per_client:
            victims = [c for c in conns if c.client == client and not c.busy]
        elif len(conns) >= self.max_connections:
            heaviest = [a for a, _ in per_client.most_common()]
            victims = []
            for address in heaviest:
                victims = [c for c in conns if c.client == address and not c.busy]
                if victims:
                    break
        else:
            return True
        if not victims:
            return False
        victim = min(victims, key=lambda c: c.opened)
        log.info("%s: closing its oldest waiting connection to admit a new one", victim.client)
        self._forget(victim)
        self._send_and_close(victim, 503, "too_many_connections", "this connection was "
                             "closed to admit a newer one (too many open connections)",
                             {"Retry-After": "1"}, drain=False)
        return True

    def _on_readable(self, conn: Connection) -> None:
        try:
            data = conn.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._forget(conn)
            self._close(conn)
            return
        if conn.closing:
            return  # draining what the client still sends after our final answer
        conn.reader.feed(data)
        self._frame(conn)

    def _resume(self, conn: Connection) -> None:
        """A worker has answered on ``conn`` and keeps it alive: back to the selector."""
        if self._stop.is_set():
            self._forget(conn)
            self._close(conn)
            return
        conn.busy = False
        conn.deadline = time.monotonic() + self.request_timeout
        try:
            if conn.sock.gettimeout() != 0.0:  # a worker wrote it blocking
                conn.sock.setblocking(False)
            self._selector.register(conn.sock, selectors.EVENT_READ, conn)
        except (OSError, ValueError, KeyError):
            self._forget(conn)
            self._close(conn)
            return
        self._frame(conn)  # a pipelined request may already be buffered

    def _frame(self, conn: Connection) -> None:
        """Dispatch every complete request buffered on ``conn`` (pipelining), in turn."""
        while True:
            try:
                request = conn.reader.next_request()
            except HTTPError as exc:
                log.info("%s framing error %d: %s", conn.client, exc.status,
                         exc.body["message"])
                self._forget(conn, keep=True)
                self._send_and_close(conn, exc.status, exc.body["code"], exc.body["message"],
                                     exc.headers, field=exc.body["field"])
                return
            if request is None:
                if conn.reader.wants_continue:
                    conn.reader.wants_continue = False
                    with contextlib.suppress(OSError):
                        conn.sock.send(b"HTTP/1.1 100 Continue\r\n\r\n")
                return
            request.client = conn.client
            if not self._dispatch(conn, request):
                return

    def _expire(self) -> None:
        now = time.monotonic()
        with self._lock:
            late = [c for c in self._conns.values() if not c.busy and c.deadline <= now]
        for conn in late:
            if conn.closing or not conn.reader.started:
                self._forget(conn)
                self._close(conn)
            else:
                log.info("%s request timeout after %g s", conn.client, self.request_timeout)
                self._forget(conn, keep=True)
                self._send_and_close(conn, 408, "request_timeout", f"the request was not "
                                     f"complete within {self.request_timeout:g} s")

    # -- dispatch -------------------------------------------------------------------------------

    def _dispatch(self, conn: Connection, request: Request) -> bool:
        """Hand ``request`` to its pool, or answer it here; True when ``conn`` may frame its
        next request at once (answered inline and kept alive)."""
        started = time.monotonic()
        refused: HTTPError | None = None
        try:
            route, params = match(request.method, request.path, self.routes)
        except HTTPError as exc:
            route, params, refused = None, {}, exc
        try:
            self.gate.check(request, route)
        except HTTPError as exc:
            refused = exc  # a foreign Host or Origin: 403 before anything else
        if refused is not None or route is None:
            # 403/404/405 are answered here, without a worker: a flood of them costs no thread.
            return self._answer_inline(conn, request, refused, started)
        pool = route.pool
        if pool == "stream":
            if not self._stream_slots.acquire(blocking=False):
                return self._answer_inline(conn, request, HTTPError(
                    503, "busy", "too many streams are open; retry later", None,
                    {"Retry-After": "1"}), started)
        else:
            with self._lock:
                full = self._in_pool[pool] >= self._queue_cap[pool]
                if not full:
                    self._in_pool[pool] += 1
            if full:
                return self._answer_inline(conn, request, HTTPError(
                    503, "busy", "the server is busy; retry later", None,
                    {"Retry-After": "1"}), started)
        conn.busy = True
        with contextlib.suppress(KeyError, ValueError):
            self._selector.unregister(conn.sock)
        if pool == "stream":
            threading.Thread(target=self._run_stream, args=(conn, request, route, params,
                                                            started),
                             name="robodcn-http-stream", daemon=True).start()
        else:
            try:
                self._pools[pool].submit(self._run, conn, request, route, params, started)
            except RuntimeError:  # shutting down
                with self._lock:
                    self._in_pool[pool] -= 1
                self._forget(conn)
                self._close(conn)
        return False

    def _answer_inline(self, conn: Connection, request: Request, exc: HTTPError,
                       started: float) -> bool:
        data = response(exc.status, dumps({"error": exc.body}), headers=exc.headers,
                        close=not request.keep_alive, head_only=request.method == "HEAD",
                        server=_SERVER)
        try:
            sent = conn.sock.send(data)
        except OSError:
            sent = -1
        self._log(request, exc.status, started)
        if sent != len(data) or not request.keep_alive:
            self._forget(conn)
            self._close(conn)
            return False
        conn.deadline = time.monotonic() + self.request_timeout
        return True

    def _answer(self, route: Route, request: Request, params: dict[str, str]
                ) -> tuple[int, Reply]:
        return answer(self, self.operations[route.name], route, request, params)

    def _run(self, conn: Connection, request: Request, route: Route, params: dict[str, str],
             started: float) -> None:
        try:
            status, reply = self._answer(route, request, params)
            keep = request.keep_alive and not self._stop.is_set()
            data = response(status, reply.body, headers=reply.headers, close=not keep,
                            head_only=request.method == "HEAD", server=_SERVER,
                            content_type=reply.content_type)
            try:
                self._send_all(conn.sock, data)
            except OSError:
                keep = False
            self._log(request, status, started)
        finally:
            with self._lock:
                self._in_pool[route.pool] -= 1
        if keep:
            self._returned.put(conn)
            self._wake()
        else:
            self._drop(conn)

    @staticmethod
    def _send_all(sock: socket.socket, data: bytes) -> None:
        """Send ``data`` on the non-blocking ``sock``: one ``send`` takes a whole answer of a
        few hundred KiB into the kernel's buffer; only the rest (a client that does not read)
        is written blocking, WRITE_TIMEOUT s per write, and the socket made non-blocking
        again. OSError when the client is gone or stalls."""
        try:
            sent = sock.send(data)
        except (BlockingIOError, InterruptedError):
            sent = 0
        if sent == len(data):
            return
        sock.settimeout(limits.WRITE_TIMEOUT)
        sock.sendall(memoryview(data)[sent:])
        sock.setblocking(False)

    def _run_stream(self, conn: Connection, request: Request, route: Route,
                    params: dict[str, str], started: float) -> None:
        """A streaming operation owns the (blocking) socket until it returns: no request
        deadline once its head is in; it gets ``request.socket`` (with WRITE_TIMEOUT per
        write, so a client that stops reading frees the slot), writes
        :func:`~robodcn.http.framing.stream_head` and its events, and returns
        ``(status, b"")``. Refusing before streaming (an error) is answered here."""
        try:
            conn.sock.setblocking(True)
            conn.sock.settimeout(limits.WRITE_TIMEOUT)
            request.socket = conn.sock
            status, reply = self._answer(route, request, params)
            if reply.body:  # a refusal (or a plain answer) instead of a stream
                with contextlib.suppress(OSError):
                    conn.sock.sendall(response(status, reply.body, headers=reply.headers,
                                               close=True, server=_SERVER,
                                               content_type=reply.content_type,
                                               head_only=request.method == "HEAD"))
            self._log(request, status, started)
        finally:
            self._stream_slots.release()
            self._drop(conn)

    # -- connection bookkeeping ----------------------------------------------------------------

    def _forget(self, conn: Connection, *, keep: bool = False) -> None:
        """Drop ``conn`` from the selector (and, unless ``keep``, from the table)."""
        with contextlib.suppress(KeyError, ValueError, OSError):
            self._selector.unregister(conn.sock)
        if not keep:
            with self._lock:
                self._conns.pop(conn.sock, None)

    def _send_and_close(self, conn: Connection, status: int, code: str, message: str,
                        headers: dict[str, str] | None = None, *, field: str | None = None,
                        drain: bool = True) -> None:
        """A final JSON error, then a half-close; unread bytes are drained (so the client
        reads the answer instead of a reset) until EOF or a short deadline."""
        data = response(status, error_body(status, code, message, field), headers=headers,
                        close=True, server=_SERVER)
        try:
            conn.sock.send(data)
            conn.sock.shutdown(socket.SHUT_WR)
        except OSError:
            drain = False
        if not drain or self._stop.is_set():
            self._forget(conn)
            self._close(conn)
            return
        conn.closing = True
        conn.busy = False
        conn.deadline = time.monotonic() + min(2.0, self.request_timeout)
        with self._lock:
            self._conns[conn.sock] = conn
        with contextlib.suppress(KeyError, ValueError, OSError):
            self._selector.register(conn.sock, selectors.EVENT_READ, conn)

    def _drop(self, conn: Connection) -> None:
        """Forget and close a connection a worker holds (already out of the selector, which
        only the selector thread may touch)."""
        with self._lock:
            self._conns.pop(conn.sock, None)
        self._close(conn)

    @staticmethod
    def _close(conn: Connection) -> None:
        with contextlib.suppress(OSError):
            conn.sock.close()

    @staticmethod
    def _log(request: Request, status: int, started: float) -> None:
        log.info("%s %s %s %d %.1f ms", request.client, request.method, request.path, status,
                 1e3 * (time.monotonic() - started))
