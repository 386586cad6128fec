"""Collision thresholds along an online chain (robodcn.stream.collision.ChainThresholds,
issue 17 §7): a tail's motion has its own thresholds, not those of the plan it replaced (a
retarget out of a plan that stood still was stopped as a collision at the plan's 0.5 A)."""

from __future__ import annotations

import math

import numpy as np
from conftest import ARM3R

from robodcn.planner import plan
from robodcn.stream.collision import MARGIN_A, ChainThresholds, predicted_currents


class Node:
    """What ChainThresholds reads of an online chain node."""

    def __init__(self, prev, switch, joints):
        self.prev, self.switch, self.joints = prev, switch, np.asarray(joints)

    def joint(self, i):
        node = self
        while i < node.switch and node.prev is not None:
            node = node.prev
        return node.joints[min(max(i - node.switch, 0), len(node.joints) - 1)]


def test_a_tail_is_held_to_its_own_current_and_the_plan_before_it_to_the_plan_s():
    move = plan(ARM3R, [(0.25, 0.10, 0.0), (0.12, 0.24, math.radians(60))], duration="auto")
    period = 1.0 / move.rate_hz
    still = np.repeat(move.joints[:1], 60, axis=0)          # a plan that does not move
    root = Node(None, 0, still)
    tail = Node(root, 30, move.joints)                       # a retarget from sample 30
    chain = ChainThresholds(period, ARM3R.servos, ARM3R, None, [2.3] * 3, None)
    before = chain.at(tail, 10)
    assert np.allclose(before, chain.at(root, 10))
    peak = np.abs(predicted_currents(move.joints, period, ARM3R.servos, ARM3R)).max(axis=0)
    during = np.max([chain.at(tail, 30 + i) for i in range(len(move.t))], axis=0)
    # the tail's samples get the current its motion needs, well above the still plan's
    assert (during > before + 0.5 * peak).all(), (during, before, peak)
    assert (during >= 2 * peak + MARGIN_A - 1e-9).all()
    # past the tail's end (a hold) the threshold is its last sample's
    assert np.allclose(chain.at(tail, 30 + len(move.t) + 50), chain.at(tail, 30 + len(move.t)))
