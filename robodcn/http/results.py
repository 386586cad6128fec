"""The service's result types moved to :mod:`robodcn.results` (the service layer, below the
HTTP edge); these names stay here."""

from robodcn.results import (  # re-export (transitional)
    RESULTS,
    ApproachInfo,
    ArmInfo,
    ErrorDetail,
    ErrorResponse,
    Health,
    MoveState,
    MoveStatus,
    RebootAnswer,
    Recording,
    State,
    StopAnswer,
    TorqueAnswer,
    to_json,
)

__all__ = ["RESULTS", "ApproachInfo", "ArmInfo", "ErrorDetail", "ErrorResponse", "Health",
           "MoveState", "MoveStatus", "RebootAnswer", "Recording", "State", "StopAnswer",
           "TorqueAnswer", "to_json"]
