"""The packet log of a simulated bus: every packet read (rx) or written (tx), in memory
and optionally appended to a text file (``python -m firmware_sim --log``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import IO

from firmware_sim.protocol import instruction_name


@dataclass(frozen=True)
class LogEntry:
    """One packet seen on the wire.

    ``time`` is ``time.perf_counter()`` seconds when the packet was read (rx) or written
    (tx). ``params`` are the unstuffed parameters (status: after the ERR byte); ``error``
    is the ERR byte of a status packet. ``note`` says what the sim did to it
    (``"crc error"``, ``"dropped"``, ``"delayed 40.0 ms"``, ``"fast: 1,2,3"`` ...).
    """

    time: float
    direction: str
    id: int
    instruction: str
    params: bytes
    error: int | None = None
    raw: bytes = field(default=b"", repr=False)
    note: str = ""

    def __str__(self) -> str:
        err = "" if self.error is None else f" err=0x{self.error:02X}"
        note = f" [{self.note}]" if self.note else ""
        return (f"{self.time:.6f} {self.direction} id={self.id} {self.instruction}{err} "
                f"params={self.params.hex(' ')}{note}")


class PacketLog:
    """Log entries in the order seen.

    Parameters
    ----------
    keep : bool
        Keep entries in :attr:`entries` (False: only the file, if any, gets them).
    limit : int
        The oldest entries are discarded beyond this many.
    path : str, optional
        Text file every entry is appended to (one ``str(entry)`` a line) while open.
    """

    def __init__(self, keep: bool = True, limit: int = 100_000, path: str | None = None) -> None:
        self.entries: list[LogEntry] = []
        self._keep = bool(keep)
        self._limit = int(limit)
        self._path = path
        self._file: IO[str] | None = None

    @property
    def keep(self) -> bool:
        """Whether entries are kept in :attr:`entries`."""
        return self._keep

    @keep.setter
    def keep(self, value: bool) -> None:
        self._keep = bool(value)

    def open(self) -> None:
        """Open the log file for appending (no-op without a path)."""
        if self._path and self._file is None:
            self._file = open(self._path, "a", encoding="utf-8")

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def add(self, entry: LogEntry) -> None:
        if self._keep:
            self.entries.append(entry)
            if len(self.entries) > self._limit:
                del self.entries[: len(self.entries) - self._limit]
        if self._file is not None:
            self._file.write(f"{entry}\n")
            self._file.flush()     # a tail -f of the file follows the bus live

    def select(self, direction: str | None = None, instruction: str | int | None = None,
               servo_id: int | None = None) -> list[LogEntry]:
        """Entries filtered by direction ("rx"/"tx"), instruction (name or code), id."""
        if isinstance(instruction, int):
            instruction = instruction_name(instruction)
        return [e for e in list(self.entries)      # a copy: the server thread appends
                if (direction is None or e.direction == direction)
                and (instruction is None or e.instruction == instruction)
                and (servo_id is None or e.id == servo_id)]

    def clear(self) -> None:
        self.entries.clear()
