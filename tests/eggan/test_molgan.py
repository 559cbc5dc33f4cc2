"""Conditional MolGAN: its WGAN-GP term matches the real (random valid) designs, its reward term raises fitness,
the gradient penalty is that of WGAN-GP, bad configs are refused, and training is deterministic to the byte.

The toy problem is the match problem (fitness = ports equal to the task's target) with a validity rule: a design
is valid when port 0 holds choice 0, so the real data (uniform valid designs) differ from the untrained
generator's near-uniform output on port 0 only.
"""

import numpy as np
import pytest
import torch

from robocompose.eggan.molgan import MolganConfig, gradient_penalty, straight_through, train_molgan
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import generate, save_generator
from robocompose.io.errors import InputError
from robocompose.params import build_config
from tests.eggan.conftest import CHOICES, PORTS, MatchProblem

NETWORK = NetworkConfig(latent=8, hidden=32)


class ValidMatchProblem(MatchProblem):
    def random_designs(self, rng, n):
        rows = rng.integers(CHOICES, size=(n, PORTS))
        rows[:, 0] = 0
        return [tuple(int(v) for v in row) for row in rows]


def _port_marginals(generator, problem, tasks) -> np.ndarray:
    """(PORTS, CHOICES): the generator's row softmax averaged over the tasks and 64 z each."""
    return np.mean([generate(generator, problem, t, 64, seed=5)[1].mean(0).numpy() for t in tasks], axis=0)


def _held_out_tasks(problem, n=10):
    rng = np.random.default_rng(999)
    return [problem.sample_task(rng) for _ in range(n)]


def test_pure_wgan_moves_the_samples_to_the_real_distribution():
    problem = ValidMatchProblem()
    tasks = _held_out_tasks(problem)
    untrained, _ = train_molgan(problem, NETWORK, MolganConfig(iterations=1, n_critic=1, lr=1e-9))
    trained, rows = train_molgan(problem, NETWORK, MolganConfig(iterations=80, lam=1.0, tasks=4, samples=8))
    # the real designs all hold choice 0 at port 0; the untrained generator gives it about 1/4
    assert _port_marginals(untrained, problem, tasks)[0, 0] < 0.4
    assert _port_marginals(trained, problem, tasks)[0, 0] > 0.7
    assert all(row["lam"] == 1.0 for row in rows)


def test_pure_reward_raises_fitness_above_random():
    problem = ValidMatchProblem()
    generator, rows = train_molgan(problem, NETWORK, MolganConfig(iterations=300, lam=0.0, wgan_only_iterations=0,
                                                                  tasks=8, samples=8, n_critic=1))
    tasks = _held_out_tasks(problem)
    matches = [np.mean([sum(a == b for a, b in zip(d, t, strict=True))
                        for d in generate(generator, problem, t, 64, seed=3)[0].designs]) for t in tasks]
    assert np.mean(matches) > 1.8  # a uniform design matches 1.5 +- 0.04 (640 draws) of 6 ports
    assert rows[-1]["fitness_mean"] > rows[0]["fitness_mean"] + 0.3
    assert rows[-1]["reward_mse"] < rows[0]["reward_mse"]


class _Linear(torch.nn.Module):
    def __init__(self, weight):
        super().__init__()
        self.weight = weight

    def forward(self, design, task_code):
        return (design.flatten(1) * self.weight).sum(1) + task_code.sum(1)


def test_gradient_penalty_vanishes_for_a_unit_gradient_critic_only():
    weight = torch.randn(PORTS * CHOICES, generator=torch.Generator().manual_seed(0))
    real, fake = torch.rand(16, PORTS, CHOICES), torch.rand(16, PORTS, CHOICES)
    codes = torch.randn(16, 3)
    assert gradient_penalty(_Linear(weight / weight.norm()), real, fake, codes).item() == pytest.approx(0, abs=1e-10)
    assert gradient_penalty(_Linear(3 * weight / weight.norm()), real, fake, codes).item() == pytest.approx(4.0)


def test_straight_through_is_the_drawn_design_forward_and_the_softmax_backward():
    logits = torch.randn(3, PORTS, CHOICES, requires_grad=True)
    output = torch.softmax(logits, -1)
    one_hot = torch.nn.functional.one_hot(torch.zeros(3, PORTS, dtype=torch.int64), CHOICES).float()
    relaxed = straight_through(one_hot, output)
    assert torch.allclose(relaxed, one_hot)
    weights = torch.randn(3, PORTS, CHOICES)
    (relaxed * weights).sum().backward()
    expected = torch.autograd.grad((torch.softmax(logits, -1) * weights).sum(), logits)[0]
    assert torch.allclose(logits.grad, expected)


def test_bad_configs_name_the_field():
    for field, value in (("lam", 1.5), ("n_critic", 0), ("gp_weight", -1.0), ("wgan_only_iterations", -1),
                         ("samples", 0), ("lr", 0.0)):
        with pytest.raises(InputError, match=f"^where.{field}: "):
            build_config(MolganConfig, {field: value}, "where")
    with pytest.raises(ValueError, match="random_designs"):
        train_molgan(MatchProblem(), NETWORK, MolganConfig(iterations=1))


def test_same_config_same_bytes_other_seed_other_model(tmp_path):
    def saved(folder, seed):
        problem = ValidMatchProblem()
        generator, rows = train_molgan(problem, NETWORK, MolganConfig(iterations=4, tasks=2, samples=4, seed=seed,
                                                                      wgan_only_iterations=2))
        (tmp_path / folder).mkdir()
        return save_generator(generator, problem, tmp_path / folder / "molgan.pt", {"rows": rows}).read_bytes()

    first = saved("a", 0)
    assert saved("b", 0) == first
    assert saved("c", 1) != first
