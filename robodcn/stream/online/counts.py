"""Counts of one move of an online execution: a retarget starts a new move mid-stream.

The stream's report counts every sample it streamed; after a retarget the samples before
the switch were the replaced move's. The new move's report counts its own (from the first
changed sample ``first`` on; the stream's bookkeeping, :class:`~robodcn.stream.loop.
SentRecords`, has the index of every sample sent):

* ``samples_total`` = n − first (n: the stream's samples at its end);
* ``samples_sent`` = the samples sent with index ≥ first;
* ``skipped`` = the samples from first to the last one due (n − 1 when it completed, the
  last sent else) that were not sent (late or a failed write); ``skipped_late`` the late
  ones among them (failed writes are counted once for the stream: they are charged to the
  move they end, the later one);
* ``duration_s``, ``achieved_rate_hz`` and the message of a completed move from those.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from robodcn.stream.report import ExecutionReport


def report_from(report: ExecutionReport, stream: Any, first: int) -> ExecutionReport:
    """``report`` of the finished ``stream`` with the counts of samples ``first`` … only
    (module doc)."""
    rec = stream.records
    count = rec.count
    index = np.asarray(rec.index[:count], dtype=np.int64)
    at = np.asarray(rec.at[:count], dtype=np.float64)
    mine = index >= first
    sent = int(mine.sum())
    total = max(0, int(stream.n) - first)
    completed = report.stop_reason == "completed"
    last = int(stream.n) - 1 if completed else (int(index[mine][-1]) if sent else first - 1)
    skipped = max(0, last - first + 1 - sent)
    failed = min(int(getattr(stream, "failed_writes", 0)), skipped)
    times = at[mine]
    span = float(times[-1] - times[0]) if sent > 1 else 0.0
    message = report.message
    if completed:
        message = (f"completed with {skipped} of {total} samples skipped "
                   f"({skipped - failed} late, {failed} failed writes)" if skipped
                   else "all samples sent")
    return dataclasses.replace(
        report, samples_total=total, samples_sent=sent, skipped=skipped,
        skipped_late=skipped - failed, message=message,
        duration_s=float(stream.t_end - times[0]) if sent else 0.0,
        achieved_rate_hz=(sent - 1) / span if span > 0 else 0.0)


__all__ = ["report_from"]
