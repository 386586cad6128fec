"""Replacing the running move over HTTP: ``POST /v1/moves`` with ``"replace": true``.

While a move runs, the new request is planned from the running move's commanded state
(:meth:`robodcn.stream.Execution.retarget`, through :func:`robodcn.admission.admit`); 202
with the new move, and the old one ends ``replaced``. Without ``replace`` a running move
still answers 409; with it and nothing running, the move starts as usual.
:func:`take_replace` reads the flag, :func:`body_schemas` adds it to the move body. The
other controls of the running motion (stop, pause, resume, speed, follow) are declared once
in :data:`robodcn.controls.CONTROLS`, from which the routes and operations are built.
"""

from __future__ import annotations

import copy
from typing import Any

from robodcn.contract.start_at import START_AT_SCHEMA
from robodcn.errors import InputError


def body_schemas(move_body: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Component schemas of the online bodies; ``move_body`` gains ``replace``."""
    move = copy.deepcopy(move_body)
    move.setdefault("properties", {})["replace"] = {
        "type": "boolean", "default": False,
        "description": "Replace the running move in flight (202, the old one ends "
                       "'replaced'); without it a running move answers 409. A replace "
                       "while another is being planned, or one that would miss its "
                       "switch, answers 409 busy with nothing changed: try again."}
    move["properties"]["start_at"] = START_AT_SCHEMA
    return {"MoveBody": move}


def take_replace(body: Any) -> tuple[Any, bool]:
    """The move body without ``replace``, and its value (InputError naming it if not a
    boolean)."""
    if not isinstance(body, dict) or "replace" not in body:
        return body, False
    body = dict(body)
    replace = body.pop("replace")
    if not isinstance(replace, bool):
        raise InputError(f"replace must be true or false, got {replace!r}", field="replace",
                         value=replace)
    return body, replace
