"""``serve --plan-only --processes N``: N worker processes answer on one port, each with the
in-process planner's exact bytes; the service ends every worker with itself, ends itself
when a worker dies, and is refused with an arm attached or a bad N.

Which worker answered a connection is read from /proc (the server side of the TCP
connection is a socket inode in exactly one worker's fd table), not from the answer.
"""

from __future__ import annotations

import errno
import http.client
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from http_helpers import ARM, ROOT

from bench.proc_children import children
from robodcn.cli import main
from robodcn.errors import InputError
from robodcn.http import ListenError, make_server
from robodcn.http.jsonbody import decode_json
from robodcn.http.planbody import parse_plan
from robodcn.http.prefork import bind_group
from robodcn.planner import plan_request

pytestmark = pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")

ARM_FILE = str(ROOT / "configs" / "arm3r.toml")
PLAN = {"waypoints": [[0.25, 0.10, 0.0], [0.15, 0.20, 1.0]], "duration": 0.5, "rate_hz": 100}
#: Generous bounds for a loaded machine (waiting for a condition, never a timing assertion).
DEADLINE = 30.0


def _spawn(processes: int) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("ROBODCN_TOKEN", None)
    return subprocess.Popen([sys.executable, "-m", "robodcn", "serve", "--arm", ARM_FILE,
                             "--plan-only", "--processes", str(processes), "--port", "0",
                             "--log-level", "warning"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def _ready(proc: subprocess.Popen[str]) -> int:
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert " on http://" in line, (line, proc.stderr.read() if proc.poll() is not None else "")
    return int(line.rsplit(":", 1)[1])


#: The services the tests below use, by name: (processes); started together (their start-up,
#: mostly imports, overlaps) by the ``services`` fixture.
SERVICES = {"two": 2, "one": 1, "three": 3, "victim": 2, "orphans": 2}


@pytest.fixture(scope="module")
def services() -> Iterator[dict[str, subprocess.Popen[str]]]:
    procs = {name: _spawn(n) for name, n in SERVICES.items()}
    try:
        yield procs
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
            proc.communicate(timeout=DEADLINE)


def _workers(proc: subprocess.Popen[str], count: int) -> set[int]:
    deadline = time.monotonic() + DEADLINE
    while len(found := children(proc.pid)) < count:
        assert proc.poll() is None and time.monotonic() < deadline, (found, proc.poll())
        time.sleep(0.05)
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _stop(proc: subprocess.Popen[str], sig: int = signal.SIGTERM) -> str:
    if proc.poll() is None:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=DEADLINE)
    return err


def _server_inode(local_port: int, server_port: int) -> str | None:
    """The inode of the server's end of the connection from ``local_port``."""
    want_local, want_remote = f":{server_port:04X}", f":{local_port:04X}"
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        parts = line.split()
        if parts[1].endswith(want_local) and parts[2].endswith(want_remote):
            return parts[9]
    return None


def _holder(inode: str, pids: set[int]) -> int | None:
    for pid in pids:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                if os.readlink(fd) == f"socket:[{inode}]":
                    return pid
            except OSError:
                continue
    return None


def _expected() -> bytes:
    raw = json.dumps(PLAN).encode()
    return plan_request(parse_plan(ARM, decode_json(raw, "application/json"))).to_json().encode()


def test_every_worker_answers_the_planners_bytes_and_ends_with_the_service(
        services: dict[str, subprocess.Popen[str]]) -> None:
    proc = services["two"]
    port = _ready(proc)
    try:
        workers = _workers(proc, 2)
        expected = _expected()
        answered: dict[int, int] = {}
        conns = []
        # The kernel spreads connections by a hash of the client port: keep each open
        # (another connection cannot reuse its port) until both workers have answered.
        for _ in range(64):
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=DEADLINE)
            conns.append(conn)
            conn.request("POST", "/v1/trajectories", body=json.dumps(PLAN),
                         headers={"Content-Type": "application/json"})
            resp = conn.getresponse()
            body = resp.read()
            assert resp.status == 200, body[:200]
            assert body == expected
            inode = _server_inode(conn.sock.getsockname()[1], port)
            assert inode is not None
            pid = _holder(inode, workers)
            assert pid in workers
            answered[pid] = answered.get(pid, 0) + 1
            if len(answered) == 2:
                break
        for conn in conns:
            conn.close()
        assert set(answered) == workers, answered
    finally:
        err = _stop(proc)
    assert proc.returncode == 0, err
    assert not any(_alive(pid) for pid in workers), workers
    assert not children(proc.pid)


