"""Keys on a terminal for the online commands: ``jog`` and a running ``move``/``sim``.

:class:`TerminalKeys` reads single key presses from a TTY in cbreak mode (arrow keys
decoded to ``"up"``, ``"down"``, ``"left"``, ``"right"``); any callable ``keys(timeout) ->
str | None`` can stand in for it (tests feed a list). :func:`drive` runs a started
:class:`~robodcn.stream.Execution` under the move keys: space pauses/resumes, ``+``/``-``
change the speed scale in steps of 0.25, Ctrl-C (or ``q``) stops smoothly along the path, a
second Ctrl-C holds at once.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import sys
import termios
import threading
import tty
from collections.abc import Callable, Iterator
from typing import Any

Keys = Callable[[float], "str | None"]

#: the keys a running move answers, as shown on the terminal
MOVE_KEYS = "space pause/resume · + / - speed · Ctrl-C smooth stop (twice: hold)"
SPEED_STEP = 0.25
_ARROWS = {"A": "up", "B": "down", "C": "right", "D": "left"}


class TerminalKeys:
    """Key presses from the terminal ``fd`` (cbreak: no echo, no line buffering; Ctrl-C
    still raises SIGINT). Use as a context manager; call with a timeout in seconds."""

    def __init__(self, fd: int | None = None) -> None:
        self.fd = sys.stdin.fileno() if fd is None else fd
        self._saved: Any = None

    def __enter__(self) -> TerminalKeys:
        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._saved is not None:
            termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)

    def _byte(self, timeout: float) -> str | None:
        ready, _, _ = select.select([self.fd], [], [], timeout)
        if not ready:
            return None
        data = os.read(self.fd, 1)
        return data.decode("latin-1") if data else None

    def __call__(self, timeout: float) -> str | None:
        try:
            key = self._byte(timeout)
        except InterruptedError:
            return None
        if key != "\x1b":
            return key
        if self._byte(0.05) == "[":
            code = self._byte(0.05)
            return _ARROWS.get(code or "", "escape")
        return "escape"


def interactive(stream: Any = None) -> bool:
    """stdin and stderr are terminals (keys can be read and shown)."""
    stream = sys.stderr if stream is None else stream
    try:
        return sys.stdin.isatty() and stream.isatty()
    except (AttributeError, ValueError):
        return False


class CtrlC:
    """SIGINT → ``first()`` the first time, ``second()`` after (main thread only)."""

    def __init__(self, first: Callable[[], None], second: Callable[[], None]) -> None:
        self.first, self.second, self.count = first, second, 0

    def __call__(self, signum: int, frame: Any) -> None:
        self.count += 1
        (self.first if self.count == 1 else self.second)()

    @contextlib.contextmanager
    def installed(self) -> Iterator[CtrlC]:
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous = signal.signal(signal.SIGINT, self)
        try:
            yield self
        finally:
            signal.signal(signal.SIGINT, previous)


def move_key(execution: Any, key: str) -> str | None:
    """Apply one move key to a running execution; what it did, for the status line."""
    if key == " ":
        if execution.paused:
            execution.resume()
            return "resumed"
        execution.pause()
        return "paused"
    if key in ("+", "="):
        execution.set_speed(min(1.0, execution.speed + SPEED_STEP))
        return f"speed {execution.speed:.2f}"
    if key in ("-", "_"):
        execution.set_speed(max(SPEED_STEP, execution.speed - SPEED_STEP))
        return f"speed {execution.speed:.2f}"
    if key == "q":
        execution.stop("smooth", "stopped by q")
        return "stopping"
    return None


def drive(execution: Any, keys: Keys, *, on_action: Callable[[str], None] | None = None,
          poll: float = 0.05) -> None:
    """Feed move keys to ``execution`` until it finishes; Ctrl-C stops smoothly, twice holds."""
    from robodcn.errors import RobodcnError

    ctrl_c = CtrlC(lambda: execution.stop("smooth", "stopped by Ctrl-C"),
                   lambda: execution.stop("hold", "stopped by Ctrl-C (hold)"))
    with ctrl_c.installed():
        while not execution.done:
            key = keys(poll)
            if key is None:
                continue
            try:
                action = move_key(execution, key)
            except RobodcnError as exc:
                action = exc.message
            if action and on_action is not None:
                on_action(action)
