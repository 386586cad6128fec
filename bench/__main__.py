"""Run every benchmark module (bench/bench_*.py) and rewrite docs/benchmarks.md.

Each module exposes ``run() -> str``: a Markdown section (a ``## heading`` and a table)
with its own figures and targets. ``python -m bench [name ...]`` runs a subset; sections
for modules not run are kept from the previous file.
"""

from __future__ import annotations

import datetime
import importlib
import os
import pkgutil
import platform
import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "benchmarks.md"


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
            f"numpy {np.__version__}, {platform.system()} {platform.release()}")


def previous_sections() -> dict[str, str]:
    if not OUT.exists():
        return {}
    parts = re.split(r"^<!-- bench:(\w+) -->\n", OUT.read_text(), flags=re.M)
    return {parts[i]: parts[i + 1].rstrip() + "\n" for i in range(1, len(parts) - 1, 2)}


def main(argv: list[str]) -> None:
    modules = pkgutil.iter_modules([str(ROOT / "bench")])
    names = sorted(m.name.removeprefix("bench_") for m in modules if m.name.startswith("bench_"))
    wanted = argv or names
    sections = previous_sections()
    for name in wanted:
        module = importlib.import_module(f"bench.bench_{name}")
        print(f"== bench {name}", flush=True)
        load_before = os.getloadavg()
        text = module.run()
        command = "make bench" if not argv else f"python -m bench {' '.join(argv)}"
        load = "; ".join(f"{a:.1f}/{b:.1f}" for a, b in zip(load_before, os.getloadavg(),
                                                             strict=True))
        stamp = (f"\n_Measured {datetime.date.today()} on {machine()}; load average "
                 f"1/5/15 min at start/end {load}; command: `{command}`._\n")
        sections[name] = text.rstrip() + "\n" + stamp
        print(text, flush=True)
    OUT.parent.mkdir(exist_ok=True)
    body = ["# Benchmarks\n", "Produced by `make bench` (`python -m bench`); every figure is "
            "from the run stamped under its section.\n"]
    for name in names:
        if name in sections:
            body.append(f"<!-- bench:{name} -->\n{sections[name]}")
    OUT.write_text("\n".join(body))
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main(sys.argv[1:])
