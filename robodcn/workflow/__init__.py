"""Everyday workflow around a real arm: calibrate, teach, replay files, servo admin, checks.

Library functions behind the ``robodcn calibrate | teach | run | pose | torque | reboot |
servo | check-config | config`` subcommands (:mod:`robodcn.workflow.commands`). Each module
holds one concept:

- :mod:`~robodcn.workflow.examples` — the example arms shipped as package data, ``--arm NAME``
- :mod:`~robodcn.workflow.check` — validate a config and summarise it
- :mod:`~robodcn.workflow.admin` — present state, torque, reboot, servo info, set id/baud,
  USB latency timer
- :mod:`~robodcn.workflow.calibrate` — zero offsets, directions and ranges by hand
- :mod:`~robodcn.workflow.teach` — record poses by hand into a waypoints file
- :mod:`~robodcn.workflow.files` — waypoints TOML, Trajectory JSON, JointTrajectory JSON

Nothing here is imported by the planner; modules that talk to servos import
:mod:`robodcn.bus` (dynamixel-sdk) themselves.
"""

from __future__ import annotations

from robodcn.workflow.examples import EXAMPLES, example_path, example_text, resolve_arm

__all__ = ["EXAMPLES", "example_path", "example_text", "resolve_arm"]
