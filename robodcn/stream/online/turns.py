"""Taking turns for one operation at a time, with a bounded wait.

Replacements of a running move are planned one after the other (each from the stream the
one before left): a :class:`Turns` lets the next wait a while for its turn, then refuses it
(:class:`~robodcn.errors.BusyError`, 409: nothing changed) instead of letting answers queue
behind each other's planning without a bound.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from robodcn.errors import BusyError


class Turns:
    """One holder at a time; a thread that already holds it goes on (re-entrant).

    Parameters
    ----------
    wait : seconds a thread waits for its turn before :meth:`take` raises BusyError
    (field ``field``, no value)
    busy : what the BusyError says is going on (it adds that nothing changed)
    """

    def __init__(self, wait: float, busy: str, field: str = "move") -> None:
        self.wait = wait
        self.busy = busy
        self.field = field
        self._lock = threading.Lock()
        self._holder: int | None = None

    @property
    def held(self) -> bool:
        """Whether some thread holds the turn now."""
        return self._holder is not None

    @contextlib.contextmanager
    def take(self) -> Iterator[None]:
        """Hold the turn for the ``with`` block (BusyError when not had within
        :attr:`wait`)."""
        me = threading.get_ident()
        if self._holder == me:
            yield
            return
        if not self._lock.acquire(timeout=self.wait):
            raise BusyError(f"{self.busy}: nothing changed, try again", field=self.field,
                            value=None)
        self._holder = me
        try:
            yield
        finally:
            self._holder = None
            self._lock.release()


__all__ = ["Turns"]
