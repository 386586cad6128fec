"""The servo bus: Dynamixel X-series servos over Protocol 2.0, through dynamixel-sdk only.

This package is the only part of robodcn that imports ``dynamixel_sdk``; every byte to and
from a servo goes through its ``PortHandler``, ``Protocol2PacketHandler``, ``GroupSyncWrite``
and ``GroupSyncRead`` (Fast Sync Read 0x8A when every servo's firmware has it, plain Sync
Read 0x82 otherwise).

:class:`ServoBus` is one object made of one concept a module, each a layer on the one
below it:

- :mod:`~robodcn.bus.connection`: port, servo ids, open/close/reopen, the ownership lock
  (:meth:`ServoBus.claim`) and a lost device;
- :mod:`~robodcn.bus.retry`: the one retry helper (retries, flushes, logs each failed try
  with the servo and the instruction);
- :mod:`~robodcn.bus.transactions`: READ/WRITE of one servo, status checked before decoding;
- :mod:`~robodcn.bus.verification`: PING, ``verify`` (ids, models, limits, firmware);
- :mod:`~robodcn.bus.reads`: (Fast) Sync Reads, positions, feedback, hardware errors;
- :mod:`~robodcn.bus.writes`: goals by Sync Write, torque, REBOOT, the Bus Watchdog;
- :mod:`~robodcn.bus.configuration`: ``configure`` and the indirect feedback map, checked;
- :mod:`~robodcn.bus.single`: one servo by id or spec (a gripper on the joints' wire):
  Present Position, a checked Goal Position;
- :mod:`~robodcn.bus.currents`: Goal Current (checked against the Current Limit, one
  servo or one Sync Write), Present Current;
- :mod:`~robodcn.bus.modes`: Operating Mode switching (torque off, mode, goals, torque on).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robodcn.bus.configuration import Configuration
from robodcn.bus.feedback import current_units
from robodcn.bus.modes import Modes
from robodcn.bus.retry import STRAGGLER_S
from robodcn.bus.verification import Verification
from robodcn.bus.writes import Writes
from robodcn.config import ServoSpec


class ServoBus(Configuration, Verification, Writes, Modes):
    """A Dynamixel Protocol 2.0 bus of X-series servos, opened at one baud rate.

    Parameters
    ----------
    port
        Serial device (``/dev/ttyUSB0``, or firmware_sim's pty path).
    baud
        Bits per second; the servos' Baud Rate item must match. The Python SDK cannot
        set 4.5 Mbps.
    servos
        The servos expected on the bus, in joint order: positions and goals are arrays in
        this order.
    retries
        Extra attempts for a read that fails (timeout, corrupt packet, error status).
    rx_timeout_ms
        Status-packet timeout of pings, reads, writes and group reads. None keeps the
        SDK's own (wire time + 2·16 ms + 2 ms, i.e. ≥ 34 ms); a short value makes a lost
        reply cost little when the adapter's latency timer is 1 ms, a long one waits for a
        slow responder (a simulator on a loaded host).
    fast_read
        Use Fast Sync Read for group reads: None decides from the firmware versions found by
        :meth:`verify` (≥ 45), True/False forces it.
    """

    def __init__(self, port: str, baud: int = 1_000_000, *, servos: Sequence[ServoSpec],
                 retries: int = 2, rx_timeout_ms: float | None = None,
                 fast_read: bool | None = None) -> None:
        super().__init__(port, baud, servos=servos, retries=retries,
                         rx_timeout_ms=rx_timeout_ms)
        self.fast_read = fast_read
        self.last_alert_ids = ()
        self.position_p_gains = None
        self.position_i_gains = None
        self.position_d_gains = None
        self.current_limits = None
        self._current_units = current_units([s.model for s in self.servos])
        self.limits = np.array([[s.min_tick, s.max_tick] for s in self.servos], dtype=np.int64)


__all__ = ["STRAGGLER_S", "ServoBus"]
