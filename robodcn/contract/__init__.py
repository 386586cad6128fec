"""The plan request contract, declared once: fields, defaults, JSON Schema, checks, request.

Every field of a plan request (the POST body of ``/v1/trajectories`` and ``/v1/moves``, the
keywords of :func:`robodcn.planner.plan`, the CLI options of ``plan``/``sim``/``move``) is a
:class:`Field` in :data:`FIELDS`: its name, its JSON Schema (types, ``minimum``/``maximum``,
``enum``), its SI unit, the CLI option and the unit the CLI user types, its default
(:data:`DEFAULTS`) and a description. From that one table come

* :func:`request_schema` — the JSON Schema of the request body (OpenAPI ``requestBody``);
* :class:`PlanRequest` / :class:`StartState` — the typed, frozen request, validated on
  construction by the checks below;
* :func:`parse_request` — a JSON body → a validated :class:`PlanRequest`, every error an
  :class:`~robodcn.errors.InputError` (or ``TooLargeError``) whose ``field`` is the JSON
  path of the bad value (``waypoints[2][1]``, ``start_joints[0]``);
* :func:`cli_choices` — the choices of ``--method``, ``--turn``, ``--profile``, ``--elbow``;
* the range checks (:func:`check_number`, :func:`check_choice`, …), which read the bounds
  from the same schemas.

:func:`schema_of` derives the JSON Schema of a result dataclass (Trajectory JSON,
:class:`~robodcn.errors.Violation`, ...) from its field type hints and
``metadata={"description": ..., "schema": ...}``.

Cross-field rules the schema cannot say are in :mod:`.checks`; ``start_state`` excludes
``start_joints`` and, when moving, needs profile ``optimal`` (:class:`PlanRequest`).

Modules: :mod:`.fields` (the table, limits, defaults), :mod:`.schema` (JSON Schemas),
:mod:`.checks`, :mod:`.request`, :mod:`.parse`. Only numpy and the standard library are
imported here, so the planning core stays light.
"""

from __future__ import annotations

from robodcn.contract.checks import (
    check_body,
    check_choice,
    check_duration,
    check_field,
    check_number,
    check_per_segment,
    check_start_joints,
    check_start_state,
    check_tool_ceiling,
    check_waypoints,
    fail,
    intervals,
    waypoint_shape,
)
from robodcn.contract.fields import (
    BETA_METHODS,
    BETA_RANGE,
    DEFAULTS,
    FIELDS,
    HANDS_ON_SPEED,
    MAX_ANGLE,
    MAX_COORDINATE,
    MAX_DURATION,
    MAX_PAYLOAD,
    MAX_SAMPLES,
    MAX_WAYPOINTS,
    MOVE_OMIT,
    TOOL_FIELDS,
    YAWED_WAYPOINTS,
    Defaults,
    Field,
    cli_choices,
    cli_option,
    field,
    hands_on_speed,
    waypoints_field,
)
from robodcn.contract.parse import parse_request
from robodcn.contract.request import PlanRequest, StartState
from robodcn.contract.schema import request_schema, schema_of
from robodcn.errors import BetaIgnoredWarning as BetaIgnoredWarning  # re-exported

__all__ = [
    "BETA_METHODS",
    "BETA_RANGE",
    "DEFAULTS",
    "FIELDS",
    "HANDS_ON_SPEED",
    "MAX_ANGLE",
    "MAX_COORDINATE",
    "MAX_DURATION",
    "MAX_PAYLOAD",
    "MAX_SAMPLES",
    "MAX_WAYPOINTS",
    "MOVE_OMIT",
    "TOOL_FIELDS",
    "YAWED_WAYPOINTS",
    "BetaIgnoredWarning",
    "Defaults",
    "Field",
    "PlanRequest",
    "StartState",
    "check_body",
    "check_choice",
    "check_duration",
    "check_field",
    "check_number",
    "check_per_segment",
    "check_start_joints",
    "check_start_state",
    "check_tool_ceiling",
    "check_waypoints",
    "cli_choices",
    "cli_option",
    "fail",
    "field",
    "hands_on_speed",
    "intervals",
    "parse_request",
    "request_schema",
    "schema_of",
    "waypoint_shape",
    "waypoints_field",
]
