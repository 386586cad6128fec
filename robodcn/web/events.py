"""``GET /v1/events``: the arm's live state as Server-Sent Events, shared by every client.

One :class:`EventHub` per server. Its sampler thread starts with the first client and ends
with the last, so N open consoles cost one state read per period, not N. It publishes three
named events (``data:`` is one JSON object of the type :data:`robodcn.results.EVENTS` names,
as ``/openapi.json`` documents it):

``state``
    :meth:`ArmController.state` plus ``"move_info"`` (id, status, progress, elapsed,
    duration, tracking_error of the latest move) and ``"time"`` (Unix s): at
    :data:`MOVING_HZ` while a move is queued or running (read from the streamer's feedback,
    no bus traffic), at :data:`IDLE_HZ` at rest (one bus read each).
``move``
    The latest move's record (``GET /v1/moves/{id}``) whenever its id or status changes.
``alert``
    ``{"alerts": {servo id: text}, "error": {code, message, field} | null}`` whenever the
    servos' hardware alerts or the state read's failure change.

Between events a ``: keep-alive`` comment goes out every :data:`KEEPALIVE_S` s. Each client is
served in its connection's own thread (:func:`serve`, from the HTTP server's ``stream`` pool),
which ends as soon as the client closes its socket or stops reading, or the server shuts down;
past :data:`MAX_CLIENTS` a client gets 503 at once.
"""

from __future__ import annotations

import collections
import dataclasses
import json
import logging
import select
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

from robodcn.errors import RobodcnError
from robodcn.results import MoveInfo, to_json

log = logging.getLogger("robodcn.web.events")

#: Event streams served at once (each holds a connection thread); more get 503.
MAX_CLIENTS = 8
#: State events per second while a move is queued or running (the console plots them).
MOVING_HZ = 40.0
#: State events per second at rest (each is one bus read).
IDLE_HZ = 2.0
#: Seconds between keep-alive comments when nothing else was sent.
KEEPALIVE_S = 10.0
#: Events queued per client; a client further behind loses its oldest ones.
QUEUE_LENGTH = 256
#: Longest wait between checks that the client is still connected (s).
_POLL_S = 0.25
_ACTIVE = ("queued", "running", "following")
#: The keys of a state event's ``move_info`` (robodcn.results.MoveInfo).
_MOVE_KEYS = tuple(f.name for f in dataclasses.fields(MoveInfo))


def encode(name: str, data: Any) -> bytes:
    """One SSE message: ``event: name`` and its JSON on a single ``data:`` line."""
    return f"event: {name}\ndata: {json.dumps(data, separators=(',', ':'))}\n\n".encode()


class _Client:
    """One subscriber: a bounded queue of encoded events and a condition to wake it."""

    def __init__(self) -> None:
        self.cond = threading.Condition()
        self.queue: collections.deque[bytes] = collections.deque(maxlen=QUEUE_LENGTH)
        self.closed = False

    def put(self, message: bytes) -> None:
        with self.cond:
            self.queue.append(message)
            self.cond.notify()

    def close(self) -> None:
        with self.cond:
            self.closed = True
            self.cond.notify()

    def take(self, timeout: float) -> list[bytes] | None:
        """Queued messages (possibly none after ``timeout``), or None once closed."""
        with self.cond:
            if not self.queue and not self.closed:
                self.cond.wait(timeout)
            if self.closed:
                return None
            out = list(self.queue)
            self.queue.clear()
            return out


