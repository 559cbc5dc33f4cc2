"""Benchmark: coverage cost of candidate allocations, batched vs one allocation at a time.

teams.allocations_per_s: allocations whose trajectories are optimised per second when a batch of
    BATCH allocations (a spread of deployment costs) is optimised together.
teams.batch_speedup: seconds per allocation one at a time / seconds per allocation batched, measured
    in the same run on the first SINGLE allocations of the same batch.
"""

from __future__ import annotations

import time

import numpy as np
import torch

from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import chip_coverage
from robocompose.teams.species import allocation_to_counts

BATCH = 50  # NSGA-II:50's generation size
SINGLE = 6


def run() -> dict[str, float]:
    torch.set_num_threads(1)
    chip = synthetic_chip(0)
    coverage = chip_coverage(chip, decompose_chip(chip, DecomposeConfig()), CoverageConfig())
    rng = np.random.default_rng(0)
    shares = rng.random((BATCH, 1, 3)) * rng.dirichlet(np.ones(8), size=(BATCH, 3)).transpose(0, 2, 1)
    counts = allocation_to_counts(shares, coverage.config.robots_per_species)  # (BATCH, 8, 3)
    coverage.evaluate(counts[:2], seed=0)  # warm-up
    started = time.perf_counter()
    coverage.evaluate(counts, seed=0)
    batched = (time.perf_counter() - started) / BATCH
    started = time.perf_counter()
    for allocation in counts[:SINGLE]:
        coverage.evaluate(allocation[None], seed=0)
    single = (time.perf_counter() - started) / SINGLE
    return {"teams.allocations_per_s": 1.0 / batched, "teams.batch_speedup": single / batched}


if __name__ == "__main__":
    print(run())
