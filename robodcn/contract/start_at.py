"""``start_at`` of a move body: the UNIX time its first sample is due, declared once.

Every move body (``POST /v1/moves`` over HTTP, ``robodcn/<arm>/op/start_move`` over Zenoh)
may give ``start_at``, seconds since the UNIX epoch on the serving host's clock (hosts kept
in step by NTP or PTP): the move is planned at once and its first sample goes out at that
time, so two arms given the same ``start_at`` start within one bus period of each other.
A time in the past, or more than :data:`START_AT_AHEAD` s ahead, is refused (422 naming
``start_at``) before anything moves.
"""

from __future__ import annotations

import math
import time
from typing import Any

from robodcn.errors import InputError

#: Furthest ahead (s) a move may be scheduled.
START_AT_AHEAD = 60.0

#: The JSON Schema of ``start_at`` (a property of every move body).
START_AT_SCHEMA: dict[str, Any] = {
    "type": "number", "exclusiveMinimum": 0,
    "description": "UNIX time (s, the serving host's clock) the move's first sample is due: "
                   f"not in the past, at most {START_AT_AHEAD:g} s ahead. Two arms given "
                   "the same start_at start within one bus period of each other (hosts in "
                   "step by NTP/PTP). Absent: at once."}


def check_start_at(value: Any, now: float | None = None) -> float:
    """``value`` as a UNIX time within [now, now + START_AT_AHEAD]; InputError naming
    ``start_at`` (with how far off it is, in seconds) otherwise."""
    now = time.time() if now is None else now
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value):
        raise InputError(f"start_at must be a UNIX time in seconds, got {value!r}",
                         field="start_at", value=value)
    ahead = float(value) - now
    if ahead < 0:
        raise InputError(f"start_at {value:.3f} is {-ahead:.3f} s in the past (now "
                         f"{now:.3f} on this host): give a time ahead, within "
                         f"{START_AT_AHEAD:g} s", field="start_at", value=value)
    if ahead > START_AT_AHEAD:
        raise InputError(f"start_at {value:.3f} is {ahead:.1f} s ahead: at most "
                         f"{START_AT_AHEAD:g} s", field="start_at", value=value)
    return float(value)


def take_start_at(body: Any) -> tuple[Any, float | None]:
    """The move body without ``start_at``, and its checked value (None when absent)."""
    if not isinstance(body, dict) or "start_at" not in body:
        return body, None
    body = dict(body)
    return body, check_start_at(body.pop("start_at"))
