"""``serve`` takes ``move``'s execution options (--compensation, --tracking-limit, --recover),
applies them to every move it starts and says in ``GET /v1/arm`` what is in force."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
import urllib.request
from typing import Any

import pytest
from http_helpers import ARM, BODY, ROOT, call, finished, poll_move, running

from robodcn.cli import build_parser
from robodcn.cli.serve_cmd import EXECUTION_OPTIONS, execution_options
from robodcn.controller import DEFAULT_EXECUTE
from robodcn.http import make_server, openapi

ARM_FILE = str(ROOT / "configs" / "arm3r.toml")


def _actions(command: str) -> dict[str, Any]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command" or a.choices)
    return {a.dest: a for a in sub.choices[command]._actions}


def test_serve_declares_the_options_exactly_as_move() -> None:
    serve, move = _actions("serve"), _actions("move")
    for dest in EXECUTION_OPTIONS:
        s, m = serve[dest], move[dest]
        assert (s.option_strings, s.help, s.default, s.choices, s.type, s.metavar) == \
            (m.option_strings, m.help, m.default, m.choices, m.type, m.metavar), dest


def test_the_options_become_execution_options() -> None:
    parser = build_parser()
    args = parser.parse_args(["serve", "--arm", ARM_FILE, "--sim", "--compensation", "off",
                              "--tracking-limit", "5", "--recover"])
    assert execution_options(args) == {"compensation": False,
                                       "tracking_limit": math.radians(5), "recover": True}
    default = execution_options(parser.parse_args(["serve", "--arm", ARM_FILE, "--sim"]))
    moved = parser.parse_args(["move", "--arm", ARM_FILE, "--to", "0.2,0.1,0"])
    assert default == {"compensation": True,
                       "tracking_limit": math.radians(moved.tracking_limit), "recover": False}
    with pytest.raises(SystemExit):
        parser.parse_args(["serve", "--arm", ARM_FILE, "--compensation", "maybe"])


def test_arm_says_what_is_in_force_and_the_schema_documents_it() -> None:
    from robodcn.controller import ArmController
    from robodcn.simulated import simulated_arm

    with running(make_server(ARM, None, request_timeout=2.0)) as server:
        status, _, body = call(server, "GET", "/v1/arm")
        assert status == 200 and body["execution"] is None
    with simulated_arm(ARM, timing="fast") as sa:
        controller = ArmController(ARM, sa.bus, execute_options={
            "compensation": False, "tracking_limit": math.radians(7), "recover": True})
        try:
            with running(make_server(ARM, controller, request_timeout=2.0)) as server:
                status, _, body = call(server, "GET", "/v1/arm")
        finally:
            controller.close()
    assert status == 200
    assert body["execution"] == {"compensation": False, "tracking_limit_deg": 7.0,
                                 "recover": True}          # exactly: no 6.999999999999999
    schema = openapi(ARM)["components"]["schemas"]["Arm"]
    assert "execution" in schema["properties"]
    assert DEFAULT_EXECUTE.compensation is True  # what a controller without options runs


def _serve(*extra: str) -> tuple[subprocess.Popen[str], str]:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("ROBODCN_TOKEN", None)
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "serve", "--arm", ARM_FILE,
                             "--sim", "--port", "0", "--log-level", "warning", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert " on http://" in line, (line, proc.stderr.read() if proc.poll() is not None else "")
    return proc, line.rsplit(" on ", 1)[1].strip()


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=10) as resp:
        return json.loads(resp.read())


def _post(url: str, body: Any) -> Any:
    req = urllib.request.Request(url, json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=10) as resp:
        return json.loads(resp.read())


def test_serve_runs_every_move_with_the_options_given() -> None:
    proc, url = _serve("--compensation", "off", "--tracking-limit", "40", "--recover")
    try:
        arm = _get(f"{url}/v1/arm")
        assert arm["execution"] == {"compensation": False,
                                    "tracking_limit_deg": 40.0, "recover": True}
        move = _post(f"{url}/v1/moves", BODY)
        deadline = time.monotonic() + 20
        while not finished(done := _get(f"{url}/v1/moves/{move['id']}")):
            assert time.monotonic() < deadline, done
            time.sleep(0.05)
        assert done["status"] in ("done", "degraded"), done
        # what the stream executed with (the report), not only what /v1/arm says
        assert done["report"]["compensation"] is False
        assert done["report"]["tracking_limit_rad"] == pytest.approx(math.radians(40))
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=20)
    assert proc.returncode == 0


def test_compensation_is_on_by_default_in_every_move() -> None:
    from robodcn.controller import ArmController
    from robodcn.simulated import simulated_arm

    parser = build_parser()
    given = execution_options(parser.parse_args(["serve", "--arm", ARM_FILE, "--sim"]))
    with simulated_arm(ARM, timing="fast") as sa:
        controller = ArmController(ARM, sa.bus,
                                   execute_options={**given, "watchdog_ms": 1000})
        try:
            with running(make_server(ARM, controller, request_timeout=2.0)) as server:
                status, _, move = call(server, "POST", "/v1/moves", BODY)
                assert status == 202, move
                done = poll_move(server, move["id"], finished)
        finally:
            controller.close()
    assert done["report"]["compensation"] is True
    assert done["report"]["tracking_limit_rad"] == pytest.approx(math.radians(15))
