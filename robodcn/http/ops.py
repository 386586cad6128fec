"""The operations: one function per :class:`~robodcn.http.routes.Route` name.

Each takes the :class:`~robodcn.http.server.RobodcnHTTPServer` (arm, controller, locks), the
framed request and its path parameters, and returns ``(status, payload)``: a JSON-ready
object or ready bytes. They raise :class:`~robodcn.http.framing.HTTPError` or a
:class:`~robodcn.errors.RobodcnError`; the server turns either into a JSON error.
"""

from __future__ import annotations

import contextlib
import hmac
import threading
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import robodcn
from robodcn.errors import InputError, RobodcnError, TooLargeError
from robodcn.http import online_ops
from robodcn.http.framing import HTTPError, Reply, Request, stream_head
from robodcn.http.jsonbody import decode_json
from robodcn.http.limits import LARGE_PLAN_SAMPLES, LARGE_PLAN_WAYPOINTS, MAX_RESPONSE
from robodcn.http.planbody import parse_move, parse_plan, parse_trajectory_move
from robodcn.http.results import ArmInfo, Health, RebootAnswer, TorqueAnswer, to_json
from robodcn.planner import PlanRequest, Trajectory, plan_request
from robodcn.present import plan_from_present
from robodcn.web import assets, events
from robodcn.workflow import files, record

if TYPE_CHECKING:
    from robodcn.http.server import RobodcnHTTPServer

Operation = Callable[["RobodcnHTTPServer", Request, dict[str, str]], tuple[int, Any]]


def authorize(server: RobodcnHTTPServer, request: Request) -> None:
    """401 unless a POST carries ``Authorization: Bearer <token>`` (when a token is set).

    Tokens are visible ASCII (checked at startup), so the header's bytes compare exactly.
    """
    token = server.token
    if token is None or request.method != "POST":
        return
    given = request.headers.get("authorization", "")
    scheme, _, value = given.partition(" ")
    if scheme.lower() != "bearer" or not hmac.compare_digest(
            value.strip().encode("latin-1"), token.encode("ascii")):
        raise HTTPError(401, "unauthorized", "this server needs 'Authorization: Bearer "
                        "<token>' on every POST" + (" (the token given is wrong)"
                                                    if given else ""),
                        "Authorization", {"WWW-Authenticate": "Bearer"})


def read_json(request: Request, *, required: bool = True) -> Any:
    """The request body as JSON (411 when required and absent; 415, 400 from decode_json)."""
    if "content-length" not in request.headers and not request.body:
        if required:
            raise HTTPError(411, "length_required", "a JSON body with Content-Length is "
                            "required", "Content-Length")
        return None
    if not request.body and not required:
        return None
    return decode_json(request.body, request.headers.get("content-type"))


def _controller(server: RobodcnHTTPServer) -> Any:
    if server.controller is None:
        raise HTTPError(503, "no_arm", "this server only plans: it has no arm attached")
    return server.controller


def _estimated_samples(req: PlanRequest) -> int | None:
    if req.duration == "auto":
        return None
    return int(req.duration * req.rate_hz) + 1


def _bytes_per_sample(req: PlanRequest) -> int:
    # t, x, y, θ, k joints (≥ 10 characters each as JSON) and k ticks (≥ 5).
    return 10 * (4 + req.arm.dof) + 5 * req.arm.dof


def check_response_size(req: PlanRequest) -> None:
    """413 before planning when the Trajectory JSON would exceed MAX_RESPONSE."""
    samples = _estimated_samples(req)
    if samples is not None and samples * _bytes_per_sample(req) > MAX_RESPONSE:
        most = MAX_RESPONSE // _bytes_per_sample(req)
        raise TooLargeError(f"{samples} samples ({req.duration:g} s at {req.rate_hz:g} Hz) "
                            f"would answer over {MAX_RESPONSE >> 20} MiB of JSON; at most "
                            f"about {most} samples per plan: shorten duration or lower rate_hz",
                            field="duration", value=req.duration)


@contextlib.contextmanager
def planning_lane(server: RobodcnHTTPServer, req: PlanRequest) -> Iterator[None]:
    """Take turns planning: small plans on one lock, large ones on another.

    Planning is CPU-bound under the GIL, so taking turns on a lock lets waiting handlers
    sleep instead of contending (measured +40 % plans/s, 3× lower p99 with 8 clients,
    bench_http). A large plan (many samples or waypoints, or "auto" over many segments)
    takes the other lock, so it never makes the small ones queue behind it.
    """
    samples = _estimated_samples(req)
    large = (len(req.waypoints) > LARGE_PLAN_WAYPOINTS
             or (samples is not None and samples > LARGE_PLAN_SAMPLES)
             or (samples is None and len(req.waypoints) > 16))
    lock: threading.Lock = server.large_plan_lock if large else server.plan_lock
    with lock:
        yield


