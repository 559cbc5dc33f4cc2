import numpy as np
import pytest

from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.ergodic import ChipCoverage, CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache

TINY = CoverageConfig(iterations=3, n_observations=5)


def tiny_coverage() -> ChipCoverage:
    terrain = np.random.default_rng(0).integers(0, 4, (30, 30))
    regions = np.repeat(np.arange(2), 15)[None, :].repeat(30, 0)
    return ChipCoverage(terrain, regions, 2, TINY)


def test_teams_cache_round_trips_both_costs_through_parquet(tmp_path):
    path = tmp_path / "cache.parquet"
    cache = teams_cache(path)
    cache.put(("a1", "chip", "s", 0), coverage_cost=0.5, deployment_cost=3)
    cache.put(("a0", "chip", "s", 1), coverage_cost=0.25, deployment_cost=7)
    cache.save()
    first_bytes = path.read_bytes()
    again = teams_cache(path)
    assert len(again) == 2 and again.get(("a1", "chip", "s", 0)) == {"coverage_cost": 0.5, "deployment_cost": 3}
    assert again.get(("a1", "chip", "s", 1)) is None
    again.save()
    assert path.read_bytes() == first_bytes


def test_evaluator_optimises_each_distinct_allocation_once(tmp_path):
    cache = teams_cache(tmp_path / "cache.parquet")
    evaluate = AllocationEvaluator(tiny_coverage(), "chip", seed=0, cache=cache, max_batch=2)
    counts = np.array([[[1, 0, 0], [0, 1, 0]], [[2, 0, 0], [0, 0, 1]], [[1, 0, 0], [0, 1, 0]]])
    objectives = evaluate(counts)
    assert evaluate.optimised == 2
    np.testing.assert_array_equal(objectives[0], objectives[2])
    assert objectives[:, 1].tolist() == [2, 3, 2]
    again = evaluate(counts[:1])
    assert evaluate.optimised == 2 and (again == objectives[:1]).all()
    cache.save()
    reloaded = AllocationEvaluator(tiny_coverage(), "chip", seed=0, cache=teams_cache(cache.path))
    np.testing.assert_array_equal(reloaded(counts), objectives)
    assert reloaded.optimised == 0


def test_other_settings_or_seed_miss_the_cache():
    cache = teams_cache()
    counts = np.array([[[1, 0, 0], [0, 1, 0]]])
    AllocationEvaluator(tiny_coverage(), "chip", seed=0, cache=cache)(counts)
    other_seed = AllocationEvaluator(tiny_coverage(), "chip", seed=1, cache=cache)
    other_seed(counts)
    assert other_seed.optimised == 1 and len(cache) == 2


def test_chip_coverage_decomposes_the_chip_into_its_regions():
    chip = synthetic_chip(0, size=40)
    coverage = chip_coverage(chip, decompose_chip(chip, DecomposeConfig(n_regions=5)), TINY)
    assert coverage.phi.shape == (5, 10, 10) and coverage.glance.shape == (5,)
    assert coverage.phi[:, 0, 0].tolist() == [1.0] * 5
    assert coverage.area.sum().item() == pytest.approx(1.0) and (coverage.glance > 0).all()
