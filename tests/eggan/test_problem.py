"""Interface helpers: categorical rows with differentiable log-probabilities, one-hot tensors, the evolutions."""

import numpy as np
import pytest
import torch

from robocompose.eggan.problem import evolve_single_objective, one_hot_rows, sample_rows
from tests.eggan.conftest import MatchSearch


def test_sample_rows_log_prob_is_the_sum_of_the_chosen_entries_and_keeps_its_gradient():
    logits = torch.randn(3, 6, 4, requires_grad=True)
    output = torch.softmax(logits, dim=-1)
    picks, log_prob = sample_rows(output, torch.Generator().manual_seed(0))
    expected = torch.stack([output[b, torch.arange(6), picks[b]].log().sum() for b in range(3)])
    assert torch.allclose(log_prob, expected)
    log_prob.sum().backward()
    assert logits.grad is not None and logits.grad.abs().sum() > 0
    assert torch.equal(one_hot_rows(picks, 4).argmax(-1), picks)


@pytest.mark.parametrize("method", ["crowding", "ga"])
def test_evolution_keeps_the_batch_size_and_crowding_never_loses_fitness(match_problem, method):
    search = MatchSearch((0, 1, 2, 3, 0, 1), match_problem)
    rng = np.random.default_rng(0)
    designs = search.sample(rng, 16)
    fitness = search.evaluate(designs)
    evolved, evolved_fitness = evolve_single_objective(search, designs, fitness, method, 4, rng)
    assert len(evolved) == 16 and np.array_equal(evolved_fitness, search.evaluate(evolved))
    if method == "crowding":  # a child replaces its parent only if strictly fitter
        assert np.all(evolved_fitness >= fitness)
    assert evolved_fitness.max() >= fitness.max()


def test_unknown_evolution(match_problem):
    with pytest.raises(ValueError, match="expected one of"):
        evolve_single_objective(MatchSearch((0,) * 6, match_problem), [(0,) * 6] * 2, np.zeros(2), "nsga2", 1,
                                np.random.default_rng(0))
