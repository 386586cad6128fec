"""Joint velocities and efforts in the state (issue 29 §2): ``GET /v1/state``'s
``velocities`` (rad/s) and ``efforts`` (N·m) from Present Velocity and Present Current, and
``/joint_states``' velocity and effort arrays, against firmware_sim over the real SDK:
velocity checked against finite differences of the positions of the same messages, effort
against the holding torque of :mod:`robodcn.dynamics` on the OM-X at rest."""

from __future__ import annotations

import dataclasses
import json
import time
from typing import Any

import numpy as np
import pytest
from http_helpers import ROOT, call, poll_move, serving_arm
from ros2_peer import RosPeer
from zenoh_helpers import peer, wait_for, zenoh_arm

from robodcn import dynamics, servo_units
from robodcn.config import load_arm, rigid_chain
from robodcn.errors import InputError

pytest_plugins = ["http_helpers"]

OMX = load_arm(ROOT / "configs" / "omx.toml")


# -- the conversions ------------------------------------------------------------------------

def _reversed(servos: Any, j: int) -> list[Any]:
    out = list(servos)
    out[j] = dataclasses.replace(out[j], direction=-out[j].direction)
    return out


def test_efforts_invert_the_float_teach_currents() -> None:
    """joint_efforts inverts float teach's holding law i = direction·g/K_t (a reversed
    servo too), K_t the XM430-W350's datasheet 4.1 N·m / 2.3 A."""
    servos = _reversed(OMX.servos, 2)
    q = np.array([0.2, -0.4, 0.9, 0.3])
    g = dynamics.gravity_torque(rigid_chain(OMX), q, OMX.payload_kg)
    direction = np.array([s.direction for s in servos])
    amps = direction * g / (4.1 / 2.3)
    assert servo_units.joint_efforts(amps, servos) == pytest.approx(g, abs=1e-12)
    assert servo_units.joint_efforts(amps[None, :], servos)[0] == pytest.approx(g, abs=1e-12)
    assert servo_units.joint_efforts(amps, OMX.servos)[2] == pytest.approx(-g[2], abs=1e-12)


def test_velocities_take_each_servos_sense() -> None:
    servos = _reversed(OMX.servos, 1)
    shaft = np.array([0.5, 0.5, -0.25, 0.0])
    assert servo_units.joint_velocities(shaft, servos).tolist() == [0.5, -0.5, -0.25, 0.0]
    # the sense of the angles: ticks moving up on a reversed servo are a falling angle
    ticks = np.array([[2048] * 4, [2148] * 4])
    angles = servo_units.ticks_to_radians(ticks, servos)
    assert np.sign(np.diff(angles, axis=0)[0]).tolist() == \
        np.sign(servo_units.joint_velocities(np.ones(4), servos)).tolist()


def test_a_wrong_width_names_the_field() -> None:
    with pytest.raises(InputError, match="currents must have shape") as info:
        servo_units.joint_efforts([0.1, 0.2], OMX.servos)
    assert info.value.field == "currents"


# -- GET /v1/state at rest on the OM-X -------------------------------------------------------

#: The most the sim's gearbox friction holds of a load at rest (firmware_sim: Coulomb half of
#: a no-load current of 10 % of stall, ≈ 5.3 % of the XM430's 4.1 N·m stall torque), plus a
#: margin for the position loop's last tick: a servo at rest pushes g(q) ± this much.
FRICTION_NM = 0.06 * 4.1


def test_state_at_rest_gives_zero_velocity_and_the_holding_torque() -> None:
    stretched = [0.26, 0.0, 0.08, 0.0]     # forward and low: the shoulder holds the most
    with serving_arm(OMX, request_timeout=10.0) as (server, _sa):
        status, _, body = call(server, "POST", "/v1/moves",
                               {"waypoints": [list(OMX.home), stretched], "duration": 2.0})
        assert status == 202, body
        poll_move(server, body["id"], lambda b: b["status"] in ("done", "degraded"))
        time.sleep(0.5)                    # the servos settle after the last goal
        status, _, state = call(server, "GET", "/v1/state")
    assert status == 200 and state["source"] == "bus"
    assert len(state["velocities"]) == len(state["efforts"]) == 4
    assert np.abs(state["velocities"]).max() < 0.05
    g = dynamics.gravity_torque(rigid_chain(OMX), np.array(state["joints"]), OMX.payload_kg)
    effort = np.array(state["efforts"])
    assert np.abs(effort - g).max() <= FRICTION_NM, (effort, g)
    loaded = np.abs(g) > FRICTION_NM
    assert loaded.any(), g                 # the pose loads a joint beyond friction
    assert (np.sign(effort[loaded]) == np.sign(g[loaded])).all(), (effort, g)
    assert (np.abs(effort[loaded]) >= np.abs(g[loaded]) - FRICTION_NM).all()


# -- /joint_states while a move streams --------------------------------------------------------

def _stamp(msg: dict[str, Any]) -> float:
    return msg["header"]["stamp"]["sec"] + msg["header"]["stamp"]["nanosec"] * 1e-9


@pytest.mark.serial  # finite differences on the real clock
def test_joint_states_carry_velocity_and_effort_during_a_move() -> None:
    with zenoh_arm("left", ros2=True) as (server, _native, endpoint), peer(endpoint) as s:
        time.sleep(0.3)
        rp = RosPeer(s)
        got = rp.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        native: list[dict[str, Any]] = []
        s.declare_subscriber("robodcn/left/state",
                             lambda m: native.append(json.loads(m.payload.to_bytes())))
        wait_for(lambda: got and native, 5, "a joint state at rest")
        q0 = list(server.controller.state().joints)
        target = [q0[0] + 0.6, q0[1] - 0.5, q0[2] + 0.4]
        rp.publish("/arm_controller/joint_trajectory", "trajectory_msgs/msg/JointTrajectory",
                   {"joint_names": list(server.controller.arm.joint_names), "points": [
                       {"positions": q0, "time_from_start": {"sec": 0, "nanosec": 0}},
                       {"positions": target, "time_from_start": {"sec": 1,
                                                                 "nanosec": 500_000_000}}]})
        wait_for(lambda: server.controller.moves() and not server.controller.busy
                 and server.controller.moves()[-1].status in ("done", "degraded"), 15,
                 "the trajectory to be played")
    # the Zenoh state key carries them too (the GET /v1/state JSON)
    streamed = [st for st in native if st["moving"] and st["velocities"] is not None]
    assert len(streamed) > 20 and max(np.abs(st["velocities"]).max() for st in streamed) > 0.2
    assert all(len(st["efforts"]) == 3 for st in streamed)
    fed = [m for _, m, _ in got if m["velocity"]]   # at rest too (zeros from the bus read)
    assert len(fed) > 50
    assert all(len(m["velocity"]) == len(m["effort"]) == 3 for m in fed)
    assert any(np.abs(m["effort"]).max() > 0 for m in fed)
    t = np.array([_stamp(m) for m in fed])
    q = np.array([m["position"] for m in fed])
    v = np.array([m["velocity"] for m in fed])
    k = 5                                   # central differences over ±5 messages (~0.1 s)
    fd = (q[2 * k:] - q[:-2 * k]) / (t[2 * k:] - t[:-2 * k])[:, None]
    mean = np.array([v[i - k:i + k + 1].mean(axis=0) for i in range(k, len(v) - k)])
    fast = np.abs(fd) > 0.2
    assert fast.sum() > 30
    assert (np.sign(mean[fast]) == np.sign(fd[fast])).mean() > 0.95
    ratio = mean[fast] / fd[fast]
    assert 0.7 < np.median(ratio) < 1.4, np.median(ratio)
