"""A decoded JSON body → a validated :class:`~robodcn.contract.PlanRequest`."""

from __future__ import annotations

from collections.abc import Iterable

from robodcn.config import Arm
from robodcn.contract.checks import check_body
from robodcn.contract.request import PlanRequest


def parse_request(body: object, arm: Arm, *, omit: Iterable[str] = ()) -> PlanRequest:
    """A decoded JSON body → a validated :class:`~robodcn.contract.PlanRequest` for ``arm``.

    Every error is an InputError (TooLargeError for the caps) whose ``field`` is the JSON
    path of the bad value, raised before anything is planned: not an object, unknown fields
    (and those in ``omit``), wrong JSON types (a bool is not a number, an object is not a
    list), integers too large for a float, non-finite or out-of-range numbers, too many
    waypoints, a duration × rate over the sample cap (:func:`~.checks.check_body`, then
    the request's own checks). ``rate_hz`` defaults to the arm's bus rate.
    """
    return PlanRequest(arm=arm, **check_body(body, omit))
