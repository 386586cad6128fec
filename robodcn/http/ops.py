"""The operations: one function per :class:`~robodcn.http.routes.Route` name.

Each takes the server (as :class:`~robodcn.http.context.Service`: arm, controller, locks),
the framed request and its path parameters, and returns ``(status, payload)``: a typed
result, a JSON-ready object or ready bytes. They raise
:class:`~robodcn.http.framing.HTTPError` or a :class:`~robodcn.errors.RobodcnError`;
:func:`robodcn.http.answer.answer` turns either into the reply.
"""

from __future__ import annotations

from typing import Any

import robodcn
from robodcn.admission import MoveOrder, admit
from robodcn.contract.start_at import take_start_at
from robodcn.controls import CONTROLS, Control
from robodcn.errors import InputError, RobodcnError, TooLargeError
from robodcn.http import online_ops
from robodcn.http.answer import Operation
from robodcn.http.context import Service, controller_of
from robodcn.http.framing import HTTPError, Reply, Request, stream_head
from robodcn.http.jsonbody import read_json
from robodcn.http.limits import MAX_RESPONSE
from robodcn.http.planbody import (
    check_move,
    from_present,
    parse_move,
    parse_plan,
    parse_trajectory_move,
)
from robodcn.http.planning import check_response_size, planning_lane
from robodcn.planner import Trajectory, plan_request
from robodcn.results import ArmInfo, ExecutionInfo, Health
from robodcn.web import assets, events
from robodcn.workflow import files, record


