"""The one thread a service touches its serial port from, and how it recovers from a fault.

robodcn.bus is single-threaded by design: every port access of an
:class:`~robodcn.controller.ArmController` runs as a job on a :class:`BusWorker` (a move's
whole stream, an idle state read, a servo admin step). Losing the serial device
(unplugged, firmware_sim killed) is a bus fault, never a crash: the job raises CommError
(503), the worker marks the port suspect (:attr:`BusWorker.fault` says why), and the next job
reopens and re-verifies it first, so the service recovers by itself once the device is back.
"""

from __future__ import annotations

import logging
import termios
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from typing import Any, TypeVar

from robodcn.bus import ServoBus
from robodcn.errors import BusError, CommError, RobodcnError

log = logging.getLogger("robodcn.controller")

#: Seconds :meth:`BusWorker.call` waits for a job (an idle state read, an admin step).
STATE_TIMEOUT = 5.0
#: Exceptions of a lost serial device that dynamixel-sdk/pyserial let through (pyserial's
#: SerialException is an OSError; termios.error is not).
DEVICE_ERRORS: tuple[type[BaseException], ...] = (OSError, termios.error)

T = TypeVar("T")


def device_fault(bus: ServoBus, exc: BaseException) -> CommError:
    """The CommError of a lost serial device (``exc`` as dynamixel-sdk/pyserial raised it)."""
    return CommError(f"the serial device {bus.port} failed ({type(exc).__name__}: {exc}); "
                     "it is reopened on the next request", field="bus", value=bus.port)


class BusWorker:
    """Runs jobs for ``bus`` one at a time on one thread; reopens the port after a fault.

    Parameters
    ----------
    bus : the open, verified ServoBus (the worker does not close it)
    """

    def __init__(self, bus: ServoBus) -> None:
        self.bus = bus
        #: Why the port is suspect (the last bus operation failed: reopen and re-verify it
        #: before the next), or None while it is sound.
        self.fault: str | None = None
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="robodcn-arm")
        self._jobs = 0
        self._jobs_lock = threading.Lock()

    @property
    def suspect(self) -> bool:
        """The last bus operation failed (:attr:`fault` says how): reopen and re-verify the
        port before the next."""
        return self.fault is not None

    def mark_fault(self, reason: str) -> None:
        """The bus failed (``reason``): reopen and re-verify it before the next job."""
        self.fault = reason

    def submit(self, fn: Callable[..., Any], *args: Any, if_idle: bool = False
               ) -> Future[Any] | None:
        """Queue ``fn(*args)`` (it calls :meth:`recover` itself when it touches the port);
        ``if_idle``: only when no job is queued or running (else None, nothing queued)."""
        def job() -> Any:
            try:
                return fn(*args)
            finally:
                with self._jobs_lock:
                    self._jobs -= 1

        with self._jobs_lock:
            if if_idle and self._jobs:
                return None
            self._jobs += 1
        try:
            return self._pool.submit(job)
        except BaseException:
            with self._jobs_lock:
                self._jobs -= 1
            raise

    def recover(self) -> None:
        """After a bus fault: reopen and re-verify the port (on the worker thread only).

        Raises CommError saying the device is still unavailable."""
        if not self.suspect:
            return
        with self.bus.claim():
            try:
                self.bus.close()
                self.bus.open()
                self.bus.verify()
            except (RobodcnError, *DEVICE_ERRORS) as exc:
                message = exc.message if isinstance(exc, RobodcnError) else str(exc)
                error = CommError(f"the servo bus on {self.bus.port} is unavailable "
                                  f"({message}); the service retries on each request until "
                                  "it is back", field="bus", value=self.bus.port)
                self.fault = error.message
                raise error from None
        log.info("servo bus on %s reopened", self.bus.port)
        self.fault = None

    def call(self, fn: Callable[[], T], what: str, timeout: float | None = None) -> T:
        """Run ``fn`` on the worker thread (recovering the port first) and wait for it.

        Bus faults and lost devices become CommError/BusError (and mark the port suspect);
        a job that does not finish within ``timeout`` (default :data:`STATE_TIMEOUT`)
        CommError naming ``what``.
        """
        future = self.submit(self._job(fn))
        assert future is not None
        return self._wait(future, what, timeout)

    def call_if_idle(self, fn: Callable[[], T], what: str, timeout: float | None = None
                     ) -> tuple[bool, T | None]:
        """:meth:`call` when no job is queued or running: ``(True, its result)``; else
        ``(False, None)`` at once, nothing queued (a check that must not wait behind a
        move or an admin job)."""
        future = self.submit(self._job(fn), if_idle=True)
        if future is None:
            return False, None
        return True, self._wait(future, what, timeout)

    def _job(self, fn: Callable[[], T]) -> Callable[[], T]:
        """``fn`` as a worker job: the port recovered first, its faults marked."""
        def job() -> T:
            self.recover()
            try:
                return fn()
            except BusError as exc:
                self.mark_fault(exc.message)
                raise
            except DEVICE_ERRORS as exc:
                fault = device_fault(self.bus, exc)
                self.mark_fault(fault.message)
                raise fault from None

        return job

    @staticmethod
    def _wait(future: Future[T], what: str, timeout: float | None) -> T:
        wait = STATE_TIMEOUT if timeout is None else timeout
        try:
            return future.result(wait)
        except FutureTimeout:
            raise CommError(f"{what} took over {wait:g} s", field="bus", value=None) from None

    def shutdown(self) -> None:
        """Finish the job in flight, drop the queued ones, end the thread."""
        self._pool.shutdown(wait=True, cancel_futures=True)
