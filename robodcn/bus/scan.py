"""Discovery: which servos answer on a port, at which baud."""

from __future__ import annotations

from collections.abc import Iterable

from robodcn import _checks
from robodcn.bus.control_table import BAUD_INDEX
from robodcn.bus.port import raw_port
from robodcn.bus.records import ServoInfo
from robodcn.bus.servo_bus import ServoBus
from robodcn.config import ServoSpec
from robodcn.errors import InputError
from robodcn.servo_models import MODEL_NAMES


def scan(port: str, bauds: Iterable[int] = (1_000_000,), *,
         ids: Iterable[int] | None = None) -> list[ServoInfo]:
    """List the servos on ``port``: id, model, firmware and baud, for each baud tried.

    With ``ids`` None a broadcast PING is sent at each baud (the SDK waits its full
    ≈0.8 s window at 1 Mbps); with ``ids`` each id is pinged in turn (a silent id costs the
    SDK's 34 ms timeout, twice: one retry). The probe bus deliberately keeps the SDK's
    status timeout (no ``rx_timeout_ms``): a scan of many ids, most of them silent, stays
    fast, and 34 ms is what a real servo behind a 16 ms latency timer needs. Results are
    sorted by baud, then id.
    """
    found: list[ServoInfo] = []
    bauds = list(bauds)
    for baud in bauds:
        if baud not in BAUD_INDEX.values() or baud == 4_500_000:
            raise InputError(f"baud must be one of {sorted(set(BAUD_INDEX.values()) - {4_500_000})}"
                             f", got {baud!r}", field="baud", value=baud)
    id_list = None if ids is None else list(ids)
    if id_list is not None:
        bad = [i for i in id_list if not _checks.is_int(i) or not 0 <= i <= 252]
        if bad:
            raise InputError(f"ids must be integers in [0, 252], got {bad}", field="ids",
                             value=bad)
    for baud in bauds:
        if id_list is None:
            with raw_port(port, baud) as (handler, packet):
                replies, _ = packet.broadcastPing(handler)
            for servo_id, (model_number, firmware) in sorted(replies.items()):
                found.append(ServoInfo(servo_id, model_number, MODEL_NAMES.get(model_number),
                                       firmware, baud))
        else:
            # One retry: a servo that misses one ping is not reported missing.
            probe = ServoBus(port, baud, servos=[ServoSpec(i, "xm430-w350") for i in id_list],
                             retries=1)
            with probe:
                for servo_id in id_list:
                    info = probe.ping(servo_id)
                    if info is not None:
                        found.append(info)
    return found