def test_plan_only_in_one_process_plans_and_has_no_arm(
        services: dict[str, subprocess.Popen[str]]) -> None:
    proc = services["one"]
    port = _ready(proc)
    try:
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=DEADLINE)
        conn.request("POST", "/v1/trajectories", body=json.dumps(PLAN),
                     headers={"Content-Type": "application/json"})
        resp = conn.getresponse()
        assert (resp.status, resp.read()) == (200, _expected())
        conn.request("GET", "/v1/state")
        resp = conn.getresponse()
        assert resp.status == 503 and json.loads(resp.read())["error"]["code"] == "no_arm"
        conn.close()
        assert not children(proc.pid)  # no worker processes: the server itself answers
    finally:
        err = _stop(proc)
    assert proc.returncode == 0, err


def test_ctrl_c_ends_the_service_and_its_workers(
        services: dict[str, subprocess.Popen[str]]) -> None:
    proc = services["three"]
    _ready(proc)
    workers = _workers(proc, 3)
    err = _stop(proc, signal.SIGINT)
    assert proc.returncode == 0, err
    assert not any(_alive(pid) for pid in workers), workers


def test_a_worker_that_dies_ends_the_service_with_an_error(
        services: dict[str, subprocess.Popen[str]]) -> None:
    proc = services["victim"]
    _ready(proc)
    workers = _workers(proc, 2)
    victim, other = sorted(workers)
    os.kill(victim, signal.SIGKILL)
    try:
        proc.wait(DEADLINE)
    finally:
        err = _stop(proc)
    assert proc.returncode == 6, err
    assert f"worker process {victim}" in err and "SIGKILL" in err, err
    assert not _alive(other)


def test_workers_end_when_the_parent_is_killed(
        services: dict[str, subprocess.Popen[str]]) -> None:
    proc = services["orphans"]
    _ready(proc)
    workers = _workers(proc, 2)
    proc.kill()
    proc.communicate(timeout=DEADLINE)
    deadline = time.monotonic() + DEADLINE
    while any(_alive(pid) for pid in workers):
        assert time.monotonic() < deadline, workers
        time.sleep(0.05)


@pytest.mark.parametrize("target", [["--sim"], ["--device", "/dev/null"], []])
def test_several_processes_with_an_arm_attached_are_refused(
        target: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["serve", "--arm", ARM_FILE, *target, "--processes", "2", "--port", "0"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "--processes 2" in err and "--plan-only" in err, err


def test_plan_only_takes_no_baud(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["serve", "--arm", ARM_FILE, "--plan-only", "--baud", "57600", "--port", "0"])
    err = capsys.readouterr().err
    assert code == 2 and "--baud" in err and "--plan-only" in err, err


@pytest.mark.parametrize("value", ["0", "-1", "x", "1.5"])
def test_a_bad_number_of_processes_is_refused(value: str,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["serve", "--arm", ARM_FILE, "--plan-only", "--processes", value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--processes" in err and repr(value) in err, err


@pytest.mark.parametrize("value", [0, -1, True, 1.5, "2"])
def test_make_server_refuses_a_bad_number_of_processes(value: object) -> None:
    with pytest.raises(InputError) as exc:
        make_server(ARM, None, processes=value)  # type: ignore[arg-type]
    assert exc.value.field == "processes" and exc.value.value == value


def test_make_server_refuses_processes_with_a_controller() -> None:
    with pytest.raises(InputError) as exc:
        make_server(ARM, object(), processes=2)  # type: ignore[arg-type]
    assert exc.value.field == "processes" and exc.value.value == 2


def test_an_address_held_by_a_group_is_not_shared() -> None:
    group = bind_group("127.0.0.1", 0, 2)
    try:
        port = group[0].getsockname()[1]
        assert {s.getsockname()[1] for s in group} == {port}
        with pytest.raises(OSError) as exc:
            bind_group("127.0.0.1", port, 2)
        assert exc.value.errno == errno.EADDRINUSE
        with pytest.raises(ListenError) as refused:
            make_server(ARM, None, port=port, processes=2)
        assert refused.value.field == "port" and refused.value.value == port
    finally:
        for sock in group:
            sock.close()
