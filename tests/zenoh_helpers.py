"""Zenoh test pieces: services with their Zenoh face on loopback and a test-side peer.

Every session is in peer mode on explicit ``tcp/127.0.0.1:<free port>`` endpoints with
multicast scouting off: the tests never reach (or are reached from) another host.
"""

from __future__ import annotations

import contextlib
import json
import socket
import time
from collections.abc import Iterator
from typing import Any

import zenoh
from http_helpers import serving_arm

from robodcn.zenoh import ZenohOptions, face


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def peer_config(listen: list[str] | None = None, connect: list[str] | None = None
                ) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(listen or ["tcp/127.0.0.1:0"]))
    config.insert_json5("connect/endpoints", json.dumps(connect or []))
    return config


@contextlib.contextmanager
def peer(*endpoints: str) -> Iterator[Any]:
    """A test-side session connected to ``endpoints``."""
    session = zenoh.open(peer_config(connect=list(endpoints)))
    try:
        yield session
    finally:
        session.close()


@contextlib.contextmanager
def zenoh_arm(name: str = "left", **options: Any) -> Iterator[tuple[Any, Any, str]]:
    """A simulated arm served over HTTP with its Zenoh face listening on a free loopback
    port: (server, native face, the endpoint to connect to)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with serving_arm() as (server, _sim), \
            face(server, ZenohOptions(listen=(endpoint,), name=name, **options),
                 url=None) as native:
        yield server, native, endpoint


def query(session: Any, key: str, body: Any = None, *, raw: bytes | None = None,
          timeout: float = 10.0) -> dict[str, Any]:
    """One query's single reply, decoded (AssertionError when none arrives)."""
    payload = raw if raw is not None else (None if body is None else json.dumps(body).encode())
    for reply in session.get(key, payload=payload, timeout=timeout):
        assert reply.ok is not None, reply.err.payload.to_string()
        return json.loads(reply.ok.payload.to_bytes())
    raise AssertionError(f"no reply on {key}")


def wait_for(predicate: Any, timeout: float = 5.0, what: str = "condition") -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")
