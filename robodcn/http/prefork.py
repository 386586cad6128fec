"""A plan-only service in several processes: one port, N worker processes (pre-fork).

Planning is CPU-bound Python: one interpreter (one GIL) plans on one core whatever its
threads do, so a plan-only service scales with processes, not threads. :class:`PreforkServer`
binds N listening sockets to one address with ``SO_REUSEPORT`` (Linux ≥ 3.9: the kernel
spreads new connections over them by a hash of the client's address and port), forks N
workers, each of which runs an ordinary :class:`~robodcn.http.server.RobodcnHTTPServer` on
its own socket, and waits.

Only for a plan-only service (no controller): a worker is a copy of the parent, so N workers
would mean N owners of one servo bus. Each worker has its own limits (connections in all
and per address, worker threads): the caps of :mod:`robodcn.http.limits` hold per process.

Lifecycle (Linux: ``SO_REUSEPORT``, ``os.pidfd_open``): ``serve_forever()`` (main thread of a
process that has started no threads of its own: the workers are forked) returns after
``shutdown()`` — from another thread, or SIGTERM or SIGINT, which it handles while it runs —
once every worker has ended (SIGTERM to each; one that does not end within
:data:`STOP_WAIT` s is killed), all reaped. A worker that ends by itself is not restarted: the
parent logs it, ends the others and raises :class:`WorkerExitError` (exit code 6), so the
service never serves on silently with part of its capacity. A worker whose parent dies gets
SIGTERM (``PR_SET_PDEATHSIG``); workers ignore SIGINT (Ctrl-C reaches the parent, which ends
them).

Why ``SO_REUSEPORT`` rather than one shared socket: with one socket every idle worker wakes
for each connection and the first one takes whatever is queued, so one worker can end up
with every keep-alive connection; with a socket each, the kernel balances. Before binding
them, a probe socket without ``SO_REUSEPORT`` is bound to the address, so an address another
service holds (even another ``--processes`` service) is refused as ever (ListenError), not
shared.
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import logging
import os
import selectors
import signal
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

from robodcn.config import Arm
from robodcn.errors import RobodcnError
from robodcn.http.server import url_of

log = logging.getLogger("robodcn.http")

#: Seconds the workers get to end after SIGTERM before they are killed.
STOP_WAIT = 10.0
_PR_SET_PDEATHSIG = 1


class WorkerExitError(RobodcnError):
    """A worker process of a multi-process service ended by itself: the service ends too
    (exit code 6: it cannot go on serving as asked)."""

    code = "worker_exited"
    exit_code = 6


def bind_group(host: str, port: int, count: int) -> list[socket.socket]:
    """``count`` listening TCP sockets on one ``(host, port)`` (``SO_REUSEPORT``); port 0
    picks a free port for all. OSError (EADDRINUSE …) when the address is taken, also by a
    group of another process: a probe without ``SO_REUSEPORT`` binds it first."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        probe.bind((host, port))
        port = probe.getsockname()[1]
    group: list[socket.socket] = []
    try:
        for _ in range(count):
            sock = socket.socket(family, socket.SOCK_STREAM)
            group.append(sock)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            sock.bind((host, port))
            sock.listen(128)
    except OSError:
        for sock in group:
            sock.close()
        raise
    return group


