"""One exception hierarchy for robodcn.

Every error names what is wrong (``field``) and the offending ``value`` so that the CLI
can print one line and the HTTP service can answer ``{"error": {code, message, field}}``.
The classes map onto CLI exit codes and HTTP statuses through ``exit_code`` and
``http_status``::

    RobodcnError                      exit 1   500
    ├── InputError (ValueError)       exit 2   422  bad argument, shape, method, value
    │   ├── ConfigError               exit 2   422  bad arm/bus TOML (file, key, value)
    │   ├── DegenerateError           exit 2   422  e.g. DLB with a zero denominator
    │   └── TooLargeError             exit 2   413  a plan over the 10⁶-sample limit
    ├── PlanError                     exit 3   422  plan infeasible (names the sample)
    │   ├── UnreachableError
    │   ├── JointLimitError
    │   ├── VelocityLimitError
    │   ├── AccelerationLimitError
    │   └── TickLimitError
    ├── BusError                      exit 4   503  servo or bus fault
    │   ├── CommError                               no/garbled status packet
    │   ├── ServoMismatchError                      missing servo, wrong model
    │   ├── HardwareAlertError                      Hardware Error Status non-zero
    │   └── StartMismatchError                      arm far from the first sample
    ├── BusyError                     exit 4   409  another move is running
    └── StoppedError                  exit 130 409  stopped by the user
"""

from __future__ import annotations

from typing import Any


class RobodcnError(Exception):
    """Base of every robodcn error.

    Parameters
    ----------
    message
        Human-readable, one or two lines, naming the bad value and how to fix it.
    field
        The argument, config key or request field at fault (``"waypoints[2]"``).
    value
        The offending value, kept for programmatic use.
    """

    code: str = "error"
    exit_code: int = 1
    http_status: int = 500

    def __init__(self, message: str, *, field: str | None = None, value: Any = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field
        self.value = value

    def to_dict(self) -> dict[str, Any]:
        """The ``{"code", "message", "field"}`` body the HTTP service returns."""
        return {"code": self.code, "message": self.message, "field": self.field}


class InputError(RobodcnError, ValueError):
    """An argument is malformed: wrong shape, non-finite, unknown name, out of range."""

    code = "invalid_input"
    exit_code = 2
    http_status = 422


class ConfigError(InputError):
    """An arm or bus configuration file is invalid; names file, key and value."""

    code = "invalid_config"

    def __init__(self, message: str, *, file: str | None = None, key: str | None = None,
                 value: Any = None) -> None:
        where = f"{file}: " if file else ""
        super().__init__(f"{where}{message}", field=key, value=value)
        self.file = file
        self.key = key


class DegenerateError(InputError):
    """The input is well-formed but the operation is undefined for it (zero denominator)."""

    code = "degenerate"


class TooLargeError(InputError):
    """The request is well-formed but larger than the service handles (e.g. > 10⁶ samples)."""

    code = "too_large"
    http_status = 413


class PlanError(RobodcnError):
    """A plan cannot be executed within the arm's limits.

    Carries the first failing ``sample`` index, its time ``t`` (s), ``pose`` (x, y, θ) and
    ``joint`` name when known.
    """

    code = "plan_infeasible"
    exit_code = 3
    http_status = 422

    def __init__(self, message: str, *, field: str | None = None, value: Any = None,
                 sample: int | None = None, t: float | None = None,
                 pose: Any = None, joint: str | None = None) -> None:
        super().__init__(message, field=field, value=value)
        self.sample = sample
        self.t = t
        self.pose = pose
        self.joint = joint

    def to_dict(self) -> dict[str, Any]:
        body = super().to_dict()
        if self.sample is not None:
            body["sample"] = self.sample
            body["t"] = self.t
        if self.joint is not None:
            body["joint"] = self.joint
        return body


class UnreachableError(PlanError):
    code = "unreachable"


class JointLimitError(PlanError):
    code = "joint_limit"


class VelocityLimitError(PlanError):
    code = "velocity_limit"


class AccelerationLimitError(PlanError):
    code = "acceleration_limit"


class TickLimitError(PlanError):
    code = "tick_limit"


class BusError(RobodcnError):
    """The servo bus failed: communication, wrong servos, hardware alert."""

    code = "bus_fault"
    exit_code = 4
    http_status = 503


class CommError(BusError):
    code = "communication"


class ServoMismatchError(BusError):
    code = "servo_mismatch"


class HardwareAlertError(BusError):
    code = "hardware_alert"


class StartMismatchError(BusError):
    code = "start_mismatch"


class BusyError(RobodcnError):
    code = "busy"
    exit_code = 4
    http_status = 409


class StoppedError(RobodcnError):
    code = "stopped"
    exit_code = 130
    http_status = 409
