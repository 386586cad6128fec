"""HTTP service throughput: POST /v1/trajectories from 8 concurrent keep-alive clients.

The server is ``robodcn serve --plan-only --processes N --port 0`` (its request log, one
INFO line a request, to /dev/null) in processes of its own, once with 1 process and once
with :data:`PROCESSES` (the target row: planning is CPU-bound Python, one interpreter plans
on one core). The 8 clients are threads of this process, each sending a 2 s, 100 Hz plan for
the 3R arm back to back for 10 s (16 nearby requests in turn, :func:`bodies`). Latency is
from sending the request to having read the whole response.

Beside the rate, figures that a shared machine disturbs less: the server's CPU time per plan
(``/proc/<pid>/stat`` of the server and of every worker process, over the measured window),
the clients' (this process's CPU time over the window), and the yard-stick, the CPU time of
the same request handled in this process without HTTP (decode the body, the contract's parse,
plan, Trajectory JSON; one thread, best of a few batches). Server CPU / yard-stick is the
service's own overhead; with clients and server sharing the cores, cores × 1000 / (server +
client CPU ms) bounds the rate.
"""

from __future__ import annotations

import http.client
import itertools
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from bench.proc_children import children

ROOT = Path(__file__).resolve().parent.parent
CLIENTS = 8
#: Worker processes of the target row (``serve --plan-only --processes 2``).
PROCESSES = 2
SECONDS = float(os.environ.get("ROBODCN_BENCH_HTTP_SECONDS", "10"))
TARGET_RPS = 600.0
TARGET_P99_MS = 50.0
BODY = {"waypoints": [[0.25, 0.10, 0.0], [0.15, 0.20, 1.0]], "duration": 2.0, "rate_hz": 100}


def bodies() -> list[bytes]:
    """BODY with its waypoints moved as bench_planner.variants moves them: every client
    cycles through these distinct requests, as a service sees them, not one request again."""
    from bench.bench_planner import variants

    return [json.dumps({**BODY, "waypoints": w}).encode()
            for w in variants(BODY["waypoints"])]



