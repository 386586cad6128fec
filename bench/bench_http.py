"""HTTP service throughput: POST /v1/trajectories from 8 concurrent keep-alive clients.

The server runs in its own process (``make_server`` on an ephemeral port, plan-only) so the
clients' Python does not share its interpreter lock; the 8 clients are threads of this
process, each sending a 2 s, 100 Hz plan for the 3R arm back to back for 10 s. Latency is
from sending the request to having read the whole response.
"""

from __future__ import annotations

import http.client
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
CLIENTS = 8
SECONDS = float(os.environ.get("ROBODCN_BENCH_HTTP_SECONDS", "10"))
TARGET_RPS = 300.0
TARGET_P99_MS = 50.0
BODY = {"waypoints": [[0.25, 0.10, 0.0], [0.15, 0.20, 1.0]], "duration": 2.0, "rate_hz": 100}

_SERVER = """
import sys
from robodcn.config import load_arm
from robodcn.http import make_server
server = make_server(load_arm(sys.argv[1]), None, port=0)
print(server.server_address[1], flush=True)
server.serve_forever()
"""


def _client(port: int, body: bytes, stop_at: float, latencies: list[float],
            errors: list[str], samples: list[int]) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    headers = {"Content-Type": "application/json"}
    try:
        while time.perf_counter() < stop_at:
            start = time.perf_counter()
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


def measure(seconds: float = SECONDS, clients: int = CLIENTS) -> dict[str, float]:
    """Requests/s, p50/p99/max latency (s), error count and samples per plan."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", _SERVER, str(ROOT / "configs" / "arm3r.toml")],
                            stdout=subprocess.PIPE, env=env, text=True)
    try:
        assert proc.stdout is not None
        port = int(proc.stdout.readline())
        body = json.dumps(BODY).encode()
        warm: list[float] = []
        _client(port, body, time.perf_counter() + 0.5, warm, [], [])
        latencies: list[list[float]] = [[] for _ in range(clients)]
        errors: list[str] = []
        samples: list[int] = []
        start = time.perf_counter()
        threads = [threading.Thread(target=_client,
                                    args=(port, body, start + seconds, latencies[i], errors,
                                          samples)) for i in range(clients)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        elapsed = time.perf_counter() - start
    finally:
        proc.terminate()
        proc.wait(10)
    lat = np.concatenate([np.asarray(x) for x in latencies])
    return {"requests": float(lat.size), "rps": lat.size / elapsed,
            "p50": float(np.percentile(lat, 50)), "p99": float(np.percentile(lat, 99)),
            "max": float(lat.max()), "errors": float(len(errors)),
            "samples": float(samples[0]) if samples else 0.0}


def run() -> str:
    load = os.getloadavg()[0]
    m = measure()
    ok_rps = "✓" if m["rps"] >= TARGET_RPS else "✗"
    ok_p99 = "✓" if m["p99"] * 1e3 < TARGET_P99_MS else "✗"
    return "\n".join([
        "## HTTP service: POST /v1/trajectories",
        "",
        f"{CLIENTS} concurrent keep-alive clients (threads of the bench process), each posting "
        f"a 2 s, 100 Hz plan for the 3R arm ({int(m['samples'])} samples, full Trajectory JSON "
        f"back) for {SECONDS:g} s; the server (robodcn.http: a selector thread frames requests, a "
        f"worker pool answers them) in its own process.",
        "",
        "| measure | value | target |",
        "|---|---|---|",
        f"| plans/s | {m['rps']:.0f} ({int(m['requests'])} in {SECONDS:g} s) | ≥ {TARGET_RPS:.0f} "
        f"{ok_rps} |",
        f"| latency p50 | {m['p50'] * 1e3:.1f} ms | — |",
        f"| latency p99 | {m['p99'] * 1e3:.1f} ms | < {TARGET_P99_MS:.0f} ms {ok_p99} |",
        f"| latency max | {m['max'] * 1e3:.1f} ms | — |",
        f"| errors | {int(m['errors'])} | 0 |",
        "",
        f"Clients and server share {os.cpu_count()} cores; 1-minute load average "
        f"{load:.1f} when the run started (other work on the machine inflates the tail). "
        "Handlers take turns on a lock for the CPU-bound planning instead of contending for "
        "the GIL.",
    ])


if __name__ == "__main__":
    print(run())
