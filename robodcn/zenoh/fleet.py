"""``robodcn fleet``: the live arms of a Zenoh network, from their liveliness tokens.

:func:`list_arms` asks for the tokens ``robodcn/*`` (one per running service), then each
arm's ``info`` and ``op/state``; :func:`follow_state` subscribes to ``robodcn/<arm>/state``
of the arms named. Both work on any open session (:func:`robodcn.zenoh.session.open_session`
with the connect endpoints of the network).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robodcn.zenoh.native import arm_key


@dataclass(frozen=True)
class ArmEntry:
    """One live arm: its name, host, whether it moves, its pose (m, rad), joints (rad)."""

    name: str
    host: str | None
    moving: bool | None
    pose: list[float] | None
    joints: list[float] | None
    error: str | None = None


def _ask(session: Any, key: str, timeout: float, payload: bytes | None = None) -> Any:
    for reply in session.get(key, payload=payload, timeout=timeout):
        if reply.ok is not None:
            return json.loads(reply.ok.payload.to_bytes())
    return None


def live_names(session: Any, timeout: float = 2.0) -> list[str]:
    """The names of the arms whose token ``robodcn/<name>`` is alive, sorted."""
    names = set()
    for reply in session.liveliness().get("robodcn/*", timeout=timeout):
        if reply.ok is not None:
            names.add(str(reply.ok.key_expr).split("/", 1)[1])
    return sorted(names)


def list_arms(session: Any, timeout: float = 2.0) -> list[ArmEntry]:
    """Every live arm with its host and present state."""
    entries = []
    for name in live_names(session, timeout):
        info = _ask(session, f"{arm_key(name)}/info", timeout) or {}
        state = _ask(session, f"{arm_key(name)}/op/state", timeout)
        body = (state or {}).get("body") or {}
        error = None if state and state.get("status") == 200 else (
            (body.get("error") or {}).get("message") if isinstance(body, dict) else None)
        ok = state is not None and state.get("status") == 200
        entries.append(ArmEntry(name=name, host=info.get("host"),
                                moving=body.get("moving") if ok else None,
                                pose=body.get("pose") if ok else None,
                                joints=body.get("joints") if ok else None,
                                error=error if not ok else None))
    return entries


def follow_state(session: Any, names: Sequence[str],
                 on_state: Callable[[str, dict[str, Any]], None]) -> list[Any]:
    """Subscribe to the state of each arm in ``names``; ``on_state(name, state)`` per sample.
    Returns the subscribers (undeclare them, or close the session, to stop)."""
    subscribers = []
    for name in names:
        def handler(sample: Any, name: str = name) -> None:
            try:
                on_state(name, json.loads(sample.payload.to_bytes()))
            except ValueError:
                pass  # not JSON: not a robodcn state
        subscribers.append(session.declare_subscriber(f"{arm_key(name)}/state", handler))
    return subscribers
