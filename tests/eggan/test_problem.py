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


class TwoTargets(MatchSearch):
    """Two optima six ports apart, all 0s and all 3s: fitness is the matches with the nearer one."""

    def evaluate(self, designs):
        self.owner.evaluations += len(designs)
        return np.array([float(max((np.array(d) == t).sum() for t in (0, 3))) for d in designs])


@pytest.mark.parametrize("method", ["crowding", "ga"])
def test_evolution_raises_the_mean_fitness_with_one_batch_per_step(match_problem, method):
    search = MatchSearch((0, 1, 2, 3, 0, 1), match_problem)
    rng = np.random.default_rng(0)
    designs = search.sample(rng, 16)
    fitness = search.evaluate(designs)  # random: 1.5 matches expected
    evolved, evolved_fitness = evolve_single_objective(search, designs, fitness, method, 5, rng)
    assert match_problem.evaluations == 16 * (1 + 5)
    assert len(evolved) == 16 and np.array_equal(evolved_fitness, search.evaluate(evolved))
    assert evolved_fitness.mean() > fitness.mean() + 1


def test_crowding_keeps_both_optima_where_the_ga_keeps_one(match_problem):
    search = TwoTargets((0,) * 6, match_problem)
    optima = {(0,) * 6, (3,) * 6}

    def optima_kept(method, seed):
        rng = np.random.default_rng(seed)
        designs = search.sample(rng, 32)
        evolved, _ = evolve_single_objective(search, designs, search.evaluate(designs), method, 30, rng)
        return len(optima & set(evolved))

    crowding, ga = [optima_kept("crowding", s) for s in range(4)], [optima_kept("ga", s) for s in range(4)]
    assert sum(k == 2 for k in crowding) >= 3 and max(ga) == 1


def test_unknown_evolution(match_problem):
    with pytest.raises(ValueError, match="expected one of"):
        evolve_single_objective(MatchSearch((0,) * 6, match_problem), [(0,) * 6] * 2, np.zeros(2), "nsga2", 1,
                                np.random.default_rng(0))