class EventHub:
    """Samples ``controller`` on one thread and fans the events out to every subscriber.

    Parameters
    ----------
    controller : robodcn.controller.ArmController (anything with ``state()``, ``moves()``
        and ``move_info(id)``), or None for a plan-only server (no client is admitted)
    max_clients, moving_hz, idle_hz, keepalive_s : see the module constants
    """

    def __init__(self, controller: Any, *, max_clients: int = MAX_CLIENTS,
                 moving_hz: float = MOVING_HZ, idle_hz: float = IDLE_HZ,
                 keepalive_s: float = KEEPALIVE_S) -> None:
        self.controller = controller
        self.max_clients = max_clients
        self.moving_period = 1.0 / moving_hz
        self.idle_period = 1.0 / idle_hz
        self.keepalive_s = keepalive_s
        self._lock = threading.Lock()
        self._clients: set[_Client] = set()
        self._thread: threading.Thread | None = None
        self._wake = threading.Event()
        self._closed = False
        #: The latest message of each name, sent first to a client that joins.
        self._latest: dict[str, bytes] = {}
        #: State reads made so far (shared by all clients: one sampler).
        self.samples = 0

    @property
    def clients(self) -> int:
        with self._lock:
            return len(self._clients)

    @property
    def sampling(self) -> bool:
        """The sampler thread is running."""
        with self._lock:
            return self._thread is not None

    def subscribe(self) -> _Client | None:
        """A new subscriber (the latest events already queued), or None at the cap/closed."""
        with self._lock:
            if self._closed or len(self._clients) >= self.max_clients:
                return None
            client = _Client()
            for message in self._latest.values():
                client.put(message)
            self._clients.add(client)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="robodcn-events",
                                                daemon=True)
                self._thread.start()
        return client

    def unsubscribe(self, client: _Client) -> None:
        client.close()
        with self._lock:
            self._clients.discard(client)
        self._wake.set()  # the sampler notices an empty hub at once

    def close(self) -> None:
        """End every stream and the sampler (the server is shutting down). Idempotent."""
        with self._lock:
            self._closed = True
            clients = list(self._clients)
            self._clients.clear()
        for client in clients:
            client.close()
        self._wake.set()

    def _publish(self, name: str, data: Any) -> None:
        message = encode(name, data)
        with self._lock:
            self._latest[name] = message
            clients = list(self._clients)
        for client in clients:
            client.put(message)

    # -- the sampler ----------------------------------------------------------------------

    def _run(self) -> None:
        move_key: tuple[Any, ...] | None = None
        alert_key: str | None = None
        next_state = 0.0
        next_tick = time.monotonic()
        while True:
            with self._lock:
                if self._closed or not self._clients:
                    self._thread = None
                    self._latest.clear()
                    return
            self._wake.clear()
            now = time.monotonic()
            try:
                info = self._latest_move()
            except RobodcnError:
                info = None
            if info is not None and (info["id"], info["status"]) != move_key:
                move_key = (info["id"], info["status"])
                self._publish("move", info)
            moving = info is not None and info["status"] in _ACTIVE
            if moving or now >= next_state:
                next_state = now + self.idle_period
                state, error = self._read_state()
                if state is not None:
                    state["move_info"] = None if info is None else {
                        k: info.get(k) for k in _MOVE_KEYS}
                    state["time"] = time.time()
                    self._publish("state", state)
                alerts = {} if state is None else state.get("alerts") or {}
                key = json.dumps([alerts, error], sort_keys=True)
                if key != alert_key and (alert_key is not None or alerts or error):
                    self._publish("alert", {"alerts": alerts, "error": error})
                alert_key = key
            # An absolute schedule (no drift), but no burst to catch up after a slow read.
            next_tick = max(next_tick + self.moving_period, time.monotonic())
            self._wake.wait(max(0.0, next_tick - time.monotonic()))

    def _latest_move(self) -> dict[str, Any] | None:
        records = self.controller.moves()
        if not records:
            return None
        info = self.controller.move_info(records[-1].id)
        return None if info is None else to_json(info)

    def _read_state(self) -> tuple[dict[str, Any] | None, dict[str, Any] | None]:
        self.samples += 1
        try:
            return to_json(self.controller.state()), None
        except RobodcnError as exc:
            log.info("state read for the event stream failed: %s", exc.message)
            return None, exc.to_dict()


# -- one client's stream --------------------------------------------------------------------

def _client_gone(sock: socket.socket) -> bool:
    """The peer has closed (or reset) the connection: readable with nothing to read."""
    try:
        readable, _, _ = select.select([sock], [], [], 0)
        if not readable:
            return False
        return sock.recv(1, socket.MSG_PEEK) == b""
    except (OSError, ValueError):
        return True


#: Headers of an event stream besides those of :func:`robodcn.http.framing.stream_head`.
STREAM_HEADERS = {"X-Accel-Buffering": "no"}


def serve(sock: socket.socket, hub: EventHub, head: bytes,
          stopping: Callable[[], bool] = lambda: False) -> bool:
    """Stream ``hub``'s events on the connected ``sock`` until the client goes, the hub
    closes or ``stopping()``; False (nothing written) when the hub is full or closed.

    Writes ``head`` (the status line and headers, :func:`robodcn.http.framing.stream_head`)
    first. ``sock`` is blocking with a write timeout (the server's), so a client that stops
    reading ends its stream instead of holding the slot; an event stream has no length, so
    the connection closes after it.
    """
    client = hub.subscribe()
    if client is None:
        return False
    try:
        # retry: how long the browser's EventSource waits before reconnecting by itself.
        sock.sendall(head + b"retry: 1000\n\n")
        quiet_since = time.monotonic()
        while not stopping() and not _client_gone(sock):
            messages = client.take(_POLL_S)
            if messages is None:
                break
            if messages:
                sock.sendall(b"".join(messages))
                quiet_since = time.monotonic()
            elif time.monotonic() - quiet_since >= hub.keepalive_s:
                sock.sendall(b": keep-alive\n\n")
                quiet_since = time.monotonic()
    except (OSError, ValueError):
        # BrokenPipe, ConnectionReset, a write timeout, or a socket already closed: the
        # client went away, which is how every stream ends.
        log.debug("event stream ended", exc_info=True)
    finally:
        hub.unsubscribe(client)
    return True