def _cpu_seconds(pid: int) -> float | None:
    """utime + stime of process ``pid`` (s), or None without /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _tree_cpu_seconds(pid: int) -> float | None:
    """CPU seconds of process ``pid`` and of its live children (the workers), or None."""
    own = _cpu_seconds(pid)
    if own is None:
        return None
    for child in children(pid):
        own += _cpu_seconds(child) or 0.0
    return own


def yardstick(batches: int = 5, per_batch: int = 40) -> dict[str, float]:
    """CPU ms of one request's work without HTTP, in this process: the whole of it (decode,
    parse, plan, JSON bytes) and its parts (plan; JSON), best of ``batches``."""
    from robodcn.config import load_arm
    from robodcn.http.jsonbody import decode_json
    from robodcn.http.planbody import parse_plan
    from robodcn.planner import plan_request

    arm = load_arm(ROOT / "configs" / "arm3r.toml")
    raws = bodies()
    requests = [parse_plan(arm, decode_json(raw, "application/json")) for raw in raws]
    trajectory = plan_request(requests[0])
    turn = itertools.count()

    def whole() -> None:
        raw = raws[next(turn) % len(raws)]
        plan_request(parse_plan(arm, decode_json(raw, "application/json"))).to_json().encode()

    def plan_one() -> None:
        plan_request(requests[next(turn) % len(requests)])

    def best(fn) -> float:
        fn()
        times = []
        for _ in range(batches):
            start = time.process_time()
            for _ in range(per_batch):
                fn()
            times.append((time.process_time() - start) / per_batch)
        return 1e3 * min(times)

    return {"whole": best(whole), "plan": best(plan_one),
            "json": best(lambda: trajectory.to_json().encode())}


def _client(port: int, bodies: list[bytes], stop_at: float, latencies: list[float],
            errors: list[str], samples: list[int], first: int = 0) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    headers = {"Content-Type": "application/json"}
    turn = itertools.count(first)
    try:
        while time.perf_counter() < stop_at:
            start = time.perf_counter()
            body = bodies[next(turn) % len(bodies)]
            conn.request("POST", "/v1/trajectories", body=body, headers=headers)
            resp = conn.getresponse()
            data = resp.read()
            latencies.append(time.perf_counter() - start)
            if resp.status != 200:
                errors.append(f"{resp.status}: {data[:200]!r}")
            elif not samples:
                samples.append(len(json.loads(data)["t"]))
    except (OSError, http.client.HTTPException) as exc:
        errors.append(repr(exc))
    finally:
        conn.close()


def measure(seconds: float = SECONDS, clients: int = CLIENTS,
            processes: int = 1) -> dict[str, float]:
    """Requests/s, p50/p99/max latency (s), error count, samples per plan, and CPU ms per
    request of the server's processes and of the clients (NaN without /proc)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("ROBODCN_TOKEN", None)
    # The command line itself, with its request log (INFO, one line a request) to nowhere.
    proc = subprocess.Popen([sys.executable, "-m", "robodcn", "serve", "--plan-only",
                             "--processes", str(processes), "--port", "0", "--arm",
                             str(ROOT / "configs" / "arm3r.toml")],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env,
                            text=True)
    try:
        assert proc.stdout is not None
        port = int(proc.stdout.readline().rsplit(":", 1)[1])
        sent = bodies()
        # Warm every worker: the kernel spreads connections, so several clients at once.
        warm = [threading.Thread(target=_client, args=(port, sent, time.perf_counter() + 0.5,
                                                       [], [], [])) for _ in range(clients)]
        for t in warm:
            t.start()
        for t in warm:
            t.join()
        latencies: list[list[float]] = [[] for _ in range(clients)]
        errors: list[str] = []
        samples: list[int] = []
        cpu_before = _tree_cpu_seconds(proc.pid)
        client_before = time.process_time()
        start = time.perf_counter()
        threads = [threading.Thread(target=_client,
                                    args=(port, sent, start + seconds, latencies[i], errors,
                                          samples, i)) for i in range(clients)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        elapsed = time.perf_counter() - start
        client_cpu = time.process_time() - client_before
        cpu_after = _tree_cpu_seconds(proc.pid)
    finally:
        proc.terminate()
        proc.wait(30)
    lat = np.concatenate([np.asarray(x) for x in latencies])
    n = max(lat.size, 1)
    server_cpu = (float("nan") if cpu_before is None or cpu_after is None
                  else (cpu_after - cpu_before) / n)
    return {"server_cpu_ms": 1e3 * server_cpu, "client_cpu_ms": 1e3 * client_cpu / n,
            "requests": float(lat.size), "rps": lat.size / elapsed,
            "p50": float(np.percentile(lat, 50)), "p99": float(np.percentile(lat, 99)),
            "max": float(lat.max()), "errors": float(len(errors)),
            "samples": float(samples[0]) if samples else 0.0}


def run() -> str:
    from bench.__main__ import machine

    load = os.getloadavg()
    one = measure(processes=1)
    many = measure(processes=PROCESSES)
    load_end = os.getloadavg()
    y = yardstick()
    ok_rps = "✓" if many["rps"] >= TARGET_RPS else "✗"
    ok_p99 = "✓" if many["p99"] * 1e3 < TARGET_P99_MS else "✗"
    cores = os.cpu_count() or 1

    def row(name: str, fmt, target: str = "—") -> str:
        return f"| {name} | {fmt(one)} | {fmt(many)} | {target} |"

    return "\n".join([
        "## HTTP service: POST /v1/trajectories",
        "",
        f"{CLIENTS} concurrent keep-alive clients (threads of the bench process), each posting "
        f"a 2 s, 100 Hz plan for the 3R arm ({int(many['samples'])} samples, full Trajectory "
        f"JSON back) for {SECONDS:g} s, to `robodcn serve --plan-only` (request log on) in "
        f"processes of its own, with 1 process and with `--processes {PROCESSES}` (the target "
        f"column: {PROCESSES} worker processes on one port, each a selector thread framing "
        "requests and a worker pool answering them). Both in the same run.",
        "",
        f"| measure | 1 process | {PROCESSES} processes (target) | target |",
        "|---|---|---|---|",
        row(f"plans/s, {CLIENTS} clients",
            lambda m: f"{m['rps']:.0f} ({int(m['requests'])} in {SECONDS:g} s)",
            f"≥ {TARGET_RPS:.0f} {ok_rps}"),
        row("latency p50", lambda m: f"{m['p50'] * 1e3:.1f} ms"),
        row("latency p99", lambda m: f"{m['p99'] * 1e3:.1f} ms",
            f"< {TARGET_P99_MS:.0f} ms {ok_p99}"),
        row("latency max", lambda m: f"{m['max'] * 1e3:.1f} ms"),
        row("errors", lambda m: f"{int(m['errors'])}", "0"),
        row("server CPU per plan (all its processes)", lambda m: f"{m['server_cpu_ms']:.2f} ms"),
        row("clients' CPU per plan (http.client)", lambda m: f"{m['client_cpu_ms']:.2f} ms"),
        row(f"{cores} cores / (server + clients' CPU): the most plans/s this machine allows",
            lambda m: f"{cores * 1e3 / (m['server_cpu_ms'] + m['client_cpu_ms']):.0f}"),
        row("server CPU per plan / yard-stick (the service's own overhead)",
            lambda m: f"{m['server_cpu_ms'] / y['whole']:.2f}"),
        "",
        f"Yard-stick: the same request without HTTP, one thread: {y['whole']:.2f} ms CPU (plan "
        f"{y['plan']:.2f} ms, Trajectory JSON {y['json']:.2f} ms) → at most "
        f"{1e3 / y['whole']:.0f} plans/s on one interpreter (one GIL), whatever its threads "
        "do: hence processes.",
        "",
        f"Machine: {machine()}. Clients and server share {cores} cores; load average "
        f"1/5/15 min {load[0]:.1f}/{load[1]:.1f}/{load[2]:.1f} at the start, "
        f"{load_end[0]:.1f}/{load_end[1]:.1f}/{load_end[2]:.1f} at the end (other work on the "
        "machine lowers the rate and inflates the tail; the CPU figures and their ratio move "
        "less). Within a process, handlers take turns on a lock for the CPU-bound planning "
        "instead of contending for the GIL.",
    ])


if __name__ == "__main__":
    print(run())
