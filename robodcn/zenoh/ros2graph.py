"""One ROS 2 node on rmw_zenoh's wire: its graph tokens, publishers, subscriptions and
service servers, on an open Zenoh session (the bytes from :mod:`robodcn.ros2`).

Every entity declares its liveliness token (``@ros2_lv/…``, what ``ros2 node list`` and
``ros2 topic list`` read), puts and replies carry the 33-byte attachment (sequence number,
source timestamp, the entity's GID; a service reply the request's sequence number and the
client's GID), payloads are CDR. A payload that does not decode is counted and logged,
never raised into Zenoh.
"""

from __future__ import annotations

import itertools
import logging
import os
import threading
import time
from collections.abc import Callable
from typing import Any

from robodcn.errors import InputError
from robodcn.ros2 import cdr, wire

log = logging.getLogger("robodcn.ros2")

#: rclcpp's default QoS of publishers, subscriptions and services: reliable, volatile,
#: keep last 10.
DEFAULT_QOS = wire.QoS(depth=10)


class Publisher:
    """A ROS 2 publisher of ``type_name`` on ``topic`` over a Zenoh publisher:
    ``publish(dict)`` encodes and puts with the attachment (sequence number counted from 1,
    the send time, the publisher's random GID)."""

    def __init__(self, topic: str, type_name: str, zenoh_publisher: Any) -> None:
        self.type_name = type_name
        self.topic = topic
        self.gid = os.urandom(wire.GID_SIZE)
        self._pub = zenoh_publisher
        self._seq = itertools.count(1)
        self._lock = threading.Lock()

    def publish(self, message: dict[str, Any]) -> None:
        payload = cdr.encode(self.type_name, message)
        with self._lock:
            att = wire.attachment(next(self._seq), time.time_ns(), self.gid)
            self._pub.put(payload, attachment=att)


class Node:
    """The node ``name`` in ``domain`` on ``session``; entities are declared with
    :meth:`publisher`, :meth:`subscription` and :meth:`service`; :meth:`close` undeclares
    them all (the session stays the caller's)."""

    def __init__(self, session: Any, domain: int, name: str, namespace: str = "/") -> None:
        self.session = session
        self.domain = domain
        self.ident = wire.Node(domain=domain, zid=str(session.info.zid()), node_id=0,
                               name=name, namespace=namespace)
        self._ids = itertools.count(1)
        self._declared: list[Any] = [
            session.liveliness().declare_token(self.ident.node_token())]
        #: Payloads that did not decode or requests without a valid attachment.
        self.bad_payloads = 0

    def _token(self, kind: wire.Kind, topic: str, type_name: str, qos: wire.QoS) -> None:
        token = self.ident.entity_token(next(self._ids), kind, topic, type_name, qos)
        self._declared.append(self.session.liveliness().declare_token(token))

    def publisher(self, topic: str, type_name: str, qos: wire.QoS = DEFAULT_QOS
                  ) -> Publisher:
        """A publisher; TRANSIENT_LOCAL keeps the last ``qos.depth`` samples for late
        subscribers (zenoh-ext's AdvancedPublisher with a cache and publisher detection, as
        rmw_zenoh)."""
        key = wire.topic_key(self.domain, topic, type_name)
        if qos.durability == wire.TRANSIENT_LOCAL:
            from zenoh import ext

            pub = ext.declare_advanced_publisher(
                self.session, key, cache=ext.CacheConfig(max_samples=qos.depth),
                publisher_detection=True)
        else:
            pub = self.session.declare_publisher(key)
        self._declared.append(pub)
        self._token("MP", topic, type_name, qos)
        return Publisher(topic, type_name, pub)

    def subscription(self, topic: str, type_name: str,
                     callback: Callable[[dict[str, Any]], None],
                     qos: wire.QoS = DEFAULT_QOS) -> None:
        """Call ``callback(message)`` for each sample (decoded) on ``topic``."""
        def on_sample(sample: Any) -> None:
            try:
                message = cdr.decode(type_name, sample.payload.to_bytes())
            except InputError as exc:
                self.bad_payloads += 1
                log.warning("%s: a %s that does not decode: %s", topic, type_name, exc)
                return
            try:
                callback(message)
            except Exception:
                log.exception("%s: handling a sample failed", topic)

        key = wire.topic_key(self.domain, topic, type_name)
        self._declared.append(self.session.declare_subscriber(key, on_sample))
        self._token("MS", topic, type_name, qos)

    def service(self, name: str, type_name: str,
                handler: Callable[[dict[str, Any]], dict[str, Any] | None],
                run: Callable[[Callable[[], None]], None]) -> None:
        """Serve ``name`` (a service type ``pkg/srv/Foo`` or an action part): for each
        request, ``run(job)`` runs ``job`` (e.g. on a worker thread), which calls
        ``handler(request) → response`` (None: no reply) and replies with the request's
        sequence number and the client's GID."""
        request_type, response_type = f"{type_name}_Request", f"{type_name}_Response"
        key = wire.topic_key(self.domain, name, type_name)

        def on_query(query: Any) -> None:
            def job() -> None:
                with query:
                    try:
                        attachment = query.attachment
                        seq, _, gid = wire.read_attachment(
                            attachment.to_bytes() if attachment is not None else b"")
                        payload = query.payload.to_bytes() if query.payload else b""
                        request = cdr.decode(request_type, payload)
                    except InputError as exc:
                        self.bad_payloads += 1
                        log.warning("%s: a bad request: %s", name, exc)
                        return
                    response = handler(request)
                    if response is None:
                        return
                    query.reply(query.key_expr, cdr.encode(response_type, response),
                                attachment=wire.attachment(seq, time.time_ns(), gid))
            run(job)

        self._declared.append(self.session.declare_queryable(key, on_query, complete=True))
        self._token("SS", name, type_name, DEFAULT_QOS)

    def close(self) -> None:
        for entity in reversed(self._declared):
            try:
                entity.undeclare()
            except Exception:  # a closing session
                pass
        self._declared.clear()
