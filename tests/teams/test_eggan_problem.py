import numpy as np
import pytest
import torch

from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.train import TrainConfig, train
from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.eggan_problem import TeamsProblem, with_depot_row
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import chip_coverage
from robocompose.teams.nsga2 import team_hypervolume

TINY = CoverageConfig(iterations=3, n_observations=5)
NETWORK = NetworkConfig(latent=4, hidden=16)


@pytest.fixture(scope="module")
def chips():
    chips = [synthetic_chip(5, index, size=40) for index in range(2)]
    return [(chip, decompose_chip(chip, DecomposeConfig(n_regions=3))) for chip in chips]


def test_designs_are_fractions_with_a_depot_row(chips):
    problem = TeamsProblem(chips, TINY)
    assert problem.task_shape == (12,) and problem.design_shape == (4, 3)
    output = problem.design_head(torch.randn(5, 4, 3))
    torch.testing.assert_close(output.sum(1), torch.ones(5, 3))
    sampled = problem.sample_designs(output, None)
    assert sampled.log_prob is None and sampled.tensor is output and sampled.designs[0].shape == (3, 3)
    torch.testing.assert_close(problem.design_tensor(sampled.designs), output, atol=1e-6, rtol=0)
    neutral = problem.design_head(torch.zeros(1, 4, 3))  # untrained: half of each species, split evenly
    torch.testing.assert_close(neutral[0], torch.tensor([[1 / 6] * 3] * 3 + [[0.5] * 3]))
    over = with_depot_row(np.full((1, 3, 3), 0.6))  # asks for 180% of each species: scaled to all of it
    np.testing.assert_allclose(over[0, :3], 1 / 3)
    np.testing.assert_allclose(over[0, 3], 0, atol=1e-12)


def test_objectives_are_the_optimisers_costs_cached_per_team(chips):
    problem = TeamsProblem(chips, TINY, seed=2)
    counts = np.array([[[1, 0, 0], [0, 2, 0], [0, 0, 0]], [[1, 0, 0], [3, 0, 1], [0, 1, 0]]])
    objectives = problem.objectives_of_counts(1, counts)
    assert problem.real_evaluations == 4  # (r0: 1 ground) is shared, empty teams cost no optimisation
    assert problem.evaluator(1).optimised == 4 and problem.team_lookups == 5
    direct, _, _ = chip_coverage(*chips[1], TINY).evaluate(counts, seed=2)  # the teams optimised together
    np.testing.assert_array_equal(objectives[:, 0], direct)  # a team's cost does not depend on its company
    assert objectives[:, 1].tolist() == [3, 6]
    problem.objectives_of_counts(1, counts[::-1])
    assert problem.real_evaluations == 4 and problem.evaluator(1).optimised == 4


def test_evolution_raises_the_hypervolume_and_dominates_every_start_design(chips):
    problem = TeamsProblem(chips, TINY)
    rng = np.random.default_rng(0)
    designs = list(rng.dirichlet(np.ones(4), size=(8, 3)).transpose(0, 2, 1)[:, :3])  # 8 (K, O) fractions
    objectives = problem.evaluate(0, designs)
    evolved, evolved_objectives = problem.evolve(0, designs, objectives, "nsga2", 2, rng)
    assert len(evolved) == 8 and evolved_objectives.shape == (8, 2)
    np.testing.assert_allclose(problem.evaluate(0, evolved), evolved_objectives)
    assert team_hypervolume(evolved_objectives) > team_hypervolume(objectives) + 0.5  # 5.05 -> 5.77
    assert all((evolved_objectives <= start).all(1).any() for start in objectives)  # elitist survival
    with pytest.raises(ValueError, match="supports \\['nsga2'\\]"):
        problem.evolve(0, designs, objectives, "crowding", 1, rng)


def test_a_killed_training_resumes_to_the_same_checkpoint(chips, tmp_path):
    config = TrainConfig(iterations=4, batch=8, tasks=2, evolution="nsga2", log_every=1, checkpoint_every=2,
                         lr_generator=1e-3, lr_discriminator=1e-3)
    whole = train(TeamsProblem(chips, TINY), NETWORK, config, tmp_path / "whole.pt")
    path = tmp_path / "killed.pt"
    train(TeamsProblem(chips, TINY), NETWORK, TrainConfig(**{**config.__dict__, "iterations": 2}), path)
    resumed_problem = TeamsProblem(chips, TINY)
    resumed = train(resumed_problem, NETWORK, config, path)  # picks up at iteration 2
    assert resumed_problem.real_evaluations == whole.rows[-1]["real_evaluations"]
    for name, tensor in whole.generator.state_dict().items():
        assert torch.equal(tensor, resumed.generator.state_dict()[name]), name
    assert whole.rows == resumed.rows

