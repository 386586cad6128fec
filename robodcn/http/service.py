"""``robodcn serve``: the service with its arm (simulated or on a device), or plan-only in one
or several processes, until a signal."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from robodcn.config import Arm
from robodcn.controller import ArmController
from robodcn.errors import InputError
from robodcn.http.auth import TOKEN_ENV, check_token
from robodcn.http.listen import check_processes, make_server
from robodcn.http.server import RobodcnHTTPServer
from robodcn.stream import ExecutionOptions

#: Seconds a signal waits for the running move to hold before the server shuts down.
STOP_WAIT = 2.0


@contextlib.contextmanager
def signals_stop(server: RobodcnHTTPServer, controller: ArmController | None = None
                 ) -> Iterator[None]:
    """SIGINT/SIGTERM: first stop the motion (the arm holds), then shut the server down.

    Main thread only (others cannot set handlers). The handler hands the work to a thread:
    ``shutdown()`` waits for ``serve_forever()``, which runs in this very thread.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop_then_shutdown() -> None:
        if controller is not None:
            controller.stop(wait=STOP_WAIT)
        server.shutdown()

    def handler(signum: int, frame: Any) -> None:
        if controller is not None:
            controller.request_stop("the service is shutting down")  # no lock, no wait
        threading.Thread(target=stop_then_shutdown, name="robodcn-http-shutdown").start()

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


@contextlib.contextmanager
def open_device(arm: Arm, device: str | None = None, baud: int | None = None
                ) -> Iterator[Any]:
    """``serve --device``'s bus: ``device`` (default: the arm's [bus] port) at ``baud``
    (default: the arm's), opened and verified against the arm's servos (BusError when they
    do not answer), closed on exit. Torque stays as it is until the first move (the
    streamer configures the servos then)."""
    from robodcn.bus import ServoBus

    bus = ServoBus(device or arm.bus.port, baud or arm.bus.baud, servos=arm.servos)
    try:
        bus.open()
        bus.verify()
        yield bus
    finally:
        bus.close()


def serve(arm: Arm, *, host: str = "127.0.0.1", port: int = 8080, token: str | None = None,
          allow_hosts: tuple[str, ...] = (),
          sim: bool = False, device: str | None = None, baud: int | None = None,
          ready: Callable[[str], None] | None = None,
          execution: ExecutionOptions | dict[str, Any] | None = None,
          plan_only: bool = False, processes: int = 1,
          faces: Sequence[Callable[[RobodcnHTTPServer], contextlib.AbstractContextManager[Any]]]
          = ()) -> None:
    """Run the service until SIGINT/SIGTERM or ``server.shutdown()``, then clean up.

    With ``sim=True`` the arm is :func:`robodcn.simulated.simulated_arm` in realistic
    timing; otherwise ``device`` (default: the arm's bus port) is opened at ``baud`` (default:
    the arm's) and verified against the arm's servos (BusError when they do not answer).
    ``token`` defaults to ``$ROBODCN_TOKEN`` (visible ASCII, checked first); ``ready(url)``
    is called once the socket listens; ``allow_hosts``: names the service answers to besides
    the loopback ones (the Host allow-list, :mod:`robodcn.http.gate`). ``execution``: the
    options every move executes with (:class:`~robodcn.stream.ExecutionOptions`, or a dict
    of its fields over :data:`robodcn.controller.DEFAULT_EXECUTE`; ``GET /v1/arm`` shows
    them). Raises ListenError (exit 6) when the address is busy.

    ``plan_only=True``: no arm attached (no bus is opened; the move, stop and state
    endpoints answer 503), answered by ``processes`` worker processes
    (:class:`~robodcn.http.prefork.PreforkServer` above 1; WorkerExitError, exit 6, when
    one ends by itself). ``processes`` above 1 without ``plan_only`` is an InputError
    naming ``processes``, raised before anything opens.

    ``faces``: other surfaces of the same service (e.g. :func:`robodcn.zenoh.face`), each
    a context manager made from the server object (its arm, controller and operations),
    entered once the socket listens and left before it closes (single-process only).
    """
    if token is None:
        token = os.environ.get(TOKEN_ENV) or None
    check_token(token)
    if plan_only and (sim or device is not None or baud is not None):
        raise InputError("a plan-only service opens no arm: give no sim, device or baud",
                         field="plan_only", value=plan_only)
    check_processes(processes, arm_attached=not plan_only)
    # Warnings of a request (e.g. a beta that the method ignores) go to the log, not stderr.
    logging.captureWarnings(True)
    if plan_only:
        server = make_server(arm, None, host=host, port=port, token=token,
                             allow_hosts=allow_hosts, processes=processes)
        try:
            with contextlib.ExitStack() as stack:
                if processes == 1:
                    stack.enter_context(signals_stop(server))
                    for make_face in faces:
                        stack.enter_context(make_face(server))
                if ready is not None:
                    ready(server.url)
                server.serve_forever(poll_interval=0.2)
        finally:
            server.server_close()
        return
    with contextlib.ExitStack() as stack:
        simulated = None
        if sim:
            from robodcn.simulated import simulated_arm

            # it carries the payload each move declares (ArmController's ``simulated``)
            simulated = stack.enter_context(simulated_arm(arm, timing="realistic"))
            bus = simulated.bus
        else:
            bus = stack.enter_context(open_device(arm, device, baud))
        controller = ArmController(arm, bus, execute_options=execution, simulated=simulated)
        stack.callback(controller.close)
        server = make_server(arm, controller, host=host, port=port, token=token,
                             allow_hosts=allow_hosts)
        stack.callback(server.server_close)
        stack.enter_context(signals_stop(server, controller))
        for make_face in faces:
            stack.enter_context(make_face(server))
        if ready is not None:
            ready(server.url)
        server.serve_forever(poll_interval=0.2)
