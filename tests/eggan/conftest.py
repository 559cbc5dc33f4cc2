"""A tiny EG-GAN problem without a simulator: the best design depends on the task tensor.

Task: a target choice per port (6 ports, 4 choices), drawn uniformly; its tensor is a 6 x 8 image with a 1 in
row r at column target[r] (2-D, so the networks read it with their convolutions). Design: 6 choices. Fitness:
the number of ports that match the target (0..6), the unique optimum is the target itself.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import torch

from robocompose.eggan.problem import Objective, Sampled, evolve_single_objective, one_hot_rows, sample_rows

PORTS, CHOICES = 6, 4


class MatchSearch:
    """The `robocompose.search` problem of one task (for the evolution)."""

    def __init__(self, target: tuple[int, ...], owner: MatchProblem):
        self.target, self.owner = np.array(target), owner

    def sample(self, rng, n):
        return [tuple(int(v) for v in row) for row in rng.integers(CHOICES, size=(n, PORTS))]

    def mutate(self, design, rng, rate):
        genes = np.array(design)
        redraw = rng.random(PORTS) < rate
        genes[redraw] = rng.integers(CHOICES, size=int(redraw.sum()))
        return tuple(int(v) for v in genes)

    def crossover(self, a, b, rng):
        swap = rng.random(PORTS) < 0.5
        return (tuple(int(y if s else x) for x, y, s in zip(a, b, swap, strict=True)),
                tuple(int(x if s else y) for x, y, s in zip(a, b, swap, strict=True)))

    def distance(self, a, b):
        return float(sum(x != y for x, y in zip(a, b, strict=True)))

    def evaluate(self, designs):
        self.owner.evaluations += len(designs)
        return np.array([float((np.array(d) == self.target).sum()) for d in designs])


class MatchProblem:
    name = "match"
    task_shape = (PORTS, 8)
    design_shape = (PORTS, CHOICES)
    discrete = True
    objectives = (Objective("matches", maximise=True),)
    evolution_methods = ("crowding", "ga")

    def __init__(self):
        self.evaluations = 0

    def sample_task(self, rng):
        return tuple(int(v) for v in rng.integers(CHOICES, size=PORTS))

    def encode_task(self, task):
        image = torch.zeros(PORTS, 8)
        image[torch.arange(PORTS), torch.tensor(task)] = 1.0
        return image

    def design_head(self, logits):
        return torch.softmax(logits, dim=-1)

    def sample_designs(self, output, generator):
        picks, log_prob = sample_rows(output, generator)
        designs = [tuple(int(v) for v in row) for row in picks.tolist()]
        return Sampled(designs, one_hot_rows(picks, CHOICES), log_prob)

    def designs_from_choices(self, choices):
        return [tuple(int(v) for v in row) for row in choices]

    def design_tensor(self, designs):
        return one_hot_rows(np.array(designs), CHOICES)

    def evaluate(self, task, designs):
        return MatchSearch(task, self).evaluate(designs)[:, None]

    def evolve(self, task, designs, objectives, method, steps, rng):
        population, fitness = evolve_single_objective(MatchSearch(task, self), designs, objectives[:, 0], method,
                                                      steps, rng)
        return population, fitness[:, None]

    def design_id(self, design):
        return "".join(str(v) for v in design)

    @property
    def real_evaluations(self):
        return self.evaluations

    def key(self):
        return hashlib.sha256(b"match-v1").hexdigest()[:16]

    def state_dict(self):
        return {"evaluations": self.evaluations}

    def load_state_dict(self, state):
        self.evaluations = state["evaluations"]


@pytest.fixture
def match_problem():
    return MatchProblem()
