"""Opening the arm's servo bus for a hands-on command (calibrate, teach, run, pose, torque,
reboot, servo info): ``--device`` or the arm's ``[bus] port``, ``--baud`` or its baud.

The USB adapter's latency timer is lowered to 1 ms first when its sysfs file is writable
(and said so on stderr).
"""

from __future__ import annotations

import argparse

from robodcn.cli import options
from robodcn.cli.dialogue import say
from robodcn.config import Arm


def add_bus_options(p: argparse.ArgumentParser) -> None:
    """--device DEV (and its deprecated spelling --port) and --baud, defaulting to the arm's."""
    options.add_device_options(p, default_help="default: the arm's [bus] port")


def device_of(args: argparse.Namespace, arm: Arm) -> str:
    """``--device``, else the arm's [bus] port."""
    return args.device or arm.bus.port


def baud_of(args: argparse.Namespace, arm: Arm) -> int:
    """``--baud``, else the arm's [bus] baud."""
    return args.baud or arm.bus.baud


def open_bus(args: argparse.Namespace, arm: Arm):
    """A ServoBus on ``--device`` (or the arm's port) at ``--baud`` (or the arm's), opened."""
    from robodcn.bus import ServoBus, lower_latency_timer

    device = device_of(args, arm)
    note = lower_latency_timer(device).message(device)
    if note:
        say(f"robodcn: {note}")
    return ServoBus(device, baud_of(args, arm), servos=arm.servos, retries=3).open()


def model_warning(mismatch) -> str:
    """One :class:`robodcn.workflow.admin.ModelMismatch` in words."""
    return (f"servo {mismatch.servo_id} (joint {mismatch.joint!r}) answers as model "
            f"{mismatch.found or '?'} (number {mismatch.found_number}), the config says "
            f"{mismatch.configured} (number {mismatch.configured_number or '?'}): its ticks "
            "and limits may not be the config's; 'robodcn move' refuses this arm")


def warn_models(mismatches) -> None:
    """A ``robodcn: warning:`` line per servo whose model differs from the config's."""
    for mismatch in mismatches:
        say(f"robodcn: warning: {model_warning(mismatch)}")


def check_models(bus, arm: Arm) -> None:
    """PING the arm's servos and warn (:func:`warn_models`) about those of another model."""
    from robodcn.workflow.admin import bus_model_mismatches

    warn_models(bus_model_mismatches(bus, arm))


__all__ = ["add_bus_options", "baud_of", "check_models", "device_of", "model_warning",
           "open_bus", "warn_models"]
