"""The live children of a process, read from /proc (Linux ``/proc/<pid>/stat``, field 4:
the parent's pid). Shared by ``bench_http`` (the workers' CPU time) and
``tests/test_http_processes.py`` (which worker is which)."""

from __future__ import annotations

from pathlib import Path


def children(pid: int) -> set[int]:
    """The pids whose parent is ``pid`` (empty without /proc)."""
    found = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.add(int(stat.parent.name))
    return found
