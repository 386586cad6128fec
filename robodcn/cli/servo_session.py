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
    """A ServoBus on ``--device`` (or the arm's port) at ``--baud`` (or the arm's), opened,
    with every servo of the arm answering: a silent one is named by its joint
    (:class:`~robodcn.errors.ServoMismatchError`) before anything is read or written."""
    from robodcn.bus import ServoBus, lower_latency_timer

    device = device_of(args, arm)
    note = lower_latency_timer(device).message(device)
    if note:
        say(f"robodcn: {note}")
    bus = ServoBus(device, baud_of(args, arm), servos=arm.servos, retries=3).open()
    try:
        missing = [spec for spec in arm.servos if bus.ping(spec.id) is None]
    except BaseException:
        bus.close()
        raise
    if missing:
        bus.close()
        raise missing_servos_error(arm, missing, device, bus.baud, args)
    return bus


def missing_servos_error(arm: Arm, missing, device: str, baud: int,
                         args: argparse.Namespace):
    """The ServoMismatchError naming each silent servo by its joint."""
    import os

    from robodcn.errors import ServoMismatchError

    names = dict(zip((s.id for s in arm.servos), arm.joint_names, strict=True))
    which = ", ".join(f"joint {names[s.id]!r} (servo {s.id})" for s in missing)
    verb = "does" if len(missing) == 1 else "do"
    hint = "" if getattr(args, "arm", None) or os.environ.get("ROBODCN_ARM") else (
        f"; without --arm these are the servos of {arm.name!r} ({arm.source}): give your "
        "arm file with --arm")
    return ServoMismatchError(
        f"{which} {verb} not answer on {device} at {baud} baud: check power and cable, the "
        f"id and baud (robodcn scan --device {device} lists what answers){hint}",
        field="servos", value={"missing": [s.id for s in missing]})


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


__all__ = ["add_bus_options", "baud_of", "check_models", "device_of",
           "missing_servos_error", "model_warning", "open_bus", "warn_models"]
