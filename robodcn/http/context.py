"""What an operation sees of the server (:class:`Service`), and the arm's controller.

The operations (:mod:`robodcn.http.ops`, :mod:`robodcn.http.online_ops`) take the server
as this protocol, so they do not import :mod:`robodcn.http.server` (which imports them).
"""

from __future__ import annotations

import threading
from typing import Any, Protocol

from robodcn.config import Arm
from robodcn.controller import ArmController
from robodcn.http.framing import HTTPError


class Service(Protocol):
    """The server as its operations use it (:class:`robodcn.http.server.RobodcnHTTPServer`)."""

    arm: Arm
    #: The arm's controller, or None for a plan-only service.
    controller: ArmController | None
    token: str | None
    #: Small plans take turns on plan_lock, large ones on large_plan_lock.
    plan_lock: threading.Lock
    large_plan_lock: threading.Lock
    openapi_bytes: bytes
    #: The console's event hub (robodcn.web.events.EventHub).
    events: Any

    @property
    def stopping(self) -> bool: ...


def controller_of(server: Service) -> ArmController:
    """The server's controller; 503 ``no_arm`` when it only plans."""
    if server.controller is None:
        raise HTTPError(503, "no_arm", "this server only plans: it has no arm attached")
    return server.controller
