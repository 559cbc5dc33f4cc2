"""Evaluating allocations: a parquet evaluation cache in front of the batched coverage optimiser.

The cache key is (allocation id, chip id, settings hash, seed): allocation id hashes the integer
K x O counts (so two fraction matrices that round to the same robots share one entry), the settings
hash covers every CoverageConfig field. Its interface is two calls, `get` and `put` (plus `save`), so
it can be merged with the robot evaluator's cache. The executor is in-process: the misses of a batch
are optimised together by torch, in chunks of `max_batch` allocations to bound memory.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.io import read_table, write_table
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import region_raster
from robocompose.teams.ergodic import ChipCoverage, CoverageConfig, allocation_id
from robocompose.teams.species import deployment_cost

CacheKey = tuple[str, str, str, int]  # (allocation id, chip id, settings hash, seed)
CACHE_SCHEMA = "teams_eval_cache"


def chip_coverage(chip: Chip, seeds: np.ndarray, coverage: CoverageConfig) -> ChipCoverage:
    """The coverage problem of a chip decomposed into the Voronoi regions of (K, 2) `seeds`."""
    regions = region_raster(seeds, *chip.classes.shape)
    return ChipCoverage(chip.terrain, regions, len(seeds), coverage)


class EvaluationCache:
    """Coverage costs by CacheKey, loaded from and saved to one parquet file (or memory only)."""

    def __init__(self, path: Path | None = None):
        self.path = None if path is None else Path(path)
        self._costs: dict[CacheKey, tuple[float, int]] = {}
        if self.path is not None and self.path.exists():
            table = read_table(self.path, CACHE_SCHEMA)
            keys = zip(table.allocation_id, table.chip_id, table.settings_hash, table.seed.astype(int),
                       strict=True)
            self._costs = dict(zip(keys, zip(table.coverage_cost, table.deployment_cost, strict=True),
                                   strict=True))

    def get(self, key: CacheKey) -> tuple[float, int] | None:
        """(coverage cost, deployment cost) stored for `key`, or None."""
        return self._costs.get(key)

    def put(self, key: CacheKey, coverage_cost: float, deployment_cost: int) -> None:
        self._costs[key] = (float(coverage_cost), int(deployment_cost))

    def merge(self, other: EvaluationCache) -> None:
        """Add every entry of `other`."""
        self._costs.update(other._costs)

    def __len__(self) -> int:
        return len(self._costs)

    def save(self) -> None:
        """Write all entries (sorted by key, so the file is deterministic) if the cache has a path."""
        if self.path is None:
            return
        rows = [(*key, *value) for key, value in sorted(self._costs.items())]
        columns = ["allocation_id", "chip_id", "settings_hash", "seed", "coverage_cost", "deployment_cost"]
        write_table(pd.DataFrame(rows, columns=columns), self.path, CACHE_SCHEMA)


class AllocationEvaluator:
    """Objectives (coverage cost, deployment cost) of integer allocations on one chip."""

    def __init__(self, coverage: ChipCoverage, chip_id: str, seed: int,
                 cache: EvaluationCache | None = None, max_batch: int = 64):
        self.coverage = coverage
        self.chip_id = chip_id
        self.seed = seed
        self.cache = EvaluationCache() if cache is None else cache
        self.max_batch = max_batch
        self.optimised = 0  # allocations actually optimised (cache misses)

    def key(self, counts: np.ndarray) -> CacheKey:
        return (allocation_id(counts), self.chip_id, self.coverage.config.settings_hash(), self.seed)

    def __call__(self, counts: np.ndarray) -> np.ndarray:
        """(B, 2) objectives [coverage cost, deployment cost] of (B, K, O) counts."""
        counts = np.asarray(counts, dtype=np.int64)
        keys = [self.key(c) for c in counts]
        missing = {key: c for key, c in zip(keys, counts, strict=True) if self.cache.get(key) is None}
        todo = list(missing.items())
        for start in range(0, len(todo), self.max_batch):
            chunk = todo[start:start + self.max_batch]
            batch = np.stack([c for _, c in chunk])
            costs, _, _ = self.coverage.evaluate(batch, self.seed)
            for (key, _), cost, deploy in zip(chunk, costs, deployment_cost(batch), strict=True):
                self.cache.put(key, cost, deploy)
            self.optimised += len(chunk)
        return np.array([self.cache.get(key) for key in keys], dtype=np.float64)
