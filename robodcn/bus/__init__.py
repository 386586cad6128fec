"""The servo bus: Dynamixel X-series servos over Protocol 2.0, through dynamixel-sdk only.

One concept a module: ``control_table`` (addresses, models, baud, error bits), ``records``
(ServoInfo, StreamProfile), ``port`` (opening a PortHandler; serial failures as CommError),
``groups`` (Fast Sync Read decoding, goal rows), ``feedback`` (the indirect feedback map and
its decoding), ``latency`` (USB latency timer), ``wire`` (wire time of a cycle), ``scan``,
and :class:`ServoBus` (``servo_bus``) built from ``connection`` (port, lock, lost device),
``retry`` (the one retry helper), ``transactions`` (one servo's READ/WRITE),
``verification`` (ping, verify), ``reads`` (group reads, feedback), ``writes`` (goals,
torque, reboot, watchdog), ``configuration`` (configure, the feedback map's check),
``single`` (one servo by id or spec), ``currents`` (Goal/Present Current) and ``modes``
(Operating Mode switching).
Every public name is importable from ``robodcn.bus``.
"""

from __future__ import annotations

import logging

from robodcn.bus.control_table import (
    ADDR_BAUD_RATE,
    ADDR_BUS_WATCHDOG,
    ADDR_CURRENT_LIMIT,
    ADDR_FIRMWARE_VERSION,
    ADDR_GOAL_CURRENT,
    ADDR_GOAL_POSITION,
    ADDR_HARDWARE_ERROR,
    ADDR_MAX_POSITION_LIMIT,
    ADDR_MIN_POSITION_LIMIT,
    ADDR_MODEL_NUMBER,
    ADDR_OPERATING_MODE,
    ADDR_POSITION_D_GAIN,
    ADDR_POSITION_I_GAIN,
    ADDR_POSITION_P_GAIN,
    ADDR_PRESENT_CURRENT,
    ADDR_PRESENT_POSITION,
    ADDR_PROFILE_ACCELERATION,
    ADDR_PROFILE_VELOCITY,
    ADDR_RETURN_DELAY_TIME,
    ADDR_TORQUE_ENABLE,
    ALERT_BIT,
    BAUD_INDEX,
    CURRENT_MODES,
    FAST_SYNC_READ_MIN_FIRMWARE,
    GOAL_CURRENT_UNIT_A,
    HARDWARE_ERROR_BITS,
    MODEL_OPERATING_MODES,
    POSITION_MODES,
    WATCHDOG_MAX,
    WATCHDOG_UNIT_MS,
    describe_hardware_error,
)
from robodcn.bus.currents import current_unit
from robodcn.bus.feedback import ADDR_FEEDBACK, FEEDBACK_LENGTH, Feedback, decode_feedback
from robodcn.bus.groups import decode_row, encode_row
from robodcn.bus.latency import (
    SYSFS_USB_SERIAL,
    LatencyResult,
    LatencyTimerWarning,
    check_latency_timer,
    latency_timer_ms,
    lower_latency_timer,
)
from robodcn.bus.modes import ModeSwitch
from robodcn.bus.port import READ_POLL_S, SERIAL_ERRORS
from robodcn.bus.records import ServoInfo, StreamProfile
from robodcn.bus.scan import scan
from robodcn.bus.servo_bus import STRAGGLER_S, ServoBus
from robodcn.bus.wire import cycle_wire_time, mean_cycle_wire_time
from robodcn.servo_models import (
    MODEL_NAMES,
    MODEL_NUMBERS,
    OPERATING_MODE_CURRENT,
    OPERATING_MODE_CURRENT_POSITION,
    OPERATING_MODE_EXTENDED_POSITION,
    OPERATING_MODE_NAMES,
    OPERATING_MODE_POSITION,
    OPERATING_MODE_PWM,
    OPERATING_MODE_VELOCITY,
)

# A library logs, the application decides where it goes: without a configured handler
# (the CLI's -v/--log-level, the service's logging), nothing is printed.
logging.getLogger("robodcn.bus").addHandler(logging.NullHandler())

__all__ = [
    "ADDR_BAUD_RATE", "ADDR_BUS_WATCHDOG", "ADDR_CURRENT_LIMIT", "ADDR_FEEDBACK",
    "ADDR_FIRMWARE_VERSION", "ADDR_GOAL_CURRENT", "ADDR_GOAL_POSITION", "ADDR_HARDWARE_ERROR",
    "ADDR_MAX_POSITION_LIMIT", "ADDR_MIN_POSITION_LIMIT", "ADDR_MODEL_NUMBER",
    "ADDR_OPERATING_MODE", "ADDR_POSITION_D_GAIN", "ADDR_POSITION_I_GAIN",
    "ADDR_POSITION_P_GAIN", "ADDR_PRESENT_CURRENT", "ADDR_PRESENT_POSITION",
    "ADDR_PROFILE_ACCELERATION", "ADDR_PROFILE_VELOCITY", "ADDR_RETURN_DELAY_TIME",
    "ADDR_TORQUE_ENABLE", "ALERT_BIT", "BAUD_INDEX", "CURRENT_MODES",
    "FAST_SYNC_READ_MIN_FIRMWARE", "FEEDBACK_LENGTH", "GOAL_CURRENT_UNIT_A",
    "HARDWARE_ERROR_BITS", "MODEL_NAMES", "MODEL_NUMBERS", "MODEL_OPERATING_MODES",
    "OPERATING_MODE_CURRENT", "OPERATING_MODE_CURRENT_POSITION",
    "OPERATING_MODE_EXTENDED_POSITION", "OPERATING_MODE_NAMES", "OPERATING_MODE_POSITION",
    "OPERATING_MODE_PWM", "OPERATING_MODE_VELOCITY", "POSITION_MODES", "READ_POLL_S",
    "SERIAL_ERRORS", "STRAGGLER_S", "SYSFS_USB_SERIAL", "WATCHDOG_MAX", "WATCHDOG_UNIT_MS",
    "Feedback", "LatencyResult", "LatencyTimerWarning", "ModeSwitch", "ServoBus", "ServoInfo",
    "StreamProfile", "check_latency_timer", "current_unit", "cycle_wire_time",
    "decode_feedback", "decode_row", "describe_hardware_error", "encode_row",
    "latency_timer_ms", "lower_latency_timer", "mean_cycle_wire_time", "scan",
]
