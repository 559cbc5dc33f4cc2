"""`make bench`: run every benchmarks/bench_*.py `run()` and merge its figures into reports/benchmarks.json.

Each benchmark returns figures measured in one run against a baseline measured in the same run (the
machines are shared and noisy), plus the absolute rates behind them. `python -m benchmarks NAME ...`
runs only the named ones (e.g. `enumerate`); figures of benchmarks not run are kept from the last file.
"""

from __future__ import annotations

import importlib
import json
import platform
import sys
import time
from pathlib import Path

OUT = Path("reports/benchmarks.json")


def main(names: list[str]) -> int:
    from robocompose.io import atomic_write_json

    available = sorted(p.stem.removeprefix("bench_") for p in Path(__file__).parent.glob("bench_*.py"))
    unknown = sorted(set(names) - set(available))
    if unknown:
        print(f"unknown benchmark(s) {unknown}; available: {available}", file=sys.stderr)
        return 2
    results = json.loads(OUT.read_text()) if OUT.exists() else {}
    for name in names or available:
        started = time.perf_counter()
        figures = importlib.import_module(f"benchmarks.bench_{name}").run()
        print(f"{name}: {json.dumps(figures)} ({time.perf_counter() - started:.0f} s)", flush=True)
        results.update({k: round(float(v), 4) for k, v in figures.items()})
    import os

    results["machine"] = {"cores": os.cpu_count(), "python": platform.python_version(), "platform": platform.machine()}
    atomic_write_json(OUT, results)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
