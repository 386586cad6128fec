"""Everyday workflow around a real arm: calibrate, teach, replay files, servo admin, checks.

Library functions behind the ``robodcn calibrate | teach | run | pose | torque | reboot |
servo | check-config | config`` subcommands (their argument parsing, dialogue and text are
in :mod:`robodcn.cli`): typed arguments in, data out, logging only. Each module holds one
concept:

- :mod:`~robodcn.workflow.examples` — the example arms shipped as package data, ``--arm NAME``
- :mod:`~robodcn.workflow.check` — validate a config and summarise it
- :mod:`~robodcn.workflow.admin` — present state, torque, reboot, servo info, set id/baud,
  USB latency timer
- :mod:`~robodcn.workflow.calibrate` — zero offsets, directions and ranges by hand
- :mod:`~robodcn.workflow.teach` — record poses by hand into a waypoints file
- :mod:`~robodcn.workflow.files` — waypoints TOML, Trajectory JSON, JointTrajectory JSON
- :mod:`~robodcn.workflow.run` — what ``run`` plays: a file's plan request, the approach
- :mod:`~robodcn.workflow.record` — what a move measured, as JSON or CSV
- :mod:`~robodcn.workflow.summary` — a planned trajectory's peaks against the limits

Nothing here is imported by the planner; modules that talk to servos import
:mod:`robodcn.bus` (dynamixel-sdk) themselves.
"""

from __future__ import annotations

from robodcn.workflow.examples import EXAMPLES, example_path, example_text, resolve_arm

__all__ = ["EXAMPLES", "example_path", "example_text", "resolve_arm"]
