"""The tracking check's span (robodcn.stream.feedback): a read that lands late — the host
stalled between a write and its read — widens the span toward where the plan is by then,
never moves it off the goal the servos were given (issue 17 §7: a stall after the first
sample once read as 224 ticks of tracking error and stopped the move)."""

from __future__ import annotations

import numpy as np

from robodcn.stream.feedback import Feedback


def test_a_late_read_of_the_first_sample_is_measured_from_the_goal_written():
    goal = np.array([2048, 900, 1500])
    plan_later = np.array([2272.0, 900.0, 1400.0])       # 11 samples on, at the limit
    present = goal.copy()                                # the servos hold the goal sent
    error = Feedback._tracking_error(present, None, goal, plan_later)
    assert (error == 0).all(), error


def test_a_servo_outside_the_span_still_counts():
    previous, goal = np.array([100, 100]), np.array([120, 90])
    plan = np.array([130.0, 80.0])
    error = Feedback._tracking_error(np.array([60, 150]), previous, goal, plan)
    assert list(error) == [-40, 50]
    # within the span of previous, written and planned goals: none
    assert (Feedback._tracking_error(np.array([125, 95]), previous, goal, plan) == 0).all()
