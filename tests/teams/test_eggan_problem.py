import numpy as np
import pytest
import torch

from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.surrogate import SurrogateConfig
from robocompose.eggan.train import TrainConfig, train
from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.eggan_problem import EvolutionConfig, TeamsProblem, with_depot_row
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import chip_coverage
from robocompose.teams.nsga2 import team_hypervolume
from robocompose.teams.params import TeamFitnessConfig

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
    starts = {problem.design_id(d) for d in designs}
    new = [k for k, d in enumerate(evolved) if problem.design_id(d) not in starts]
    assert new and all(not ((objectives <= evolved_objectives[k]).all(1) & (objectives < evolved_objectives[k]).any(1)
                            ).any() for k in new)  # evolution made designs that no start design dominates
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



MODEL = TeamFitnessConfig(source="model", warmup=12, real_every=2, budget=10_000)
SMALL = SurrogateConfig(hidden=16, layers=2, steps=60, batch=64)  # a region-cost model that fits in milliseconds


def test_the_model_source_answers_unknown_teams_from_the_model_and_known_ones_exactly(chips):
    problem = TeamsProblem(chips, TINY, fitness=MODEL, region_model=SMALL)
    counts = np.array([[[1, 0, 0], [0, 2, 0], [0, 0, 0]], [[4, 4, 4], [3, 0, 1], [0, 1, 0]]])
    objectives = problem.objectives_of_counts(0, counts)  # the warm-up: 12 random allocations per chip, a fit
    warm = problem.real_evaluations
    assert warm == len(problem.evaluator(0).asked) + len(problem.evaluator(1).asked) > 12
    assert problem.model.fits == 1
    exact = TeamsProblem(chips, TINY)
    truth = exact.evaluator(0).team_costs(counts)
    known = np.array([[problem.evaluator(0).key((i, tuple(allocation[i]))) in problem.cache for i in range(3)]
                      for allocation in counts]) & (counts.sum(2) > 0)
    answered = problem.evaluator(0).team_costs(counts, lambda teams: problem.predict(0, teams))
    np.testing.assert_array_equal(answered[known], truth[known])  # an optimised team answers exactly
    assert problem.real_evaluations == warm  # the model answered the rest: nothing optimised
    np.testing.assert_allclose(objectives[:, 0], answered.sum(1))
    # every second evaluate call is a round: its unknown teams optimised, the model refitted, the error noted
    designs = list(counts / 20.0)
    problem.evaluate(0, designs)
    assert problem.model.fits == 1
    values = problem.evaluate(0, designs)
    assert problem.model.fits == 2 and len(problem.prospective) == problem.real_evaluations - warm > 0
    np.testing.assert_allclose(values[:, 0], exact.evaluate(0, designs)[:, 0])  # the round's exact costs answer
    error = problem.model_error()
    assert error["model_heldout_n"] + error["model_teams"] == problem.real_evaluations
    assert error["model_prospective_n"] == len(problem.prospective) and -1 <= error["model_heldout_spearman"] <= 1
    assert TeamsProblem(chips, TINY).model_error() == {}


def test_a_model_round_stops_at_the_budget(chips):
    problem = TeamsProblem(chips, TINY, fitness=TeamFitnessConfig(source="model", warmup=12, real_every=1,
                                                                  budget=1), region_model=SMALL)
    problem.evaluate(0, list(np.full((2, 3, 3), 0.3)))  # the warm-up alone passes the budget: no round
    assert problem.model.fits == 1 and problem.prospective == []


def test_the_archive_keeps_the_chips_population_and_its_front_never_recedes(chips):
    problem = TeamsProblem(chips, TINY, evolution=EvolutionConfig(archive=True))
    rng = np.random.default_rng(1)
    fronts = []
    for _ in range(3):
        designs = list(rng.dirichlet(np.ones(4), size=(8, 3)).transpose(0, 2, 1)[:, :3])
        evolved, objectives = problem.evolve(0, designs, problem.evaluate(0, designs), "nsga2", 1, rng)
        fronts.append(team_hypervolume(objectives))
    assert fronts[0] <= fronts[1] <= fronts[2]  # elitist over X_gen and the last X_pop: the archive only improves
    np.testing.assert_allclose(problem._archive[0].reshape(-1, 3, 3), np.stack(evolved))
    restored = TeamsProblem(chips, TINY, evolution=EvolutionConfig(archive=True))
    restored.load_state_dict(problem.state_dict())
    np.testing.assert_array_equal(restored._archive[0], problem._archive[0])


def test_a_killed_training_on_the_model_source_resumes_to_the_same_generator(chips, tmp_path):
    config = TrainConfig(iterations=4, batch=8, tasks=2, evolution="nsga2", log_every=1, checkpoint_every=2,
                         lr_generator=1e-3, lr_discriminator=1e-3)

    def problem() -> TeamsProblem:
        return TeamsProblem(chips, TINY, EvolutionConfig(archive=True), fitness=MODEL, region_model=SMALL)

    whole = train(problem(), NETWORK, config, tmp_path / "whole.pt")
    path = tmp_path / "killed.pt"
    train(problem(), NETWORK, TrainConfig(**{**config.__dict__, "iterations": 2}), path)
    resumed = train(problem(), NETWORK, config, path)
    for name, tensor in whole.generator.state_dict().items():
        assert torch.equal(tensor, resumed.generator.state_dict()[name]), name
    assert whole.rows == resumed.rows
