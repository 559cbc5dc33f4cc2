"""Evaluating allocations: the project's evaluation cache in front of the batched coverage optimiser.

The cache is the shared `robocompose.fanout.cache.EvaluationCache` on table "teams_eval_cache",
keyed by (allocation id, chip id, settings hash, seed): allocation id hashes the integer K x O counts
(so two fraction matrices that round to the same robots share one entry), the settings hash covers
every CoverageConfig field. Evaluation stays in-process and batched: the misses of a batch are
optimised together by torch, in chunks of `max_batch` allocations to bound memory (fanning whole runs
out to processes is experiments.py's job).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocompose.fanout.cache import CacheKey, EvaluationCache
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.ergodic import ChipCoverage, CoverageConfig, allocation_id
from robocompose.teams.species import deployment_cost

CACHE_KEY_COLUMNS = ("allocation_id", "chip_id", "settings_hash", "seed")


def teams_cache(path: str | Path | None = None) -> EvaluationCache:
    """The (coverage cost, deployment cost) cache of allocations; `path` None = memory only."""
    return EvaluationCache(path, table="teams_eval_cache", key_columns=CACHE_KEY_COLUMNS)


def chip_coverage(chip: Chip, decomposition: Decomposition, coverage: CoverageConfig) -> ChipCoverage:
    """The coverage problem of a chip split into the regions of `decomposition`."""
    return ChipCoverage(chip.terrain, decomposition.raster(chip.terrain), decomposition.n_regions, coverage)


class AllocationEvaluator:
    """Objectives (coverage cost, deployment cost) of integer allocations on one chip."""

    def __init__(self, coverage: ChipCoverage, chip_id: str, seed: int,
                 cache: EvaluationCache | None = None, max_batch: int = 64):
        self.coverage = coverage
        self.chip_id = chip_id
        self.seed = seed
        self.cache = teams_cache() if cache is None else cache
        self.max_batch = max_batch
        self.optimised = 0  # allocations actually optimised (cache misses)

    def key(self, counts: np.ndarray) -> CacheKey:
        return (allocation_id(counts), self.chip_id, self.coverage.config.settings_hash(), self.seed)

    def __call__(self, counts: np.ndarray) -> np.ndarray:
        """(B, 2) objectives [coverage cost, deployment cost] of (B, K, O) counts."""
        counts = np.asarray(counts, dtype=np.int64)
        keys = [self.key(c) for c in counts]
        missing = {key: c for key, c in zip(keys, counts, strict=True) if key not in self.cache}
        todo = list(missing.items())
        for start in range(0, len(todo), self.max_batch):
            chunk = todo[start:start + self.max_batch]
            batch = np.stack([c for _, c in chunk])
            costs, _, _ = self.coverage.evaluate(batch, self.seed)
            for (key, _), cost, deploy in zip(chunk, costs, deployment_cost(batch), strict=True):
                self.cache.put(key, coverage_cost=cost, deployment_cost=deploy)
            self.optimised += len(chunk)
        rows = [self.cache.get(key) for key in keys]
        return np.array([[row["coverage_cost"], row["deployment_cost"]] for row in rows], dtype=np.float64)
