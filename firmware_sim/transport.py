"""The pseudo-terminal a client opens as its USB serial adapter.

The sim keeps both ends: it reads and writes the master, and holding the slave open
keeps the pty alive between clients and lets it read the baud rate the client set
(the slave's termios), which decides which servos hear the client.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import select
import termios
import time
import tty

#: Bytes that were already waiting when ``select`` was called arrived no later than then.
_ALREADY_WAITING_S = 50e-6


def _termios_rates() -> dict[int, int]:
    rates = {}
    for name in dir(termios):
        if name.startswith("B") and name[1:].isdigit():
            rates[getattr(termios, name)] = int(name[1:])
    return rates


_TERMIOS_RATES = _termios_rates()

log = logging.getLogger(__name__)


def take_over_stale_link(link: str, own_pty: str) -> None:
    """Remove ``link`` if it is a symlink left by a simulator that died (``kill -9``).

    Each simulator records its pid beside its link (``LINK.pid``): a link whose recorded
    process is gone is stale and removed, whatever its pty became (the kernel reuses a freed
    pty's number for the next one opened, by any process). Without a pid file, a dangling
    link or one naming the pty this simulator was just given is stale. A link of a live
    simulator, or to another pty that exists, and anything that is not a symlink raise
    FileExistsError naming the path, as ``os.symlink`` would.
    """
    if not os.path.islink(link):
        return                                  # nothing there, or a file symlink() refuses
    owner = _recorded_pid(link)
    if owner is not None:
        stale = not _alive(owner)
    else:
        stale = os.readlink(link) == own_pty or not os.path.exists(link)
    if not stale:
        raise FileExistsError(errno.EEXIST,
                              f"{link} links to {os.readlink(link)}, which is still open "
                              "(another firmware_sim?)", link)
    log.info("removing the stale link %s (its simulator is gone)", link)
    for path in (link, link + ".pid"):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)


def _recorded_pid(link: str) -> int | None:
    try:
        with open(link + ".pid", encoding="ascii") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return False                            # our own earlier link: ours to replace
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class PtyPort:
    """One pty: :attr:`path` for the client, the master end for the sim.

    Parameters
    ----------
    link : str, optional
        Path of a symlink to the slave, made on :meth:`open` and removed on :meth:`close`.
    """

    def __init__(self, link: str | None = None) -> None:
        self.link = link
        self.path = ""
        self._master: int | None = None
        self._slave: int | None = None
        self._link_made = False

    @property
    def closed(self) -> bool:
        return self._master is None

    def open(self) -> None:
        master, slave = os.openpty()
        try:
            tty.setraw(slave)       # nothing echoed or line-buffered before the client opens it
            os.set_blocking(master, False)
            self.path = os.ttyname(slave)
            if self.link:
                take_over_stale_link(self.link, self.path)
                os.symlink(self.path, self.link)
                self._link_made = True
                with open(self.link + ".pid", "w", encoding="ascii") as f:
                    f.write(f"{os.getpid()}\n")
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        self._master, self._slave = master, slave

    def close(self) -> None:
        """Release the pty and the link (idempotent)."""
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None
        if self._link_made and self.link:
            for path in (self.link, self.link + ".pid"):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(path)
            self._link_made = False

    def rate(self) -> int | None:
        """Bits/s the client set on the port (slave termios), None if not a known rate."""
        if self._slave is None:
            return None
        try:
            speed = termios.tcgetattr(self._slave)[5]
        except termios.error:
            return None
        return _TERMIOS_RATES.get(speed)

    def receive(self, timeout_s: float) -> tuple[bytes, float] | None:
        """Bytes the client sent and the ``perf_counter`` time they arrived by, or None if
        none came within ``timeout_s``. Other OSErrors than "no client" propagate."""
        master = self._master
        if master is None:
            time.sleep(timeout_s)
            return None
        try:
            t_wait = time.perf_counter()
            ready, _, _ = select.select([master], [], [], timeout_s)
            if not ready:
                return None
            data = os.read(master, 4096)
        except BlockingIOError:
            return None
        except OSError as exc:
            if exc.errno != errno.EIO:
                raise
            time.sleep(timeout_s)      # no slave open (we keep one, but be safe)
            return None
        now = time.perf_counter()
        if now - t_wait < _ALREADY_WAITING_S:
            # the bytes were there before we looked (the thread was busy): they arrived
            # no later than t_wait. Using it keeps a busy thread from seeing a false
            # 1.5 ms inter-byte gap, and dates the instruction closer to its arrival.
            now = t_wait
        return data, now

    def write(self, data: bytes) -> None:
        """Put ``data`` on the port for the client; what it never collects is lost."""
        master = self._master
        if master is None:
            return
        view = memoryview(data)
        flushed = False
        while view:
            try:
                n = os.write(master, view)
                view = view[n:]
            except BlockingIOError:
                if flushed or self._slave is None:
                    return            # nobody reads the port: the bytes are lost, as on a wire
                # the client is not reading: drop what it never collected, as a wire would
                termios.tcflush(self._slave, termios.TCIFLUSH)
                flushed = True
