"""The native key space of one arm, ``robodcn/<arm>/…``, on an open Zenoh session.

- liveliness token ``robodcn/<arm>`` while the service runs (Zenoh drops it when the
  process or its session dies);
- ``robodcn/<arm>/state``: the ``GET /v1/state`` JSON, at ``state_hz`` (100 Hz) while a
  move is queued or running (from the streamer's feedback, no bus traffic) and ``idle_hz``
  (≥ 2 Hz) at rest (one bus read each);
- queryable ``robodcn/<arm>/op/<operationId>`` for every operation of the OpenAPI document
  (:mod:`robodcn.zenoh.dispatch`), answered on worker threads by the route's pool kind so
  a load of plans never delays a stop;
- queryable ``robodcn/<arm>/info``: name, host, process, version, the HTTP URL;
- subscriber ``robodcn/<arm>/follow/target``: a put of a ``PUT /v1/follow/target`` body
  feeds the open follow session (the ``follow_target`` operation) on a thread of its own,
  the newest put replacing one not yet taken (a target stream is only as good as its
  newest); a refused target is counted and logged.

A peer that disappears changes nothing here (a move it started runs on); callbacks never
raise into Zenoh (a bad query is answered, a bad put is counted and logged).
"""

from __future__ import annotations

import json
import logging
import os
import socket
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import robodcn
from robodcn.http.context import Service
from robodcn.zenoh import dispatch
from robodcn.zenoh.options import ZenohOptions

log = logging.getLogger("robodcn.zenoh")

#: Worker threads answering queries, by the route's pool kind (``stream`` is refused).
POOL_SIZES = {"control": 2, "read": 4, "work": 2}
#: Queries a pool holds (running and waiting) before it answers 503 at once.
POOL_BACKLOG = 64
#: The follow operation a ``follow/target`` put feeds (another surface's operation).
FOLLOW_OPERATION = "follow_target"


def arm_key(name: str) -> str:
    """The key prefix of arm ``name``: ``robodcn/<name>``."""
    return f"robodcn/{name}"