def _die_with_parent() -> None:
    """SIGTERM this process when its parent dies (Linux ``prctl``; nothing elsewhere)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM))


class PreforkServer:
    """A plan-only service for ``arm`` answered by ``len(sockets)`` worker processes.

    Use :func:`robodcn.http.listen.make_server` with ``processes=N``; then
    ``serve_forever()``, ``shutdown()`` (another thread, or a signal), ``server_close()``.
    ``make_worker(sock)`` builds a worker's server on its socket (in the worker).
    """

    def __init__(self, arm: Arm, sockets: list[socket.socket],
                 make_worker: Callable[[socket.socket], Any]) -> None:
        self.arm = arm
        self.controller = None
        self.processes = len(sockets)
        self.server_address = sockets[0].getsockname()
        self._sockets = sockets
        self._make_worker = make_worker
        #: pid → pidfd of each running worker.
        self.workers: dict[int, int] = {}
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._stop = threading.Event()
        self._stopped = threading.Event()
        self._stopped.set()

    @property
    def url(self) -> str:
        return url_of(self.server_address)

    # -- the parent ----------------------------------------------------------------------------

    def serve_forever(self, poll_interval: float = 0.5) -> None:
        """Fork the workers and wait until :meth:`shutdown` (or SIGTERM/SIGINT) or until a
        worker ends by itself (then :class:`WorkerExitError`); every worker is ended and
        reaped before it returns. ``poll_interval`` is each worker's."""
        self._stopped.clear()
        # What the parent has built stays shared with the workers: a collection in a worker
        # no longer writes to (and so copies) the pages of every object it inherited.
        gc.freeze()
        try:
            with self._signals():  # also while the workers end: a second Ctrl-C waits too
                try:
                    for sock in self._sockets:
                        self._fork(sock, poll_interval)
                    for sock in self._sockets:  # each worker holds its own now
                        sock.close()
                    died = self._wait()
                finally:
                    self._end_workers()
        finally:
            gc.unfreeze()
            self._stopped.set()
        if died is not None:
            pid, status = died
            raise WorkerExitError(f"worker process {pid} of the service ended by itself "
                                  f"({_status_text(status)}); the service stopped",
                                  field="processes", value=self.processes)

    def shutdown(self) -> None:
        """End the workers and :meth:`serve_forever` (from another thread: it waits)."""
        self._request_stop()
        self._stopped.wait()

    def server_close(self) -> None:
        """Close what the parent holds (the sockets, if never served; the wake pipe)."""
        for sock in self._sockets:
            sock.close()
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._wake_r = self._wake_w = -1

    def _request_stop(self) -> None:
        self._stop.set()
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"\0")

    @contextlib.contextmanager
    def _signals(self) -> Any:
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        previous = {sig: signal.signal(sig, lambda signum, frame: self._request_stop())
                    for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for sig, old in previous.items():
                signal.signal(sig, old)

    def _fork(self, sock: socket.socket, poll_interval: float) -> None:
        parent = os.getpid()
        pid = os.fork()
        if pid == 0:  # the worker: never returns
            self._worker(sock, poll_interval, parent)
        self.workers[pid] = os.pidfd_open(pid)
        log.info("worker process %d serving", pid)

    def _wait(self) -> tuple[int, int] | None:
        """Until a stop is asked (None) or a worker ends by itself: (pid, wait status)."""
        with selectors.DefaultSelector() as selector:
            selector.register(self._wake_r, selectors.EVENT_READ, None)
            for pid, fd in self.workers.items():
                selector.register(fd, selectors.EVENT_READ, pid)
            while not self._stop.is_set():
                for key, _ in selector.select():
                    if key.data is None:
                        with contextlib.suppress(OSError):
                            os.read(self._wake_r, 512)
                        continue
                    status = self._reap(key.data, wait=True)
                    if status is not None and not self._stop.is_set():
                        log.error("worker process %d ended by itself (%s): stopping the "
                                  "service", key.data, _status_text(status))
                        return key.data, status
        return None

    def _reap(self, pid: int, *, wait: bool) -> int | None:
        """The wait status of worker ``pid`` once it has ended (then forgotten), else None."""
        try:
            done, status = os.waitpid(pid, 0 if wait else os.WNOHANG)
        except ChildProcessError:
            done, status = pid, 0
        if done == 0:
            return None
        with contextlib.suppress(OSError):
            os.close(self.workers.pop(pid))
        return status

    def _end_workers(self) -> None:
        """SIGTERM every worker, wait up to STOP_WAIT s for all, kill the rest; reap all."""
        for pid in list(self.workers):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_WAIT
        while self.workers and time.monotonic() < deadline:
            for pid in list(self.workers):
                self._reap(pid, wait=False)
            if self.workers:
                time.sleep(0.02)
        for pid in list(self.workers):
            log.warning("worker process %d did not end within %g s: killed", pid, STOP_WAIT)
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
            self._reap(pid, wait=True)

    # -- a worker ------------------------------------------------------------------------------

    def _worker(self, sock: socket.socket, poll_interval: float, parent: int) -> None:
        """Serve on ``sock`` until SIGTERM; exit status 0, or 1 when the server failed (or
        the parent is gone already)."""
        code = 1
        try:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the parent
            _die_with_parent()
            if os.getppid() != parent:
                return
            for other in self._sockets:
                if other is not sock:
                    other.close()
            for fd in (self._wake_r, self._wake_w, *self.workers.values()):
                with contextlib.suppress(OSError):
                    os.close(fd)
            server = self._make_worker(sock)
            signal.signal(signal.SIGTERM, lambda signum, frame: threading.Thread(
                target=server.shutdown, name="robodcn-http-shutdown").start())
            try:
                server.serve_forever(poll_interval=poll_interval)
            finally:
                server.server_close()
            code = 0
        except BaseException:
            log.exception("worker process %d failed", os.getpid())
        finally:
            logging.shutdown()
            os._exit(code)


def _status_text(status: int) -> str:
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        with contextlib.suppress(ValueError):
            return f"signal {signal.Signals(sig).name}"
        return f"signal {sig}"
    return f"exit status {os.waitstatus_to_exitcode(status)}"
