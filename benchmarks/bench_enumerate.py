"""Benchmark: grammar enumeration with contact features on all cores.

enumerate.designs_per_s: distinct valid designs per second (derivation, build, 10 coarse rest steps,
    contacts), pool start-up included. Anchor: the thesis made 5e5 designs in ~4 h on 8 cores (~35/s);
    target here >= 70/s on 2 cores.
enumerate.designs_per_s_per_core: the same divided by the worker count.
enumerate.parallel_efficiency: all-core rate / (cores x one-core rate), both measured in this run.
"""

from __future__ import annotations

import os
import time

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.fanout.executor import Executor

N = 1500


def _rate(n: int, workers: int) -> float:
    started = time.perf_counter()  # the workers' start-up counts, as in the stage
    with Executor(workers=workers) as executor:
        enumerate_designs(EnumerateConfig(n=n, seed=123), executor, progress=None)
    return n / (time.perf_counter() - started)


def run() -> dict[str, float]:
    cores = os.cpu_count() or 1
    one = _rate(N // 4, workers=1)
    every = _rate(N, workers=cores)
    return {"enumerate.designs_per_s": every, "enumerate.designs_per_s_per_core": every / cores,
            "enumerate.parallel_efficiency": every / (cores * one)}