class NativeFace:
    """The ``robodcn/<arm>`` keys of one service (``server``: the HTTP server object, whose
    arm, controller and locks the operations use) on ``session``; :meth:`close` undeclares
    them (the session stays the caller's)."""

    def __init__(self, server: Service, session: Any, options: ZenohOptions,
                 *, url: str | None = None) -> None:
        self.server = server
        self.session = session
        self.options = options
        self.name = options.name or server.arm.name
        self.prefix = arm_key(self.name)
        self.url = url
        self.bad_puts = 0
        self.published = 0
        #: The ROS 2 node beside this face (``--ros2``), or None.
        self.ros: Any = None
        #: Called with each state published (the ROS node's /joint_states rides on it).
        self.listeners: list[Callable[[dict[str, Any]], None]] = []
        self._stop = threading.Event()
        self._pools = {kind: ThreadPoolExecutor(n, thread_name_prefix=f"robodcn-zenoh-{kind}")
                       for kind, n in POOL_SIZES.items()}
        self._backlog = {kind: threading.BoundedSemaphore(POOL_BACKLOG) for kind in POOL_SIZES}
        self._declared: list[Any] = []
        self._thread: threading.Thread | None = None
        #: Follow targets handed to the follow operation, and those a newer one replaced
        #: before they were taken.
        self.follow_fed = 0
        self.follow_dropped = 0
        self._follow_lock = threading.Lock()
        self._follow_next: bytes | None = None
        self._follow_wake = threading.Event()
        self._follow_thread: threading.Thread | None = None

    # -- lifecycle ------------------------------------------------------------------------

    def start(self) -> NativeFace:
        s = self.session
        self._declared = [
            s.liveliness().declare_token(self.prefix),
            s.declare_queryable(f"{self.prefix}/op/*", self._on_query, complete=True),
            s.declare_queryable(f"{self.prefix}/info", self._on_info, complete=True),
            s.declare_subscriber(f"{self.prefix}/follow/target", self._on_follow),
        ]
        self._publisher = s.declare_publisher(f"{self.prefix}/state")
        self._declared.append(self._publisher)
        if self.server.controller is not None:
            self._thread = threading.Thread(target=self._publish_state, daemon=True,
                                            name="robodcn-zenoh-state")
            self._thread.start()
        self._follow_thread = threading.Thread(target=self._feed_follow, daemon=True,
                                               name="robodcn-zenoh-follow")
        self._follow_thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        self._follow_wake.set()
        for thread in (self._thread, self._follow_thread):
            if thread is not None:
                thread.join(2.0)
        for entity in reversed(self._declared):
            try:
                entity.undeclare()
            except Exception:  # the session may be closing already
                pass
        for pool in self._pools.values():
            pool.shutdown(wait=False, cancel_futures=True)

    def __enter__(self) -> NativeFace:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- callbacks (Zenoh's threads: hand off, never raise) --------------------------------

    def _on_query(self, query: Any) -> None:
        name = str(query.key_expr).rsplit("/", 1)[-1]
        route = dispatch.BY_NAME.get(name)
        kind = "read" if route is None or route.pool not in self._pools else route.pool
        if not self._backlog[kind].acquire(blocking=False):
            with query:
                query.reply(query.key_expr, json.dumps({"status": 503, "body": {"error": {
                    "code": "busy", "message": f"{POOL_BACKLOG} {kind} queries are waiting "
                    "already: retry later", "field": None}}}).encode(),
                    encoding="application/json")
            return
        try:
            self._pools[kind].submit(self._answer, query, name, self._backlog[kind])
        except RuntimeError:  # shut down
            self._backlog[kind].release()

    def _answer(self, query: Any, name: str, backlog: threading.BoundedSemaphore) -> None:
        try:
            self._reply(query, name)
        finally:
            backlog.release()

    def _reply(self, query: Any, name: str) -> None:
        with query:
            try:
                payload = query.payload.to_bytes() if query.payload is not None else b""
                params = {k: v for k, v in query.parameters}
                result = dispatch.call(self.server, name, payload, params)
            except Exception as exc:  # a bug: answer 500, keep the traceback in the log
                log.exception("zenoh op %s failed", name)
                result = {"status": 500, "body": {"error": {
                    "code": "internal", "message": f"internal error: {type(exc).__name__}",
                    "field": None}}}
            query.reply(query.key_expr, json.dumps(result, allow_nan=False).encode(),
                        encoding="application/json")

    def _on_info(self, query: Any) -> None:
        info = {"name": self.name, "arm": self.server.arm.name, "host": socket.gethostname(),
                "pid": os.getpid(), "version": robodcn.__version__, "http": self.url,
                "dof": self.server.arm.dof, "joint_names": list(self.server.arm.joint_names)}
        with query:
            query.reply(query.key_expr, json.dumps(info).encode(),
                        encoding="application/json")

    def _on_follow(self, sample: Any) -> None:
        """A target put: handed to the follow thread, the newest replacing any not yet
        taken (the follow session heads for the newest target anyway)."""
        with self._follow_lock:
            if self._follow_next is not None:
                self.follow_dropped += 1
            self._follow_next = sample.payload.to_bytes()
        self._follow_wake.set()

    def _feed_follow(self) -> None:
        while not self._stop.is_set():
            self._follow_wake.wait(0.5)
            with self._follow_lock:
                payload, self._follow_next = self._follow_next, None
                self._follow_wake.clear()
            if payload is None:
                continue
            if FOLLOW_OPERATION not in dispatch.BY_NAME:
                self.bad_puts += 1
                if self.bad_puts == 1:
                    log.warning("a follow target arrived on %s/follow/target but this "
                                "service has no %s operation", self.prefix, FOLLOW_OPERATION)
                continue
            try:
                result = dispatch.call(self.server, FOLLOW_OPERATION, payload)
            except Exception:
                log.exception("follow target failed")
                self.bad_puts += 1
                continue
            if result["status"] >= 300:
                self.bad_puts += 1
                log.info("follow target refused (%s): %s", result["status"], result["body"])
            else:
                self.follow_fed += 1

    # -- the state publication -------------------------------------------------------------

    def _publish_state(self) -> None:
        moving_period = 1.0 / self.options.state_hz
        idle_period = 1.0 / self.options.idle_hz
        controller = self.server.controller
        assert controller is not None
        next_tick = time.monotonic()
        while not self._stop.is_set():
            busy = controller.busy
            result = dispatch.call(self.server, "state", None)
            if result["status"] == 200:
                try:
                    self._publisher.put(json.dumps(result["body"]).encode(),
                                        encoding="application/json")
                    self.published += 1
                except Exception as exc:  # a closing session: the loop ends with it
                    log.debug("state put failed: %s", exc)
                for listener in list(self.listeners):
                    try:
                        listener(result["body"])
                    except Exception:
                        log.exception("a state listener failed")
            period = moving_period if busy or controller.busy else idle_period
            next_tick = max(next_tick + period, time.monotonic())
            # wake early when a move starts, so its first samples are not 0.5 s late
            while not self._stop.is_set() and time.monotonic() < next_tick:
                if not busy and controller.busy:
                    break
                self._stop.wait(min(moving_period, max(0.0, next_tick - time.monotonic())))
