"""Stage wall times, kept apart from DVC-tracked outputs so that those stay byte-reproducible.

Each stage records its duration (and any speed figures) under its name in reports/timings.json, a
file DVC does not track; the report shows them. A stage that runs several jobs side by side records each job's
own figures too, under STAGE@JOB (`train_vae@full`), from the stage's process as each job finishes: one writer.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from robocompose.io.atomic import atomic_write_json, read_json

TIMINGS_FILE = Path("reports/timings.json")


class Timing(dict):
    """Figures of one stage run; `elapsed()` is the time since the stage started."""

    def __init__(self) -> None:
        super().__init__()
        self._start = time.perf_counter()

    def elapsed(self) -> float:
        return time.perf_counter() - self._start

    def figures(self) -> dict:
        """The figures put in, and the wall time so far (`seconds`)."""
        return {**self, "seconds": round(self.elapsed(), 1)}


def read_timings(path: Path = TIMINGS_FILE) -> dict:
    return read_json(path) if path.exists() else {}


def record(name: str, figures: dict, path: Path = TIMINGS_FILE) -> None:
    """Put `figures` under `name` in the timings file, keeping every other entry."""
    timings = read_timings(path)
    timings[name] = figures
    atomic_write_json(path, timings)


@contextmanager
def timed(stage: str, path: Path = TIMINGS_FILE) -> Iterator[Timing]:
    """Record `stage`'s wall time (and the figures put in the yielded dict) when it finishes."""
    timing = Timing()
    yield timing
    record(stage, timing.figures(), path)
