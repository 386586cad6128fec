"""Plan and move bodies, from :mod:`robodcn.contract` (the one definition of the request).

The parsing is :func:`robodcn.contract.parse_request` and the schema
:func:`robodcn.contract.request_schema`; a move body omits
:data:`robodcn.contract.MOVE_OMIT` (a move starts from the arm's present joints).
:data:`PLAN_FIELDS`, :data:`MOVE_FIELDS` and :func:`parse_plan_body` are kept for the old
``robodcn.http_server`` import path, derived from the contract.
"""

from __future__ import annotations

from typing import Any

from robodcn import contract
from robodcn.config import Arm
from robodcn.planner import PlanRequest


def plan_body_schema(arm: Arm | None = None) -> dict[str, Any]:
    """JSON Schema of a ``POST /v1/trajectories`` body."""
    return contract.request_schema(arm)


def move_body_schema(arm: Arm | None = None) -> dict[str, Any]:
    """JSON Schema of a ``POST /v1/moves`` body."""
    return contract.request_schema(arm, omit=contract.MOVE_OMIT)


def parse_plan(arm: Arm, body: Any) -> PlanRequest:
    """A decoded ``/v1/trajectories`` body → a validated PlanRequest (InputError naming the
    JSON path of the bad value; TooLargeError for the caps, all before planning)."""
    return contract.parse_request(body, arm)


def parse_move(arm: Arm, body: Any) -> PlanRequest:
    """A decoded ``/v1/moves`` body → a validated PlanRequest without start_joints."""
    return contract.parse_request(body, arm, omit=contract.MOVE_OMIT)


def _fields(omit: tuple[str, ...] = ()) -> dict[str, tuple[dict[str, Any], str]]:
    props = contract.request_schema(omit=omit)["properties"]
    return {name: ({k: v for k, v in s.items() if k != "description"}, s["description"])
            for name, s in props.items()}


#: name → (JSON schema, description) of a plan body (derived from the contract).
PLAN_FIELDS = _fields()
#: The same for a move body.
MOVE_FIELDS = _fields(contract.MOVE_OMIT)


def parse_plan_body(arm: Arm, body: Any, fields: dict[str, Any] = PLAN_FIELDS) -> PlanRequest:
    """Compatibility: :func:`parse_plan`, or :func:`parse_move` for ``MOVE_FIELDS``."""
    return parse_move(arm, body) if "start_joints" not in fields else parse_plan(arm, body)
