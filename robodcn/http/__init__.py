"""The HTTP trajectory service: JSON in and out, SI units.

Endpoints (one route table, :data:`~robodcn.http.routes.ROUTES`, drives dispatch, the worker
pool of each request and ``/openapi.json``)::

    GET  /healthz            health: arm name, whether a move runs; 503 with the reason
                             while the bus is lost or faulted
    GET  /v1/arm             the arm configuration (SI units)
    POST /v1/trajectories    plan only → 200 Trajectory JSON
    POST /v1/moves           plan and execute → 202 Move; 409 while a move runs
    GET  /v1/moves/{id}      status (done | degraded | stopped | fault | …), progress, report
    POST /v1/stop            stop and hold (the move, a gripper action)
    GET  /v1/state           present joints, pose, torque, alerts
    GET  /openapi.json       OpenAPI 3.1 document of all of the above
    GET  /v1/moves/{id}/trajectory   what a move planned (Trajectory JSON)
    GET  /v1/moves/{id}/record       what it measured (JSON, or CSV by Accept: text/csv)
    POST /v1/torque          torque on (holding) or off, one joint or all
    POST /v1/reboot          reboot one servo or all
    GET  /v1/events          Server-Sent Events: live state, move status, alerts
    GET  /                   the web console (robodcn.web); its files under /static/{name}

``POST /v1/moves`` takes waypoints (planned from the present joints,
:func:`robodcn.present.plan_from_present`) or ``{"trajectory": Trajectory JSON |
JointTrajectory JSON}`` (:func:`robodcn.workflow.files.trajectory_from_data`, then
:func:`~robodcn.workflow.files.with_approach` from the present joints).

Errors are ``{"error": {"code", "message", "field", ...}}`` with the status of the
:mod:`robodcn.errors` class (``http_status``: 422 input/plan, 413 too large, 409 busy, 503
bus fault) or of the HTTP check that failed: 400 malformed request or JSON (not UTF-8, too
deep), 401 missing/wrong bearer token (on every POST, PUT and DELETE when one is set), 403 a
``Host`` or ``Origin`` not the service's (:mod:`~robodcn.http.gate`), 404 unknown path or
move, 405 method not served (with ``Allow``), 408 request not complete within its
deadline, 411 no Content-Length, 413 body over 1 MiB, 414/431 request line/head too long,
415 not JSON (every POST, PUT and DELETE carries a JSON body, ``{}`` for none), 505 not
HTTP/1.x, 503 server full; a console file unchanged since its ETag is 304.

Modules: :mod:`~robodcn.http.limits` (every limit), :mod:`~robodcn.http.framing` (request
reader, responses), :mod:`~robodcn.http.jsonbody`, :mod:`~robodcn.http.routes`,
:mod:`~robodcn.http.auth` (the bearer token), :mod:`~robodcn.http.gate` (the Host
allow-list and the Origin check), :mod:`~robodcn.http.context` (what an
operation sees of the server), :mod:`~robodcn.http.planbody`,
:mod:`~robodcn.http.planning` (size check, planning lanes), :mod:`~robodcn.http.openapi`,
:mod:`~robodcn.http.ops` and :mod:`~robodcn.http.online_ops` (the operations; a move goes
through :func:`robodcn.admission.admit`; the controls of the running motion are built from
:data:`robodcn.controls.CONTROLS`), :mod:`~robodcn.http.answer` (the edge: typed
results of :mod:`robodcn.results` and errors as replies), :mod:`~robodcn.http.server`
(selector loop, caps, pools), :mod:`~robodcn.http.listen` (``make_server``),
:mod:`~robodcn.http.prefork` (a plan-only service in N worker processes,
``make_server(..., processes=N)``), :mod:`~robodcn.http.service` (``serve``).
"""

from robodcn.http.auth import TOKEN_ENV
from robodcn.http.framing import HTTPError
from robodcn.http.limits import MAX_BODY, MAX_CONNECTIONS, MAX_PER_CLIENT, REQUEST_TIMEOUT
from robodcn.http.listen import ListenError, make_server
from robodcn.http.openapi import openapi, schemas
from robodcn.http.prefork import PreforkServer, WorkerExitError
from robodcn.http.routes import ROUTES, Route
from robodcn.http.server import RobodcnHTTPServer
from robodcn.http.service import serve

__all__ = ["MAX_BODY", "MAX_CONNECTIONS", "MAX_PER_CLIENT", "REQUEST_TIMEOUT", "ROUTES",
           "TOKEN_ENV", "HTTPError", "ListenError", "PreforkServer", "RobodcnHTTPServer", "Route",
           "WorkerExitError", "make_server", "openapi", "schemas", "serve"]
