import numpy as np
import pytest
import torch

from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.ergodic import (
    ChipCoverage,
    CoverageConfig,
    Robots,
    allocation_id,
    ergodic_cost,
    frequencies,
    optimise_trajectories,
    region_targets,
    rollout,
)
from robocompose.teams.evaluator import chip_coverage
from robocompose.teams.nsga2 import REFERENCE_POINT, team_hypervolume
from robocompose.teams.species import SPEED_SCALE

SMALL = CoverageConfig(iterations=15, n_observations=10)
WHOLE_SQUARE = region_targets(np.zeros((20, 20), dtype=np.int64), 1, 10)[0]  # (1, 10, 10)


def cost_of(points: np.ndarray) -> float:
    observations = torch.as_tensor(points, dtype=torch.float64)[None]  # (1, T, 2)
    weights = torch.ones(1, len(points), dtype=torch.float64)
    return ergodic_cost(observations, weights, torch.zeros(1, dtype=torch.int64), WHOLE_SQUARE).item()


def test_spread_out_observations_cost_less_than_clumped_ones():
    grid = (np.stack(np.meshgrid(np.arange(5), np.arange(5)), -1).reshape(-1, 2) + 0.5) / 5
    clump = 0.5 + 0.02 * np.random.default_rng(0).standard_normal((25, 2))
    assert cost_of(grid) < 0.1 * cost_of(clump)


def test_uniform_region_target_and_empty_team_cost():
    assert WHOLE_SQUARE[0, 0, 0].item() == pytest.approx(1.0)
    assert WHOLE_SQUARE[0, 1:, :].abs().max().item() < 1e-3  # pixel centres ~ uniform: phi_k ~ 0
    empty = ergodic_cost(torch.zeros(0, 3, 2), torch.zeros(0, 3), torch.zeros(0, dtype=torch.int64),
                         WHOLE_SQUARE.float())
    assert empty.item() == pytest.approx(1.0, abs=1e-3)


def test_species_weights_count_observations_in_proportion():
    left, right = np.array([[0.25, 0.5]] * 4), np.array([[0.75, 0.5]] * 4)
    observations = torch.as_tensor(np.stack([left, right]))
    team = torch.zeros(2, dtype=torch.int64)
    equal = ergodic_cost(observations, torch.ones(2, 4, dtype=torch.float64), team, WHOLE_SQUARE)
    skewed = ergodic_cost(observations, torch.tensor([[20.0] * 4, [10.0] * 4], dtype=torch.float64),
                          team, WHOLE_SQUARE)
    assert skewed.item() > equal.item()


def test_steps_respect_the_speed_of_the_terrain_underneath():
    terrain = torch.full((30, 30), 1, dtype=torch.int64)  # Mountain: ground robots 20 m/s
    robots = Robots(torch.tensor([0]), torch.tensor([0]), torch.tensor([[0.5, 0.5]]), torch.zeros(1, 4, 2))
    controls = torch.full((1, 4, 2), 100.0)  # saturated: as far as allowed
    path = rollout(robots, controls, terrain, substeps=4)[0]
    steps = (path[1:] - path[:-1]).norm(dim=-1)
    assert torch.allclose(steps, torch.full((4,), 20 * SPEED_SCALE), rtol=1e-3)


def test_a_species_with_speed_zero_on_a_terrain_cannot_cross_it():
    terrain = np.full((60, 60), 2, dtype=np.int64)  # Plain
    terrain[:, 26:31] = 0  # water 5 px (0.083) wide: narrower than a ground robot's step (0.12)
    regions = np.zeros((60, 60), dtype=np.int64)  # one region: the whole chip, so robots want to spread
    coverage = ChipCoverage(terrain, regions, 1, CoverageConfig(iterations=25, n_observations=20))
    counts = np.array([[[6, 0, 0]]])  # six ground robots
    _, robots, observations = coverage.evaluate(counts, seed=0)
    start_left = robots.start[:, 0] < 0.4
    assert start_left.any() and (~start_left).any()
    x = observations[..., 0]  # (N, T)
    assert (x[start_left] < 26 / 60).all() and (x[~start_left] >= 31 / 60).all()
    # an aerial robot has speed 50 on water and does cross when that helps coverage
    _, robots, observations = coverage.evaluate(np.array([[[0, 1, 0]]]), seed=0)
    xs = observations[0, :, 0]
    assert (xs < 26 / 60).any() and (xs >= 31 / 60).any()


def test_optimiser_lowers_the_cost_of_the_initial_trajectories():
    regions = np.zeros((40, 40), dtype=np.int64)
    coverage = ChipCoverage(np.full((40, 40), 2), regions, 1, SMALL)
    robots = coverage.deploy(np.array([[[2, 2, 0]]]), seed=0)
    weights = torch.ones(len(robots.species), SMALL.n_observations, dtype=torch.float64)
    before = ergodic_cost(rollout(robots, robots.controls, coverage.terrain, 8).double(), weights,
                          robots.team, coverage.phi)
    after, _ = optimise_trajectories(robots, coverage.phi, coverage.terrain, SMALL)
    assert after.item() < 0.5 * before.item()


