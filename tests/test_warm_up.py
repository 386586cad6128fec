"""``warm_up`` pays the online laws' first calls before a stream starts: a refusal of
those laws (a re-timing or a brake the limits forbid) must never fail the move."""

from __future__ import annotations

import logging

import numpy as np
from conftest import ARM3R
from online_helpers import GOAL, RATE, START

from robodcn import kinematics
from robodcn.errors import InputError
from robodcn.planner import plan
from robodcn.stream.online import execution
from robodcn.stream.online.planning_times import PlanningTimes


def _trajectory():
    q0 = kinematics.ik(ARM3R.links, np.array([START]))[0]
    pose = tuple(kinematics.fk(ARM3R.links, q0[None])[0])
    return plan(ARM3R, [pose, GOAL], rate_hz=RATE, start_joints=q0)


def test_a_refused_retiming_does_not_fail_the_warm_up(monkeypatch, caplog):
    calls = []

    def refuse(*args, **kwargs):
        calls.append(args)
        raise InputError("the path cannot move from s = 0.83: every joint limit forbids it",
                         field="s", value=0.83)

    monkeypatch.setattr(execution, "retime", refuse)
    monkeypatch.setattr(execution, "brake_checked", refuse)
    with caplog.at_level(logging.DEBUG, logger="robodcn.stream"):
        execution.warm_up(_trajectory(), ARM3R, PlanningTimes())
    assert calls, "the warm-up re-timed the plan's path"
    assert any("warm-up" in r.getMessage() and r.levelno == logging.DEBUG
               for r in caplog.records)


def test_a_refused_retarget_does_not_fail_the_warm_up(monkeypatch):
    def refuse(self, *args, **kwargs):
        raise InputError("refused", field="goals", value=None)

    monkeypatch.setattr(execution.Retargeting, "tail", refuse)
    times = PlanningTimes()
    execution.warm_up(_trajectory(), ARM3R, times)
    assert times.warmed
