import dataclasses

import numpy as np
import pytest

from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.ergodic import ChipCoverage, CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache

TINY = CoverageConfig(iterations=3, n_observations=5)


def tiny_coverage_maps(n_regions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    terrain = np.random.default_rng(0).integers(0, 4, (30, 30))
    regions = np.repeat(np.arange(30) * n_regions // 30, 1)[None, :].repeat(30, 0)  # vertical bands
    return terrain, regions


def tiny_coverage() -> ChipCoverage:
    return ChipCoverage(*tiny_coverage_maps(), 2, TINY)


def test_team_cost_table_round_trips_through_parquet(tmp_path):
    path = tmp_path / "team_costs.parquet"
    cache = teams_cache(path)
    cache.put(("1:0-2-0", "chip", "s", 0), team_cost=0.5)
    cache.put(("0:1-0-0", "chip", "s", 1), team_cost=0.25)
    cache.save()
    first_bytes = path.read_bytes()
    again = teams_cache(path)
    assert len(again) == 2 and again.get(("1:0-2-0", "chip", "s", 0)) == {"team_cost": 0.5}
    assert again.get(("1:0-2-0", "chip", "s", 1)) is None
    again.save()
    assert path.read_bytes() == first_bytes


def test_a_teams_cost_does_not_depend_on_its_company():
    """What makes the memo sound: a team optimised alone, beside the other teams of its allocation, or in a batch
    of other allocations gets the same cost up to float32 rounding (vectorised kernels round a tensor's tail
    elements differently, so bits can move in the 8th digit), and the memo's sums are those team costs."""
    coverage = ChipCoverage(*tiny_coverage_maps(3), 3, TINY)
    rng = np.random.default_rng(1)
    counts = rng.integers(0, 3, (12, 3, 3)) * (rng.random((12, 3, 1)) < 0.7)  # some regions empty
    together, _, _ = coverage.evaluate_teams(counts, seed=4)  # (12, K)
    for b in range(0, 12, 5):
        alone, _, _ = coverage.evaluate_teams(counts[b:b + 1], seed=4)
        np.testing.assert_allclose(alone[0], together[b], rtol=1e-6)
    memo = AllocationEvaluator(coverage, "chip", seed=4, max_batch=5)
    np.testing.assert_allclose(memo.team_costs(counts[::-1]), together[::-1], rtol=1e-6)
    np.testing.assert_array_equal(memo(counts)[:, 0], memo.team_costs(counts).sum(1))
    empty = counts.sum(2) == 0
    np.testing.assert_array_equal(together[empty], np.broadcast_to(coverage.empty_team_costs(), empty.shape)[empty])


def test_evaluator_optimises_each_distinct_team_once(tmp_path):
    cache = teams_cache(tmp_path / "team_costs.parquet")
    evaluate = AllocationEvaluator(tiny_coverage(), "chip", seed=0, cache=cache, max_batch=2)
    counts = np.array([[[1, 0, 0], [0, 1, 0]], [[1, 0, 0], [0, 0, 1]], [[1, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, 1, 0]]])
    objectives = evaluate(counts)
    assert evaluate.optimised == 3 and len(evaluate.asked) == 3 and evaluate.lookups == 7
    np.testing.assert_array_equal(objectives[0], objectives[2])
    assert objectives[:, 1].tolist() == [2, 2, 2, 1]
    again = evaluate(counts[:1])
    assert evaluate.optimised == 3 and (again == objectives[:1]).all()
    cache.save()
    reloaded = AllocationEvaluator(tiny_coverage(), "chip", seed=0, cache=teams_cache(cache.path))
    np.testing.assert_array_equal(reloaded(counts), objectives)
    assert reloaded.optimised == 0 and len(reloaded.asked) == 3  # spent the same, whatever the cache held


def test_other_settings_or_seed_miss_the_cache():
    cache = teams_cache()
    counts = np.array([[[1, 0, 0], [0, 1, 0]]])
    AllocationEvaluator(tiny_coverage(), "chip", seed=0, cache=cache)(counts)
    other_seed = AllocationEvaluator(tiny_coverage(), "chip", seed=1, cache=cache)
    other_seed(counts)
    assert other_seed.optimised == 2 and len(cache) == 4
    longer = ChipCoverage(*tiny_coverage_maps(), 2, dataclasses.replace(TINY, iterations=4))
    assert longer.config.settings_hash() != TINY.settings_hash()


def test_chip_coverage_decomposes_the_chip_into_its_regions():
    chip = synthetic_chip(0, size=40)
    coverage = chip_coverage(chip, decompose_chip(chip, DecomposeConfig(n_regions=5)), TINY)
    assert coverage.phi.shape == (5, 10, 10) and coverage.glance.shape == (5,)
    assert coverage.phi[:, 0, 0].tolist() == [1.0] * 5
    assert coverage.area.sum().item() == pytest.approx(1.0) and (coverage.glance > 0).all()