def op_health(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller = server.controller
    return 200, to_json(Health(status="ok", version=robodcn.__version__, arm=server.arm.name,
                               moving=bool(controller is not None and controller.busy)))


def op_arm(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
           ) -> tuple[int, Any]:
    arm = server.arm
    return 200, to_json(ArmInfo(name=arm.name, dof=arm.dof, joint_names=list(arm.joint_names),
                                servo_ids=list(arm.servo_ids), source=arm.source,
                                config=arm.to_dict()))


def op_plan(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
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


def _given_trajectory(server: RobodcnHTTPServer, body: dict[str, Any]) -> Trajectory:
    """The ``trajectory`` of a move body (Trajectory or JointTrajectory JSON), checked for
    the arm; errors name their JSON path under ``trajectory``."""
    value, rate = parse_trajectory_move(server.arm, body)
    try:
        return files.trajectory_from_data(value, server.arm, rate, source="trajectory")
    except RobodcnError as exc:
        if exc.field and not exc.field.startswith("trajectory"):
            exc.field = f"trajectory.{exc.field}"
        raise


def op_start_move(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
                  ) -> tuple[int, Any]:
    controller = _controller(server)
    body, replace = online_ops.take_replace(read_json(request))
    given = _given_trajectory(server, body) if isinstance(body, dict) and \
        "trajectory" in body else None
    req = None if given is not None else parse_move(server.arm, body)
    if replace and controller.busy:
        if given is not None:
            raise InputError("replace takes waypoints: a given trajectory cannot take over a "
                             "running move in flight (stop it first)", field="replace",
                             value=True)
        return online_ops.replace_move(server, controller, req)
    # Plan from where the arm is (409 at once if it is moving), so an infeasible approach
    # is a 422 now rather than a failed move later, and the record shows what will run.
    with controller.admitting():
        present = controller.present_joints()
        if given is not None:
            trajectory = files.with_approach(given, server.arm, present)
            if trajectory is not given:  # the samples prepended are the approach
                trajectory.approach_samples = len(trajectory.t) - len(given.t)
        else:
            with planning_lane(server, req):
                trajectory = plan_from_present(server.arm, None, req, joints=present)
        moving = controller.start_move(trajectory)
    return 202, controller.move_info(moving.id)


def _move(server: RobodcnHTTPServer, move_id: str) -> Any:
    found = _controller(server).move(move_id)
    if found is None:
        raise HTTPError(404, "not_found", f"no move {move_id!r} (the service keeps the most "
                        "recent moves only)", "id")
    return found


def op_move_trajectory(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
                       ) -> tuple[int, Any]:
    return 200, _move(server, params["id"]).trajectory.to_json().encode()


def op_move_record(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
                   ) -> tuple[int, Any]:
    _move(server, params["id"])
    samples = server.controller.recording(params["id"]) or []
    if "text/csv" in request.headers.get("accept", "").lower():
        return 200, Reply(record.recording_csv(server.arm, samples).encode(),
                          "text/csv; charset=utf-8")
    return 200, {"move": params["id"], **record.recording(server.arm, samples)}


def _admin_body(server: RobodcnHTTPServer, body: Any, fields: tuple[str, ...],
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


def op_torque(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller = _controller(server)
    body = _admin_body(server, read_json(request), ("on", "joint"), "torque")
    if not isinstance(body.get("on"), bool):
        raise InputError(f"on must be true or false, got {body.get('on')!r}"
                         if "on" in body else "on is missing: true or false", field="on")
    ids = controller.set_torque(body["on"], body.get("joint"))
    return 200, to_json(TorqueAnswer(on=body["on"], joint=body.get("joint"),
                                     servo_ids=list(ids)))


def op_reboot(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    controller = _controller(server)
    body = read_json(request, required=False) if request.body else {}
    body = _admin_body(server, body, ("joint",), "reboot")
    ids = controller.reboot(body.get("joint"))
    return 200, to_json(RebootAnswer(joint=body.get("joint"), servo_ids=list(ids)))


def op_events(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    _controller(server)
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


def op_console(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
               ) -> tuple[int, Any]:
    return _asset(request, assets.INDEX)


def op_static(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
              ) -> tuple[int, Any]:
    return _asset(request, params["name"])


def op_get_move(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
                ) -> tuple[int, Any]:
    _move(server, params["id"])
    return 200, server.controller.move_info(params["id"])


def op_stop(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
            ) -> tuple[int, Any]:
    controller = _controller(server)
    body = read_json(request, required=False) if request.body else {}
    return 200, controller.stop_move(online_ops.stop_mode(body))


def op_state(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
             ) -> tuple[int, Any]:
    return 200, _controller(server).state()


def op_openapi(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
               ) -> tuple[int, Any]:
    return 200, server.openapi_bytes


OPERATIONS: dict[str, Operation] = {name.removeprefix("op_"): fn for name, fn in
                                    dict(globals()).items() if name.startswith("op_")}
OPERATIONS.update(online_ops.OPERATIONS)