def op_health(server: Service, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    """200 while the arm can be driven; 503 with the reason (the bus lost or faulted, a
    servo's hardware error: :meth:`~robodcn.controller.ArmController.check_bus`)."""
    controller = server.controller
    if controller is not None:
        controller.check_bus()
    return 200, Health(status="ok", version=robodcn.__version__, arm=server.arm.name,
                       moving=bool(controller is not None and controller.busy))


def op_arm(server: Service, request: Request, params: dict[str, str]
           ) -> tuple[int, Any]:
    arm, controller = server.arm, server.controller
    execution = None if controller is None else ExecutionInfo.of(controller.execute_options)
    return 200, ArmInfo(name=arm.name, dof=arm.dof, joint_names=list(arm.joint_names),
                        servo_ids=list(arm.servo_ids), source=arm.source, config=arm.to_dict(),
                        pose_axes=list(arm.pose_keys), payload_kg=arm.payload_kg,
                        gripper=arm.gripper is not None, execution=execution,
                        keep_out=arm.workspace.zone_list(planar=not arm.yawed))


def op_plan(server: Service, request: Request, params: dict[str, str]
            ) -> tuple[int, Any]:
    req = parse_plan(server.arm, read_json(request))
    check_response_size(req)
    with planning_lane(server, req):
        trajectory: Trajectory = plan_request(req)
    body = trajectory.to_json().encode()
    if len(body) > MAX_RESPONSE:
        raise TooLargeError(f"the plan has {len(trajectory.t)} samples, over "
                            f"{MAX_RESPONSE >> 20} MiB of JSON: shorten the motion or lower "
                            "rate_hz", field="duration", value=req.duration)
    return 200, body


def _given_trajectory(server: Service, body: dict[str, Any]) -> Trajectory:
    """The ``trajectory`` of a move body (Trajectory or JointTrajectory JSON), checked for
    the arm; errors name their JSON path under ``trajectory``."""
    value, rate = parse_trajectory_move(server.arm, body)
    try:
        return files.trajectory_from_data(value, server.arm, rate, source="trajectory")
    except RobodcnError as exc:
        if exc.field and not exc.field.startswith("trajectory"):
            exc.field = f"trajectory.{exc.field}"
        raise


def move_order(server: Service, body: Any) -> MoveOrder:
    """The :class:`~robodcn.admission.MoveOrder` of a ``POST /v1/moves`` body: waypoints to
    plan, or a given trajectory; with or without ``replace``. One waypoint is a move from
    the present state: its body is parsed by admission once the present joints are read
    (its own rules are checked now)."""
    body, replace = online_ops.take_replace(body)
    body, start_at = take_start_at(body)
    if isinstance(body, dict) and "trajectory" in body:
        return MoveOrder(trajectory=_given_trajectory(server, body), replace=replace,
                         start_at=start_at)
    if from_present(body):
        check_move(body)
        arm = server.arm
        return MoveOrder(parse=lambda joints: parse_move(arm, body, joints), replace=replace,
                         start_at=start_at)
    return MoveOrder(request=parse_move(server.arm, body), replace=replace, start_at=start_at)


def op_start_move(server: Service, request: Request, params: dict[str, str]
                  ) -> tuple[int, Any]:
    controller = controller_of(server)
    order = move_order(server, read_json(request))
    moving = admit(controller, order, planning=lambda req: planning_lane(server, req))
    return 202, controller.move_info(moving.id)


def _move(server: Service, move_id: str) -> Any:
    found = controller_of(server).move(move_id)
    if found is None:
        raise HTTPError(404, "not_found", f"no move {move_id!r} (the service keeps the most "
                        "recent moves only)", "id")
    return found


def op_move_trajectory(server: Service, request: Request, params: dict[str, str]
                       ) -> tuple[int, Any]:
    return 200, _move(server, params["id"]).trajectory.to_json().encode()


def op_move_record(server: Service, request: Request, params: dict[str, str]
                   ) -> tuple[int, Any]:
    _move(server, params["id"])
    samples = controller_of(server).recording(params["id"]) or []
    if "text/csv" in request.headers.get("accept", "").lower():
        return 200, Reply(record.recording_csv(server.arm, samples).encode(),
                          "text/csv; charset=utf-8")
    return 200, {"move": params["id"], **record.recording(server.arm, samples)}


def _admin_body(server: Service, body: Any, fields: tuple[str, ...],
                what: str) -> dict[str, Any]:
    """A torque/reboot body: an object of ``fields`` only, ``joint`` one of the arm's."""
    if not isinstance(body, dict):
        raise InputError(f"the {what} body must be a JSON object", field="body")
    extra = sorted(set(body) - set(fields))
    if extra:
        raise InputError(f"unknown field {extra[0]!r}: {what} takes "
                         f"{' and '.join(fields)}", field=extra[0])
    if "joint" in body and body["joint"] not in server.arm.joint_names:
        raise InputError(f"joint {body['joint']!r} is not a joint of arm "
                         f"{server.arm.name!r} (joints: {', '.join(server.arm.joint_names)})",
                         field="joint")
    return body


def op_torque(server: Service, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller = controller_of(server)
    body = _admin_body(server, read_json(request), ("on", "joint", "confirm"), "torque")
    if not isinstance(body.get("on"), bool):
        raise InputError(f"on must be true or false, got {body.get('on')!r}"
                         if "on" in body else "on is missing: true or false", field="on")
    return 200, controller.set_torque(body["on"], body.get("joint"),
                                      confirm=body.get("confirm", False))


def op_gripper(server: Service, request: Request, params: dict[str, str]
               ) -> tuple[int, Any]:
    controller = controller_of(server)
    arm = server.arm
    if arm.gripper is None:
        raise HTTPError(404, "not_found", f"arm {arm.name!r} has no gripper (a [gripper] "
                        "table in its file)", "gripper")
    body = _admin_body(server, read_json(request), ("command", "width_m"), "gripper")
    return 200, controller.gripper(body.get("command"), width_m=body.get("width_m"))


def op_reboot(server: Service, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller = controller_of(server)
    body = _admin_body(server, read_json(request), ("joint", "confirm"), "reboot")
    return 200, controller.reboot(body.get("joint"), confirm=body.get("confirm", False))


def op_events(server: Service, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller_of(server)
    head = stream_head(content_type="text/event-stream; charset=utf-8",
                       headers=events.STREAM_HEADERS, server=f"robodcn/{robodcn.__version__}")
    if request.method == "HEAD":
        request.socket.sendall(head)
        return 200, b""
    hub = server.events
    if not events.serve(request.socket, hub, head, lambda: server.stopping):
        raise HTTPError(503, "too_many_clients", f"{hub.max_clients} event streams are open "
                        "already (the limit); close one or retry later", None,
                        {"Retry-After": "2"})
    return 200, b""


def _asset(request: Request, name: str) -> tuple[int, Any]:
    found = assets.answer(name, request.headers.get("if-none-match"))
    if found is None:
        raise HTTPError(404, "not_found", f"no console file {name!r}", "name")
    status, body, content_type, headers = found
    return status, Reply(body, content_type, headers)


def op_console(server: Service, request: Request, params: dict[str, str]
               ) -> tuple[int, Any]:
    return _asset(request, assets.INDEX)


def op_static(server: Service, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    return _asset(request, params["name"])


def op_get_move(server: Service, request: Request, params: dict[str, str]
                ) -> tuple[int, Any]:
    _move(server, params["id"])
    return 200, controller_of(server).move_info(params["id"])


def op_state(server: Service, request: Request, params: dict[str, str]
             ) -> tuple[int, Any]:
    return 200, controller_of(server).state()


def op_openapi(server: Service, request: Request, params: dict[str, str]
               ) -> tuple[int, Any]:
    return 200, server.openapi_bytes


OPERATIONS: dict[str, Operation] = {name.removeprefix("op_"): fn for name, fn in
                                    dict(globals()).items() if name.startswith("op_")}


def _control(control: Control) -> Operation:
    """The HTTP operation of a control (robodcn.controls): its JSON body to its ``run``."""
    def op(server: Service, request: Request, params: dict[str, str]) -> tuple[int, Any]:
        return control.ok, control.run(controller_of(server), read_json(request))
    op.__name__ = f"op_{control.name}"
    return op


OPERATIONS.update({c.name: _control(c) for c in CONTROLS})
