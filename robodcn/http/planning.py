"""How the service paces planning: a size check before planning and two planning lanes."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from robodcn.errors import TooLargeError
from robodcn.http.context import Service
from robodcn.http.limits import LARGE_PLAN_SAMPLES, LARGE_PLAN_WAYPOINTS, MAX_RESPONSE
from robodcn.planner import PlanRequest


def _estimated_samples(req: PlanRequest) -> int | None:
    if req.duration == "auto":
        return None
    return int(req.duration * req.rate_hz) + 1


def _bytes_per_sample(req: PlanRequest) -> int:
    # t, x, y, θ, k joints (≥ 10 characters each as JSON) and k ticks (≥ 5).
    return 10 * (4 + req.arm.dof) + 5 * req.arm.dof


def check_response_size(req: PlanRequest) -> None:
    """413 before planning when the Trajectory JSON would exceed MAX_RESPONSE."""
    samples = _estimated_samples(req)
    if samples is not None and samples * _bytes_per_sample(req) > MAX_RESPONSE:
        most = MAX_RESPONSE // _bytes_per_sample(req)
        raise TooLargeError(f"{samples} samples ({req.duration:g} s at {req.rate_hz:g} Hz) "
                            f"would answer over {MAX_RESPONSE >> 20} MiB of JSON; at most "
                            f"about {most} samples per plan: shorten duration or lower rate_hz",
                            field="duration", value=req.duration)


@contextlib.contextmanager
def planning_lane(server: Service, req: PlanRequest) -> Iterator[None]:
    """Take turns planning: small plans on one lock, large ones on another.

    Planning is CPU-bound under the GIL, so taking turns on a lock lets waiting handlers
    sleep instead of contending (measured +40 % plans/s, 3× lower p99 with 8 clients,
    bench_http). A large plan (many samples or waypoints, or "auto" over many segments)
    takes the other lock, so it never makes the small ones queue behind it.
    """
    samples = _estimated_samples(req)
    large = (len(req.waypoints) > LARGE_PLAN_WAYPOINTS
             or (samples is not None and samples > LARGE_PLAN_SAMPLES)
             or (samples is None and len(req.waypoints) > 16))
    lock: threading.Lock = server.large_plan_lock if large else server.plan_lock
    with lock:
        yield
