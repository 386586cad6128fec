"""The service's limits, in one place: sizes, deadlines, connection and worker counts."""

from __future__ import annotations

#: Largest request body accepted (bytes), checked from Content-Length before reading.
MAX_BODY = 1 << 20
#: Largest request line plus headers (bytes); more is 431.
MAX_HEAD = 16 << 10
#: Longest request line (bytes); more is 414.
MAX_REQUEST_LINE = 8 << 10
#: Largest response body (bytes) a plan may produce; a plan estimated larger is 413 before
#: it is planned (Trajectory JSON is about 155 bytes a sample on a 3-joint arm).
MAX_RESPONSE = 16 << 20
#: Deepest JSON nesting accepted in a body (a plan body needs 3).
MAX_JSON_DEPTH = 32
#: Seconds from a request's first byte (or the connection's opening, or the end of the
#: previous response) to its last body byte: an absolute deadline, not a per-byte timeout.
REQUEST_TIMEOUT = 10.0
#: Open connections at once (read by one selector thread; they cost a socket, not a thread).
MAX_CONNECTIONS = 256
#: Open connections from one client address at once.
MAX_PER_CLIENT = 32
#: Threads that run ordinary operations (planning, moves, reads).
WORKERS = 8
#: Requests beyond WORKERS that may wait for a worker; more are answered 503.
WORK_QUEUE = 32
#: Threads reserved for the control routes (stop, state, health): never used by others.
CONTROL_WORKERS = 2
#: Long-lived (streaming) responses at once, each holding a thread of its own pool.
STREAM_SLOTS = 8
#: Seconds a worker may block writing one response to a client that does not read.
WRITE_TIMEOUT = 10.0
#: A plan estimated above this many samples (or waypoints) plans in the "large" lane, so it
#: never holds the lock small plans take turns on.
LARGE_PLAN_SAMPLES = 20_000
LARGE_PLAN_WAYPOINTS = 64