def test_batched_evaluation_equals_one_allocation_at_a_time():
    terrain = np.random.default_rng(0).integers(0, 4, (40, 40))
    regions = np.repeat(np.arange(2), 20)[None, :].repeat(40, 0)  # left / right halves
    coverage = ChipCoverage(terrain, regions, 2, SMALL)
    counts = np.array([[[1, 0, 0], [0, 2, 1]], [[3, 1, 0], [0, 0, 0]], [[0, 1, 1], [2, 0, 0]]])
    batched, _, _ = coverage.evaluate(counts, seed=5)
    single = [coverage.evaluate(c[None], seed=5)[0][0] for c in counts]
    np.testing.assert_allclose(batched, single, rtol=1e-5)
    empty_right = 0.5 * (coverage.phi[1] ** 2 * frequencies(10)[1]).sum() / coverage.glance[1]
    assert batched[1] > empty_right.item() > 1.0  # the right region got no robot: a_1 E_empty / G_1


def test_an_allocation_costs_the_sum_of_its_teams_costs():
    terrain = np.random.default_rng(1).integers(0, 4, (40, 40))
    regions = np.repeat(np.arange(2), 20)[None, :].repeat(40, 0)
    coverage = ChipCoverage(terrain, regions, 2, SMALL)
    both, first, second, none = np.array([[[1, 2, 0], [0, 1, 1]], [[1, 2, 0], [0, 0, 0]],
                                          [[0, 0, 0], [0, 1, 1]], [[0, 0, 0], [0, 0, 0]]])
    costs, _, _ = coverage.evaluate(np.stack([both, first, second, none]), seed=2)
    assert costs[0] == pytest.approx(costs[1] + costs[2] - costs[3], rel=1e-9)


def test_glance_cost_is_the_expected_metric_of_random_observations():
    """G = E[metric of one uniform observation]; N independent ones cost G / N on average, so the
    normalised cost of N random glances per region is 1 / N."""
    regions = np.zeros((40, 40), dtype=np.int64)
    regions[:, 25:] = 1  # two regions: 25 and 15 columns wide
    phi, glance = region_targets(regions, 2, 10)
    rng = np.random.default_rng(0)
    pixels = np.argwhere(regions == 1)  # (P, 2) rows, cols
    for n_points in (1, 5):
        costs = []
        for _ in range(3000):
            row, col = pixels[rng.integers(len(pixels), size=n_points)].T
            points = np.stack([(col + 0.5) / 40, (row + 0.5) / 40], -1)  # pixel centres, as phi is
            observations = torch.as_tensor(points)[None]  # (1, N, 2)
            costs.append(ergodic_cost(observations, torch.ones(1, n_points, dtype=torch.float64),
                                      torch.zeros(1, dtype=torch.int64), phi[1:]).item())
        assert np.mean(costs) / glance[1].item() == pytest.approx(1 / n_points, rel=0.06)


def test_reference_point_bounds_covering_allocations_and_hypervolume_rises_with_coverage():
    """Allocations with a robot in every region lie inside the (0.25, 60) box, one that leaves a region
    empty lies outside, and at the same robot counts better trajectories give a larger hypervolume."""
    chip = synthetic_chip(0, 1, size=60)
    decomposition = decompose_chip(chip, DecomposeConfig(n_regions=4))
    aerial = np.zeros((4, 4, 3), dtype=np.int64)  # 1..4 aerial robots (they move on every terrain) per region
    aerial[:, :, 1] = np.arange(1, 5)[:, None]
    fronts = {}
    for iterations in (0, 25):
        config = CoverageConfig(iterations=iterations, n_observations=20)
        costs, _, _ = chip_coverage(chip, decomposition, config).evaluate(aerial, seed=0)
        fronts[iterations] = np.stack([costs, aerial.sum((1, 2))], -1)
    assert (fronts[25][:, 0] < fronts[0][:, 0]).all()  # the optimiser improves coverage ...
    assert (fronts[25][:, 0] < REFERENCE_POINT[0]).all()  # ... inside the box
    gain = team_hypervolume(fronts[25]) - team_hypervolume(fronts[0])
    assert gain > 0.01 * team_hypervolume(fronts[25])  # coverage, not only the robot count, moves HV
    one_empty = aerial[3:].copy()
    one_empty[0, 0] = 0
    cost, _, _ = chip_coverage(chip, decomposition, CoverageConfig(iterations=25)).evaluate(one_empty, seed=0)
    assert cost[0] > 1.0 > REFERENCE_POINT[0]


def test_allocation_id_depends_on_counts_and_shape_only():
    counts = np.array([[1, 2, 3], [0, 0, 1]])
    assert allocation_id(counts) == allocation_id(counts.astype(np.int64))
    assert allocation_id(counts) != allocation_id(counts.reshape(3, 2))
    assert allocation_id(counts) != allocation_id(counts + 1)
