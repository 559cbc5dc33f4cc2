import numpy as np
import pytest
import torch

from robocompose.io.errors import InputError
from robocompose.teams.baselines import (
    no_decomposition_costs,
    random_allocation,
    random_species_counts,
    random_teams,
)
from robocompose.teams.ergodic import ChipCoverage, CoverageConfig, ergodic_cost, frequencies

TINY = CoverageConfig(iterations=4, n_observations=6)
HALVES = np.repeat(np.arange(2), 15)[None, :].repeat(30, 0)  # (30, 30): left region 0, right region 1


def test_random_draws_respect_budget_and_bank():
    rng = np.random.default_rng(0)
    for budget in (1, 15, 60):
        counts = random_allocation(rng, budget, n_regions=4, n_species=3, robots_per_species=20)
        assert counts.shape == (4, 3) and counts.sum() == budget and (counts.sum(0) <= 20).all()
    assert random_species_counts(rng, 60, 3, 20).tolist() == [20, 20, 20]


def test_random_teams_fill_every_region_and_split_the_budget_uniformly():
    rng = np.random.default_rng(0)
    for budget in (8, 15, 45):
        counts = random_teams(rng, budget, n_regions=8, n_species=3, robots_per_species=20)
        assert counts.shape == (8, 3) and counts.sum() == budget and (counts.sum(1) >= 1).all()
        assert (counts.sum(0) <= 20).all()
    # 4 robots in 2 regions: team sizes (1, 3), (2, 2), (3, 1), each a third of the compositions
    sizes = [tuple(random_teams(rng, 4, 2, 3, 20).sum(1)) for _ in range(3000)]
    shares = {s: sizes.count(s) / len(sizes) for s in set(sizes)}
    assert set(shares) == {(1, 3), (2, 2), (3, 1)} and all(abs(v - 1 / 3) < 0.04 for v in shares.values())
    with pytest.raises(InputError, match="budget 5: expected at least one robot per region"):
        random_teams(rng, 5, 8, 3, 20)


def test_no_decomposition_scores_observations_in_the_region_they_lie_in():
    terrain = np.full((30, 30), 2)
    coverage = ChipCoverage(terrain, HALVES, 2, TINY)
    species_counts = np.array([[2, 1, 0], [0, 3, 0]])
    costs, unvisited = no_decomposition_costs(coverage, species_counts, seed=0)
    assert costs.shape == (2,) and (costs > 0).all() and unvisited.shape == (2,)
    # recompute the first allocation by hand from the same joint plan
    whole = ChipCoverage(terrain, np.zeros_like(HALVES), 1, TINY)
    _, robots, observations = whole.evaluate(species_counts[:1, None, :], seed=0)
    points = observations.reshape(-1, 2).double()
    region = (points[:, 0] >= 0.5).long()
    weights = torch.tensor([20.0, 10.0, 0.0], dtype=torch.float64)[robots.species].repeat_interleave(6)
    metrics = ergodic_cost(points[:, None], weights[:, None], region, coverage.phi)  # (2,) raw, per region
    assert np.isclose(costs[0], (0.5 * metrics / coverage.glance).sum().item())  # halves: a_i = 0.5


def test_no_decomposition_with_all_robots_in_one_half_leaves_the_other_costly():
    terrain = np.full((30, 30), 2)
    terrain[:, 15:] = 0  # right half water: ground robots cannot start or go there
    coverage = ChipCoverage(terrain, HALVES, 2, TINY)
    costs, unvisited = no_decomposition_costs(coverage, np.array([[3, 0, 0]]), seed=0)
    never_visited = 0.5 * (coverage.phi[1] ** 2 * frequencies(10)[1]).sum() / coverage.glance[1]
    assert costs[0] > never_visited.item() > 1.0  # region 1 costs what an empty team does
    assert unvisited.tolist() == [1]
