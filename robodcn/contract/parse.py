"""A decoded JSON body → a validated :class:`~robodcn.contract.PlanRequest`."""

from __future__ import annotations

from collections.abc import Iterable

from numpy.typing import ArrayLike

from robodcn.config import Arm
from robodcn.contract.checks import check_body
from robodcn.contract.request import PlanRequest


def parse_request(body: object, arm: Arm, *, omit: Iterable[str] = (),
                  start_joints: ArrayLike | None = None) -> PlanRequest:
    """A decoded JSON body → a validated :class:`~robodcn.contract.PlanRequest` for ``arm``.

    Every error is an InputError (TooLargeError for the caps) whose ``field`` is the JSON
    path of the bad value, raised before anything is planned: not an object, unknown fields
    (and those in ``omit``), wrong JSON types (a bool is not a number, an object is not a
    list), integers too large for a float, non-finite or out-of-range numbers, too many
    waypoints, a duration × rate over the sample cap (:func:`~.checks.check_body`, then
    the request's own checks). ``rate_hz`` defaults to the arm's bus rate.

    ``start_joints``: the present joints a service fills in for a body that gives no start
    (a move body omits it): the plan starts there, and one waypoint is then enough
    (``{"waypoints": [G]}``: from the present pose to G).
    """
    fields = check_body(body, omit)
    if start_joints is not None and fields.get("start_joints") is None \
            and fields.get("start_state") is None:
        fields["start_joints"] = start_joints
    return PlanRequest(arm=arm, **fields)
