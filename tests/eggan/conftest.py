"""Tiny EG-GAN problems without a simulator: the match problem and the two-family world (below).

Task: a target choice per port (6 ports, 4 choices), drawn uniformly; its tensor is a 6 x 8 image with a 1 in
row r at column target[r] (2-D, so the networks read it with their convolutions). Design: 6 choices. Fitness:
the number of ports that match the target (0..6), the unique optimum is the target itself.
"""

from __future__ import annotations

import hashlib
import itertools

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


# --- a world where the terrain decides (issue 46, item 5) ---
# Two terrain families on a 12 x 6 height map: low bumps (family A, tallest cell < 4 cm) and tall blocks (family B,
# 20-40 cm). A design is 6 ports of "nlwb" (the modular robot's letters). Exact table fitness: on A the number of
# wheels, on B the number of legs, plus a per-terrain draw in [0, 0.3) for every design (each terrain has its own
# table and optimum). Training tasks are a fixed pool of 20 terrains (as the modular pool's), held-out ones apart.

LETTERS, PORTS, H, W = "nlwb", 6, 12, 6
DESIGNS = ["".join(p) for p in itertools.product(LETTERS, repeat=PORTS)]  # all 4096
TRAIN = [("A", s) for s in range(10)] + [("B", s) for s in range(10)]
HELD_OUT = [("A", s) for s in range(100, 106)] + [("B", s) for s in range(100, 106)]


def height_map(task: tuple[str, int]) -> np.ndarray:
    family, seed = task
    rng = np.random.default_rng([seed, 0 if family == "A" else 1])
    heights = np.zeros((H, W), dtype=np.float32)
    for _ in range(int(rng.integers(3, 7))):  # a few blocks of 2 x 2 cells
        x, y = int(rng.integers(H - 1)), int(rng.integers(W - 1))
        heights[x:x + 2, y:y + 2] = rng.uniform(0.0, 0.04) if family == "A" else rng.uniform(0.2, 0.4)
    return heights


def fitness_table(task: tuple[str, int]) -> dict[str, float]:
    family, seed = task
    noise = np.random.default_rng([seed, 7, 0 if family == "A" else 1]).uniform(0.0, 0.3, size=len(DESIGNS))
    rewarded = "w" if family == "A" else "l"
    return {d: d.count(rewarded) + float(u) for d, u in zip(DESIGNS, noise, strict=True)}


class FamilySearch:
    """The `robocompose.search` problem of one terrain (for the evolution), scored by the table."""

    def __init__(self, owner: TwoFamilies, task):
        self.owner, self.task = owner, task

    def mutate(self, design, rng, rate):
        return "".join(LETTERS[int(rng.integers(4))] if rng.random() < rate else c for c in design)

    def crossover(self, a, b, rng):
        swap = rng.random(PORTS) < 0.5
        return ("".join(y if s else x for x, y, s in zip(a, b, swap, strict=True)),
                "".join(x if s else y for x, y, s in zip(a, b, swap, strict=True)))

    def distance(self, a, b):
        return float(sum(x != y for x, y in zip(a, b, strict=True)))

    def evaluate(self, designs):
        return self.owner.evaluate(self.task, designs)[:, 0]


class TwoFamilies:
    """The two-family world as an `EgganProblem`; evaluations are distinct (terrain, design) look-ups."""

    name = "two_families"
    task_shape = (H, W)
    design_shape = (PORTS, len(LETTERS))
    discrete = True
    objectives = (Objective("distance", maximise=True),)
    evolution_methods = ("crowding", "ga")

    def __init__(self):
        self.tables = {task: fitness_table(task) for task in TRAIN + HELD_OUT}
        self.looked_up: set = set()

    def sample_task(self, rng):
        return TRAIN[int(rng.integers(len(TRAIN)))]

    def encode_task(self, task):
        return torch.from_numpy(height_map(task))

    def design_head(self, logits):
        return torch.softmax(logits, dim=-1)

    def sample_designs(self, output, generator):
        picks, log_prob = sample_rows(output, generator)
        designs = ["".join(LETTERS[i] for i in row) for row in picks.tolist()]
        return Sampled(designs, one_hot_rows(picks, len(LETTERS)), log_prob)

    def design_tensor(self, designs):
        return one_hot_rows(np.array([[LETTERS.index(c) for c in d] for d in designs]), len(LETTERS))

    def evaluate(self, task, designs):
        self.looked_up |= {(task, d) for d in designs}
        return np.array([self.tables[task][d] for d in designs])[:, None]

    def evolve(self, task, designs, objectives, method, steps, rng):
        population, fitness = evolve_single_objective(FamilySearch(self, task), designs, objectives[:, 0], method,
                                                      steps, rng)
        return population, fitness[:, None]

    def design_id(self, design):
        return design

    @property
    def real_evaluations(self):
        return len(self.looked_up)

    def key(self):
        return hashlib.sha256(b"two-families-v1").hexdigest()[:16]

    def state_dict(self):
        return {"looked_up": sorted([family, seed, d] for (family, seed), d in self.looked_up)}

    def load_state_dict(self, state):
        self.looked_up = {((family, seed), d) for family, seed, d in state["looked_up"]}


@pytest.fixture
def match_problem():
    return MatchProblem()
