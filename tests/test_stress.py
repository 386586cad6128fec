"""Online operations under races and abuse (issue 17 §7): several threads interleave new
moves, replacements, pauses, resumes, speed changes, stops and reads against a service on a
simulated arm — as ``serve --sim`` runs it, and as ``serve --device`` runs it on
firmware_sim over a pty — for ``ROBODCN_STRESS_S`` seconds each (default 20).

Must hold: no 5xx; every request answered within :data:`ANSWER_S`; every answer a status
its route documents; a Move or State answer consistent in itself (paused only while
running; moving ⇔ a move); every move ends done, degraded, stopped or replaced (the other
documented endings — collision, fault, failed — have no cause here: no obstacle, no
injected fault; a failure carries the move's error and report); after a stop the service
takes a new move, which runs to its end; and no goal the servos received steps further
than v_max·T (+1 tick) from the one before it (T the stream period). A failure names the
seed of the thread that saw it and its last requests.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from http_helpers import ARM, HOME, call, finished, running

from robodcn.controller import ArmController
from robodcn.http import make_server, openapi
from robodcn.http.service import open_device
from robodcn.simulated import sim_arm_document, simulated_arm, start_ticks
from robodcn.stream.compensation import max_steps

pytestmark = pytest.mark.serial

#: Seconds per variant (make test: 2 × 20 s); longer runs with ROBODCN_STRESS_S=300.
DURATION_S = float(os.environ.get("ROBODCN_STRESS_S", "20"))
THREADS = int(os.environ.get("ROBODCN_STRESS_THREADS", "6"))
SEED = int(os.environ.get("ROBODCN_STRESS_SEED", "17"))
#: Every request is answered within this (s).
ANSWER_S = 1.0
#: Seconds between the checks that a stop leaves the service ready for a new move.
PHASE_S = 5.0
#: As serve runs a move (serve_cmd defaults), with the Bus Watchdog relaxed: the simulator
#: and the clients share this process with the streamer.
EXECUTION = {"compensation": True, "tracking_limit": np.radians(15.0), "recover": False,
             "watchdog_ms": 1000}
#: Move statuses (robodcn.results.MoveState) a finished move may have here; ``collision``,
#: ``fault`` and ``failed`` are documented too, but nothing in this test causes them (no
#: obstacle, no injected fault): a move ending so fails the test.
ENDED = ("done", "degraded", "stopped", "replaced")
#: stop reasons that are findings whatever the move's status
FAULT_STOPS = ("collision", "tracking_error")
TARGETS = ([0.18, 0.12, 0.6], [0.2, 0.05, 0.3], [0.12, 0.24, 1.0], [0.25, 0.0, -0.3],
           [0.22, 0.15, 0.2], HOME)


def _documented() -> dict[tuple[str, str], set[int]]:
    doc = openapi(ARM)
    return {(path, method.upper()): {int(c) for c in op["responses"]}
            for path, ops in doc["paths"].items() for method, op in ops.items()}


DOCUMENTED = _documented()
#: (time.monotonic at the request, at its answer, what) of every request, to place a goal
#: jump (the simulator's clock is time.monotonic too).
REQUESTS: list[tuple[float, float, str]] = []
#: Moves of a run that ended without a cause here (collision, fault, failed), with why.
FINDINGS: list[str] = []


def _ending(move: dict[str, Any]) -> str:
    """A move's ending for a failure message: status, error, and its report's stop reason,
    message and collision."""
    report = move.get("report") or {}
    return (f"move {move.get('id')} ended {move.get('status')}: error {move.get('error')}, "
            f"stop reason {report.get('stop_reason')}, message {report.get('message')!r}, "
            f"collision {report.get('collision')}, progress {move.get('progress')}")


class GoalLog:
    """Every goal each simulated servo accepts from now on, with the time it arrived
    (firmware_sim's timed goal history; the goal held before included)."""

    def __init__(self, sim: Any) -> None:
        self.sim = sim
        self.since = {i: len(sim.goal_history(i)) for i in ARM.servo_ids}

    @property
    def rows(self) -> list[tuple[float, int, int]]:
        """(time accepted on the simulator's clock — time.monotonic —, servo id, goal)."""
        return [(t, i, g) for i in ARM.servo_ids
                for t, g in self.sim.timed_goal_history(i)[max(0, self.since[i] - 1):]]

    def steps_beyond_limits(self) -> list[str]:
        """Goal steps of a joint beyond v_max·T (+1 tick of rounding) from the goal before
        it, at every goal written (T the stream period; robodcn.stream.step_guard)."""
        allowed = np.floor(max_steps(ARM, ARM.servos, 1.0 / ARM.bus.rate_hz,
                                     len(ARM.servos))) + 1
        out = []
        every = self.rows
        for j, servo_id in enumerate(ARM.servo_ids):
            rows = [(t, g) for t, i, g in every if i == servo_id]
            if len(rows) < 2:
                continue
            t = np.array([r[0] for r in rows])
            g = np.array([r[1] for r in rows], dtype=np.int64)
            step = np.abs(np.diff(g))
            for k in np.flatnonzero(step > allowed[j])[:5]:
                out.append(f"servo {servo_id}: goal {g[k]} -> {g[k + 1]} ({step[k]} ticks) in "
                           f"{1e3 * (t[k + 1] - t[k]):.1f} ms, allowed {allowed[j]:.0f}; "
                           f"requests in the 0.3 s before: {_before(t[k + 1])}")
        return out


def _before(t: float, window: float = 0.3) -> list[str]:
    return [f"{1e3 * (t - a):.0f} ms before: {what}" for a, _, what in REQUESTS
            if t - window <= a <= t][-4:]


class Client:
    """One stress thread: random requests from its own seed; what it saw."""

    def __init__(self, server: Any, seed: int, go: threading.Event, stop: threading.Event,
                 idle: threading.Semaphore) -> None:
        self.server = server
        self.seed = seed
        self.rng = random.Random(seed)
        self.go, self.stop, self.idle = go, stop, idle
        self.failures: list[str] = []
        self.last: list[str] = []
        self.moves: set[str] = set()
        self.requests = 0

    def _request(self, method: str, path: str, body: Any = None) -> tuple[int, Any]:
        started = time.monotonic()
        status, _, answer = call(self.server, method, path, body, timeout=10)
        took = time.monotonic() - started
        REQUESTS.append((started, time.monotonic(), f"{method} {path} {json.dumps(body)} -> "
                         f"{status}"))
        self.requests += 1
        self.last = [*self.last[-7:], f"{method} {path} {json.dumps(body)} -> {status} "
                     f"({1e3 * took:.0f} ms)"]
        route = path if not path.startswith("/v1/moves/") else "/v1/moves/{id}"
        if status >= 500:
            self._fail(f"{status} on {method} {path}: {answer}")
        elif status not in DOCUMENTED[(route, method)]:
            self._fail(f"undocumented {status} on {method} {path}: {answer}")
        if took > ANSWER_S:
            self._fail(f"{method} {path} answered in {took:.2f} s")
        if status in (200, 202) and isinstance(answer, dict):
            self._consistent(answer)
        return status, answer

    def _consistent(self, answer: dict[str, Any]) -> None:
        if "progress" in answer:  # a Move
            self.moves.add(answer["id"])
            if answer["paused"] and answer["status"] != "running":
                self._fail(f"move {answer['id']} paused while {answer['status']}")
        elif "moving" in answer:  # a State
            if answer["moving"] != (answer["move"] is not None):
                self._fail(f"state moving={answer['moving']} with move {answer['move']}")
            if answer["paused"] and not answer["moving"]:
                self._fail("state paused without a move")

    def _fail(self, what: str) -> None:
        self.failures.append(f"seed {self.seed}: {what}; last requests: {self.last}")

    def _move_body(self) -> dict[str, Any]:
        target = self.rng.choice(TARGETS)
        body: dict[str, Any] = {"waypoints": [HOME, target], "rate_hz": 100}
        if self.rng.random() < 0.3:
            body["duration"] = round(self.rng.uniform(0.8, 2.5), 2)
        return body

    def step(self) -> None:
        op = self.rng.choices(("move", "replace", "pause", "resume", "speed", "stop",
                               "state", "status"), weights=(3, 4, 2, 2, 2, 1, 2, 1))[0]
        if op == "move":
            status, answer = self._request("POST", "/v1/moves", self._move_body())
            if status == 202:
                self.moves.add(answer["id"])
        elif op == "replace":
            status, answer = self._request("POST", "/v1/moves",
                                           {**self._move_body(), "replace": True})
            if status == 202:
                self.moves.add(answer["id"])
        elif op == "pause":
            status, answer = self._request("POST", "/v1/pause")
            if status == 200 and not (answer["paused"] or answer["status"] != "running"):
                self._fail(f"pause answered 200 with paused false: {answer}")
        elif op == "resume":
            self._request("POST", "/v1/resume")
        elif op == "speed":
            scale = self.rng.choice((0.2, 0.5, 0.8, 1.0, self.rng.uniform(0.05, 1.0)))
            self._request("PUT", "/v1/speed", {"scale": scale})
        elif op == "stop":
            mode = self.rng.choice(("smooth", "hold"))
            status, answer = self._request("POST", "/v1/stop", {"mode": mode})
            if status == 200 and answer["stopped"] and answer["status"] == "running" \
                    and mode == "hold":
                self._fail(f"a hold answered with the move still running: {answer}")
        elif op == "state":
            self._request("GET", "/v1/state")
        elif self.moves:
            self._request("GET", f"/v1/moves/{self.rng.choice(sorted(self.moves))}")
        time.sleep(self.rng.uniform(0.0, 0.03))

    def run(self) -> None:
        try:
            while not self.stop.is_set():
                if not self.go.is_set():
                    self.idle.release()
                    self.go.wait()
                    continue
                self.step()
        except Exception as exc:  # the failure of this thread, with its seed
            self._fail(f"{type(exc).__name__}: {exc}")
        finally:
            self.idle.release()


def _wait_idle(server: Any, timeout: float = 5.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        status, _, state = call(server, "GET", "/v1/state")
        assert status == 200, state
        if not state["moving"]:
            return state
        assert time.monotonic() < deadline, f"still moving {timeout:g} s after a stop: {state}"
        time.sleep(0.02)


def _usable_after_a_stop(server: Any) -> None:
    """Stop (hold), then a new move is taken (202) and runs to its end."""
    status, _, answer = call(server, "POST", "/v1/stop", {"mode": "hold"})
    assert status == 200, answer
    _wait_idle(server)
    status, _, move = call(server, "POST", "/v1/moves",
                           {"waypoints": [HOME, TARGETS[0]], "rate_hz": 100})
    assert status == 202, f"no new move after a stop: {move}"
    deadline = time.monotonic() + 10
    while not finished(done := call(server, "GET", f"/v1/moves/{move['id']}")[2]):
        assert time.monotonic() < deadline, done
        time.sleep(0.02)
    if done["status"] not in ("done", "degraded"):
        FINDINGS.append(f"the move after a stop: {_ending(done)}")


def _check_endings(server: Any, moves: set[str], checked: set[str]) -> None:
    """Each of ``moves`` not yet in ``checked`` that has ended: not paused, and its status
    one this test can cause (else a finding with its error and report)."""
    for move_id in sorted(moves - checked, key=int):
        status, _, move = call(server, "GET", f"/v1/moves/{move_id}")
        if status == 404:  # past the service's history
            checked.add(move_id)
            continue
        if not finished(move):
            continue
        checked.add(move_id)
        assert not move["paused"], move
        report = move.get("report") or {}
        # a collision or tracking stop is a finding under any status (free space, a sim
        # that follows): a status that hides it (a replace racing the stop) must not
        if move["status"] not in ENDED or report.get("stop_reason") in FAULT_STOPS \
                or report.get("collision"):
            FINDINGS.append(_ending(move))


def stress(server: Any, goals: GoalLog) -> None:
    go, stop = threading.Event(), threading.Event()
    idle = threading.Semaphore(0)
    clients = [Client(server, SEED * 1000 + i, go, stop, idle) for i in range(THREADS)]
    threads = [threading.Thread(target=c.run, name=f"stress-{i}", daemon=True)
               for i, c in enumerate(clients)]
    go.set()
    for t in threads:
        t.start()
    end = time.monotonic() + DURATION_S
    checked: set[str] = set()
    try:
        while time.monotonic() < end:
            time.sleep(min(PHASE_S, max(0.0, end - time.monotonic())))
            go.clear()
            for _ in clients:  # every thread between two requests
                assert idle.acquire(timeout=15), "a stress thread did not come back"
            _usable_after_a_stop(server)
            # every move so far has ended: check them while the history still holds them
            _check_endings(server, set().union(*(c.moves for c in clients)), checked)
            go.set()
    finally:
        stop.set()
        go.set()
        for t in threads:
            t.join(15)
    failures = [f for c in clients for f in c.failures][:10]
    _wait_idle(server)
    seen = set().union(*(c.moves for c in clients))
    _check_endings(server, seen, checked)
    # all that went wrong in one message: a client's failure may follow from a move's
    failures += [*FINDINGS, *goals.steps_beyond_limits()]
    FINDINGS.clear()
    assert not failures, "\n".join(failures)
    assert sum(c.requests for c in clients) > 20 * DURATION_S
    assert len(seen) >= 5, seen


@contextlib.contextmanager
def _service(bus: Any) -> Iterator[Any]:
    controller = ArmController(ARM, bus, execute_options=EXECUTION)
    try:
        with running(make_server(ARM, controller, request_timeout=5.0)) as server:
            yield server
    finally:
        controller.close()


def test_stress_serve_sim() -> None:
    """As ``serve --sim``: the simulated arm in realistic timing."""
    with simulated_arm(ARM, timing="realistic") as sa:
        goals = GoalLog(sa.sim)
        with _service(sa.bus) as server:
            stress(server, goals)
    assert not sa.sim.errors, sa.sim.errors


def test_stress_serve_device_on_firmware_sim() -> None:
    """As ``serve --device``: firmware_sim on a pty, the device opened as serve opens it."""
    from firmware_sim.bus import SimBus
    from firmware_sim.bus_config import SimBusConfig

    ticks = start_ticks(ARM)
    sim = SimBus(config=SimBusConfig(
        ids=ARM.servo_ids, model={s.id: s.model for s in ARM.servos}, baud=ARM.bus.baud,
        timing="realistic", log=False, dynamics=True, arm=sim_arm_document(ARM),
        positions={i: int(t) for i, t in zip(ARM.servo_ids, ticks, strict=True)}))
    sim.start()
    try:
        goals = GoalLog(sim)
        with open_device(ARM, sim.port_path) as bus, _service(bus) as server:
            stress(server, goals)
    finally:
        sim.close()
    assert not sim.errors, sim.errors
