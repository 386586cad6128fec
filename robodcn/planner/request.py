"""PlanRequest and StartState (they live in the contract layer: :mod:`robodcn.contract.request`)."""

from __future__ import annotations

from robodcn.contract.request import PlanRequest, StartState  # re-export (public path)

__all__ = ["PlanRequest", "StartState"]
