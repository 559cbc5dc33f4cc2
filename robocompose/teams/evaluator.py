"""Evaluating allocations: the project's evaluation cache in front of the batched coverage optimiser.

The cache is the shared `robocompose.fanout.cache.EvaluationCache` on table "teams_eval_cache",
keyed by (allocation id, chip id, settings hash, seed): allocation id hashes the integer K x O counts
(so two fraction matrices that round to the same robots share one entry), the settings hash covers
every CoverageConfig field. Lookups go through `robocompose.fanout.executor.evaluate_many`, every world's
cached objective; evaluation stays in-process and batched: the misses of a batch are optimised together by
torch, in chunks of `max_batch` allocations to bound memory (fanning whole runs out is experiments.py's job).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocompose.fanout.cache import CacheKey, EvaluationCache
from robocompose.fanout.executor import evaluate_many
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

    def _optimise(self, chunk: list[np.ndarray]) -> list[dict]:
        """The cache rows of up to `max_batch` allocations, optimised together."""
        batch = np.stack(chunk)
        costs, _, _ = self.coverage.evaluate(batch, self.seed)
        self.optimised += len(chunk)
        return [{"coverage_cost": cost, "deployment_cost": deploy}
                for cost, deploy in zip(costs, deployment_cost(batch), strict=True)]

    def __call__(self, counts: np.ndarray) -> np.ndarray:
        """(B, 2) objectives [coverage cost, deployment cost] of (B, K, O) counts."""
        counts = np.asarray(counts, dtype=np.int64)
        rows = evaluate_many(self._optimise, list(counts), self.key, self.cache, batch=self.max_batch)
        return np.array([[row["coverage_cost"], row["deployment_cost"]] for row in rows], dtype=np.float64)
