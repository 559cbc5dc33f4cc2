"""Evaluating allocations from exact team costs, memoised in the project's evaluation cache.

An allocation's coverage cost is a sum over regions of one team's cost a_i E_i / G_i, and a team's plan depends
only on its region, its species counts, the optimiser settings and the seed (`ChipCoverage.deploy`). So the map
(chip, region, team counts) -> cost is memoised, on table "teams_team_costs" keyed by (team, chip id, settings
hash, seed), where team is "region:n_1-...-n_O" and the settings hash covers every CoverageConfig field and the
code a cost reaches. NSGA-II, EG-GAN training and every table read allocations through it: a team met once is
never optimised again. Lookups go through `robocompose.fanout.executor.evaluate_many`, every world's cached
objective; the missing teams of a batch are optimised together by torch, in chunks of `max_batch` teams to bound
memory. An empty region costs its closed-form `empty_team_costs` (the bits of an optimised empty team).

Exact up to float32 rounding: optimised alone or in another batch, a team's cost can move in the 8th digit
(torch's vectorised kernels round a tensor's tail elements differently). So a memo starts empty in every stage
and run and is never shared through a file between stages: a stage's bytes then do not depend on what an
earlier stage left behind, and a killed training resumes with its own memo (TeamsProblem's state).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from robocompose.fanout.cache import CacheKey, EvaluationCache
from robocompose.fanout.executor import evaluate_many
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition
from robocompose.teams.ergodic import ChipCoverage, CoverageConfig
from robocompose.teams.species import deployment_cost

CACHE_KEY_COLUMNS = ("team", "chip_id", "settings_hash", "seed")
Team = tuple[int, tuple[int, ...]]  # (region, species counts)


def teams_cache(path: str | Path | None = None) -> EvaluationCache:
    """The team-cost table; `path` None = memory only."""
    return EvaluationCache(path, table="teams_team_costs", key_columns=CACHE_KEY_COLUMNS)


def chip_coverage(chip: Chip, decomposition: Decomposition, coverage: CoverageConfig) -> ChipCoverage:
    """The coverage problem of a chip split into the regions of `decomposition`."""
    return ChipCoverage(chip.terrain, decomposition.raster(chip.terrain), decomposition.n_regions, coverage)


class AllocationEvaluator:
    """Objectives (coverage cost, deployment cost) of integer allocations on one chip, from memoised team costs.

    `asked` holds the key of every distinct team asked for (what a method spent, whatever the cache held),
    `lookups` counts every non-empty team asked for, `optimised` those the optimiser ran (this process's misses).
    """

    def __init__(self, coverage: ChipCoverage, chip_id: str, seed: int,
                 cache: EvaluationCache | None = None, max_batch: int = 256):
        self.coverage = coverage
        self.chip_id = chip_id
        self.seed = seed
        self.cache = teams_cache() if cache is None else cache
        self.max_batch = max_batch
        self.asked: set[CacheKey] = set()
        self.lookups = 0
        self.optimised = 0
        self._settings_hash = coverage.config.settings_hash()
        self._empty = coverage.empty_team_costs()  # (K,)

    def key(self, team: Team) -> CacheKey:
        region, counts = team
        return (f"{region}:{'-'.join(map(str, counts))}", self.chip_id, self._settings_hash, self.seed)

    def _optimise(self, chunk: list[Team]) -> list[dict]:
        """The cache rows of up to `max_batch` teams, each alone in an allocation, optimised together."""
        single = np.zeros((len(chunk), self.coverage.n_regions, len(chunk[0][1])), dtype=np.int64)  # (U, K, O)
        for b, (region, counts) in enumerate(chunk):
            single[b, region] = counts
        costs, _, _ = self.coverage.evaluate_teams(single, self.seed)  # (U, K)
        self.optimised += len(chunk)
        return [{"team_cost": float(costs[b, region])} for b, (region, _) in enumerate(chunk)]

    def distinct_teams(self, counts: np.ndarray) -> set[CacheKey]:
        """The keys of the distinct non-empty teams of (B, K, O) counts: what scoring them spends."""
        counts = np.asarray(counts, dtype=np.int64)
        return {self.key((int(i), tuple(int(n) for n in allocation[i])))
                for allocation in counts for i in np.flatnonzero(allocation.sum(1))}

    def team_costs(self, counts: np.ndarray, fallback: Callable[[list[Team]], np.ndarray] | None = None
                   ) -> np.ndarray:
        """(B, K) team costs of (B, K, O) integer counts (an empty region: its closed-form cost). With `fallback`,
        a team not in the memo is answered by `fallback(teams)` (a learned model) instead of the optimiser, and
        it is not counted in `asked`."""
        counts = np.asarray(counts, dtype=np.int64)
        costs = np.tile(self._empty, (len(counts), 1))  # (B, K)
        where = [(b, i) for b, allocation in enumerate(counts) for i in np.flatnonzero(allocation.sum(1))]
        teams = [(int(i), tuple(int(n) for n in counts[b, i])) for b, i in where]
        self.lookups += len(teams)
        if fallback is not None:
            known = [self.key(team) in self.cache for team in teams]
            unknown = [team for team, hit in zip(teams, known, strict=True) if not hit]
            predicted = iter(fallback(unknown) if unknown else [])
            for (b, i), team, hit in zip(where, teams, known, strict=True):
                costs[b, i] = self.cache.get(self.key(team))["team_cost"] if hit else next(predicted)
            return costs
        self.asked.update(self.key(team) for team in teams)
        rows = evaluate_many(self._optimise, teams, self.key, self.cache, batch=self.max_batch)
        for (b, i), row in zip(where, rows, strict=True):
            costs[b, i] = row["team_cost"]
        return costs

    def __call__(self, counts: np.ndarray) -> np.ndarray:
        """(B, 2) objectives [coverage cost, deployment cost] of (B, K, O) counts."""
        counts = np.asarray(counts, dtype=np.int64)
        return np.stack([self.team_costs(counts).sum(1), deployment_cost(counts).astype(np.float64)], axis=-1)
