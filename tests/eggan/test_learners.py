"""The learner registry: every learner reads its own files and answers a task with k candidates, best first;
the baselines train through their registry entry. The toy problem of conftest.py stands in for both worlds."""

import inspect

from robocompose.eggan.dqn import DQNConfig
from robocompose.eggan.fit2form import Fit2formConfig
from robocompose.eggan.learners import LEARNERS, baselines
from robocompose.eggan.molgan import MolganConfig
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import load_generator
from robocompose.eggan.train import TrainConfig, train

NETWORK = NetworkConfig(latent=8, hidden=16)


def test_the_registry_holds_eggan_and_the_three_learned_baselines_of_table_5_1():
    assert list(LEARNERS) == ["eggan", "fit2form", "dqn", "molgan"]
    assert list(baselines()) == ["fit2form", "dqn", "molgan"] and LEARNERS["eggan"].training is None
    assert [LEARNERS[n].training.settings for n in baselines()] == [Fit2formConfig, DQNConfig, MolganConfig]
    for learner in baselines().values():
        assert list(inspect.signature(learner.training.train).parameters)[:4] == ["problem", "network", "config",
                                                                                  "progress"]


def test_a_trained_eggan_generator_answers_through_its_registry_entry(tmp_path, match_problem):
    from robocompose.eggan.query import save_generator

    trained = train(match_problem, NETWORK, TrainConfig(iterations=4, batch=16, tasks=4, samples=4, log_every=2,
                                                        checkpoint_every=2))
    path = save_generator(trained.generator, match_problem, tmp_path / "g.pt", {})
    learner = LEARNERS["eggan"]
    answer = learner.answer(learner.load(path, match_problem)[0], 16)
    designs = answer(match_problem, 1, 0, 3)
    assert len(designs) == len(set(map(match_problem.design_id, designs))) == 3
    assert answer(match_problem, 1, 0, 3) == designs  # the query seed fixes the draws


def test_a_generator_baseline_trains_saves_loads_and_answers_through_its_entry(tmp_path, match_problem):
    """Fit2form on the toy problem (MolGAN and DQN need a modular problem: tests/modular/test_eggan_experiments.py)."""
    name, learner = "fit2form", LEARNERS["fit2form"]
    config = learner.training.settings(iterations=2, tasks=2)
    model, rows = learner.training.train(match_problem, NETWORK, config, False)
    assert rows and isinstance(learner.training.metrics(config, rows), dict)
    path = learner.training.save(model, match_problem, tmp_path / f"{name}.pt", {"metrics": {}})
    assert learner.load is load_generator
    designs = learner.answer(learner.load(path, match_problem)[0], 8)(match_problem, 2, 5, 2)
    assert len(designs) == 2
