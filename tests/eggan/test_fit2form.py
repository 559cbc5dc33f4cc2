"""Fit2form by policy gradient learns the toy problem's task-dependent answer."""

import numpy as np

from robocompose.eggan.fit2form import Fit2formConfig, train_fit2form
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import generate, rank_distinct


def test_fit2form_beats_random_on_held_out_tasks(match_problem):
    generator, rows = train_fit2form(match_problem, NetworkConfig(latent=16),
                                     Fit2formConfig(iterations=600, tasks=8, samples=8, lr=3e-3))
    rng = np.random.default_rng(999)
    scores = []
    for _ in range(20):
        task = match_problem.sample_task(rng)
        best = rank_distinct(match_problem, *generate(generator, match_problem, task, 64, seed=1), 1)[0].design
        scores.append(sum(a == b for a, b in zip(best, task, strict=True)))
    assert np.mean(scores) > 2.3  # random designs match 1.5 of 6
    assert rows[-1]["fitness_mean"] > rows[0]["fitness_mean"]
