"""The operations: one function per :class:`~robodcn.http.routes.Route` name.

Each takes the :class:`~robodcn.http.server.RobodcnHTTPServer` (arm, controller, locks), the
framed request and its path parameters, and returns ``(status, payload)``: a JSON-ready
object or ready bytes. They raise :class:`~robodcn.http.framing.HTTPError` or a
:class:`~robodcn.errors.RobodcnError`; the server turns either into a JSON error.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hmac
import threading
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import robodcn
from robodcn.errors import TooLargeError
from robodcn.http import online_ops
from robodcn.http.framing import HTTPError, Request
from robodcn.http.jsonbody import decode_json
from robodcn.http.limits import LARGE_PLAN_SAMPLES, LARGE_PLAN_WAYPOINTS, MAX_RESPONSE
from robodcn.http.planbody import parse_move, parse_plan
from robodcn.http.results import ArmInfo, Health, to_json
from robodcn.planner import PlanRequest, Trajectory, plan_request

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


def op_start_move(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
                  ) -> tuple[int, Any]:
    controller = _controller(server)
    body, replace = online_ops.take_replace(read_json(request))
    req = parse_move(server.arm, body)
    if replace and controller.busy:
        return online_ops.replace_move(server, controller, req)
    # Plan from where the arm is (409 at once if it is moving), so an infeasible approach
    # is a 422 now rather than a failed move later, and the record shows what will run.
    with controller.admitting():
        present = controller.present_joints()
        req = dataclasses.replace(req, start_joints=tuple(float(q) for q in present))
        with planning_lane(server, req):
            trajectory = plan_request(req)
        record = controller.start_move(trajectory)
    return 202, controller.move_info(record.id)


def op_get_move(server: RobodcnHTTPServer, request: Request, params: dict[str, str]
                ) -> tuple[int, Any]:
    info = _controller(server).move_info(params["id"])
    if info is None:
        raise HTTPError(404, "not_found", f"no move {params['id']!r} (the service keeps the "
                        "most recent moves only)", "id")
    return 200, info


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
