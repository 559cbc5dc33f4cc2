"""The problem interface EG-GAN trains on (thesis ch. 4), and the evolution helpers a problem can reuse.

EG-GAN is generic: a problem supplies the task distribution, the tensor forms of tasks and designs, how a
design is drawn from the generator's output, the evolution that turns generated designs into "real" ones
(thesis Algorithms 2 and 3), and one or more objectives. The trainer (`robocompose.eggan.train`) never looks
inside a task or a design; it only hands them back to the problem. Each world implements this protocol in its
own package (`robocompose.modular.plugins.eggan_problem`, the teams problem in `robocompose.teams`), so this package
imports neither.

Conventions
- A *task* and a *design* are whatever objects the problem likes (a terrain seed, a port string, a region
  feature matrix, an allocation): the trainer stores them in lists and passes them back.
- `encode_task(task)` -> float32 tensor of shape `task_shape`. A 2-D task shape (H, W) is read by the
  networks as an image (two 3x3 convolutions of 32 filters, thesis 5.1); any other shape is flattened
  (an MLP on (z, task), thesis 5.2).
- The generator's last layer gives `(B, *design_shape)` logits; `design_head` turns them into the output
  X~ (discrete problems: a categorical distribution per row, thesis 5.1's 6 x 4 row-softmax; continuous
  problems: the design itself, e.g. a softmax over regions per species).
- `sample_designs(output, generator)`: for a discrete problem, draw one design per row of the batch and
  return its log-probability under `output` (differentiable, for the BGAN loss eq. 4.2); for a continuous
  problem return the designs that `output` *is*, `log_prob` None and `tensor` = `output` itself (so the
  discriminator's gradient reaches the generator, eq. 4.1).
- `design_tensor(designs)` -> `(B, *design_shape)` float32: the discriminator's input for evolved designs
  (one-hot rows for a discrete problem), and the same form `sample_designs` gives for generated ones.
- `evaluate(task, designs)` -> `(B, K)` float64, one column per entry of `objectives`; each objective says
  whether it is maximised. A problem may answer from a cache, a table of exact results or a learned
  surrogate; it counts the real evaluations it spends in `real_evaluations` (the report's training budget).
  A problem with a finite budget raises `BudgetSpent` from the call that would exceed it: every trainer stops
  there, keeping the model of its last completed iteration.
- `random_designs(rng, n)`: n designs drawn uniformly from the problem's valid designs (the conditional MolGAN
  baseline's "real" data, thesis 5.1); only the baselines that need it call it.
- `key()`, `state_dict()`, `load_state_dict()`: what enters the trainer's checkpoint key, and the mutable
  state (a surrogate, counters) a checkpoint must hold for a resumed run to continue bit for bit.
- `evolve(task, designs, objectives, method, steps, rng)`: the evolution-guided data creation on a
  generated batch: returns X_pop (same length) and its `(B, K)` objectives. `method` names the evolution
  (e.g. "crowding", "ga", "nsga2"); a problem lists the ones it supports in `evolution_methods`.
  Single-objective problems can delegate to `evolve_single_objective` below.
- Sequential designers (the DQN baseline) build a discrete design one decision at a time
  (`SequentialProblem`): decision g sets every row of `decision_groups[g]` of the (R, C) design to one choice,
  and `designs_from_choices` turns (B, R) choices back into designs. A problem without `decision_groups` is
  decided one row per step (`decision_groups_of`); a problem with a symmetry (the modular robot's mirrored
  port pairs) lists the rows one decision sets together.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any, Protocol

import numpy as np
import torch
import torch.nn.functional as F

from robocompose.io.errors import InputError
from robocompose.search.crowding import CrowdingConfig, crowding_generation
from robocompose.search.ga import GAConfig, ga_generation
from robocompose.search.problem import Problem as SearchProblem

Task = Any
Design = Any


class BudgetSpent(Exception):
    """A problem's budget of evaluations is spent: the asking call was not answered and nothing was counted."""


@dataclass(frozen=True)
class Objective:
    """One objective of a problem: its name (a column of the logs and tables) and its sense."""

    name: str
    maximise: bool = True


@dataclass
class Sampled:
    """Designs drawn from (or given by) the generator's output for a batch of B noise vectors."""

    designs: list[Design]  # B designs
    tensor: torch.Tensor  # (B, *design_shape) the discriminator's input for them
    log_prob: torch.Tensor | None  # (B,) log P_theta(x | z, task), differentiable; None for continuous designs


class EgganProblem(Protocol):
    """What EG-GAN needs from a composition problem (see the module docstring for the conventions)."""

    name: str  # short name, used in file names and logs ("modular", "teams")
    task_shape: tuple[int, ...]  # shape of encode_task's tensor
    design_shape: tuple[int, ...]  # shape of one design's tensor form and of the generator's output
    discrete: bool  # True: designs are drawn from the output (BGAN loss); False: the output is the design
    objectives: tuple[Objective, ...]
    evolution_methods: tuple[str, ...]  # names `evolve` accepts

    def sample_task(self, rng: np.random.Generator) -> Task:
        """A training task drawn from the task distribution."""
        ...

    def encode_task(self, task: Task) -> torch.Tensor:
        """The task as a float32 tensor of shape `task_shape`."""
        ...

    def design_head(self, logits: torch.Tensor) -> torch.Tensor:
        """(B, *design_shape) logits -> the generator's output X~ (e.g. a softmax per row)."""
        ...

    def sample_designs(self, output: torch.Tensor, generator: torch.Generator | None) -> Sampled:
        """Designs from the generator's output (B, *design_shape); see the module docstring."""
        ...

    def design_tensor(self, designs: Sequence[Design]) -> torch.Tensor:
        """(B, *design_shape) float32 tensor form of designs."""
        ...

    def evaluate(self, task: Task, designs: Sequence[Design]) -> np.ndarray:
        """(B, K) objective values of designs on the task, K = len(objectives)."""
        ...

    def evolve(self, task: Task, designs: list[Design], objectives: np.ndarray, method: str, steps: int,
               rng: np.random.Generator) -> tuple[list[Design], np.ndarray]:
        """X_pop and its (B, K) objectives: `steps` steps of evolution `method` on the generated batch."""
        ...

    def random_designs(self, rng: np.random.Generator, n: int) -> list[Design]:
        """n designs drawn uniformly (with replacement) from the valid designs (MolGAN's real data)."""
        ...

    def design_id(self, design: Design) -> str:
        """A printable, canonical name of a design (logs, tables, the compose CLI)."""
        ...

    @property
    def real_evaluations(self) -> int:
        """Evaluations by the real evaluator (simulator / optimiser) spent so far, repeats included."""
        ...

    def key(self) -> str:
        """Everything about the problem that shapes training (settings, task distribution, data, and the
        `robocompose.io.provenance.code_digest` of the problem's modules): part of the checkpoint key."""
        ...

    def state_dict(self) -> dict:
        """The problem's mutable state (e.g. a surrogate and its data, the evaluation counters), for checkpoints."""
        ...

    def load_state_dict(self, state: dict) -> None:
        """Restore what `state_dict` returned, so that a resumed run continues exactly."""
        ...


class SequentialProblem(EgganProblem, Protocol):
    """A discrete problem a sequential designer can build (see the module docstring)."""

    decision_groups: tuple[tuple[int, ...], ...]  # optional: the rows each decision sets, in decision order

    def designs_from_choices(self, choices: np.ndarray) -> list[Design]:
        """(B, R) integer choice per row of the design (R = design_shape[0]) -> B designs."""
        ...


def decision_groups_of(problem: SequentialProblem) -> tuple[tuple[int, ...], ...]:
    """The problem's decision groups (one decision per row when it declares none), checked to partition the rows."""
    rows = problem.design_shape[0]
    groups = tuple(tuple(int(r) for r in g) for g in getattr(problem, "decision_groups", [(r,) for r in range(rows)]))
    if sorted(r for g in groups for r in g) != list(range(rows)) or not all(groups):
        raise ValueError(f"problem {problem.name}: decision_groups {groups} must partition the design's rows "
                         f"0..{rows - 1}, each row in exactly one non-empty group")
    return groups


def sample_rows(output: torch.Tensor, generator: torch.Generator | None) -> tuple[torch.Tensor, torch.Tensor]:
    """Categorical draw per row of a (B, R, C) row-stochastic output: (B, R) indices and (B,) log-probabilities.

    The log-probability sum_r log output[b, r, x_br] keeps its gradient (the BGAN loss needs it).
    """
    b, r, c = output.shape
    with torch.no_grad():
        picks = torch.multinomial(output.detach().reshape(b * r, c), 1, generator=generator).view(b, r)
    log_prob = output.gather(2, picks.unsqueeze(2)).squeeze(2).clamp_min(1e-12).log().sum(dim=1)
    return picks, log_prob


def one_hot_rows(indices: np.ndarray | torch.Tensor, classes: int) -> torch.Tensor:
    """(B, R) integer choices -> (B, R, C) float32 one-hot rows (a discrete design's tensor form)."""
    return F.one_hot(torch.as_tensor(np.asarray(indices), dtype=torch.int64), classes).float()


SINGLE_OBJECTIVE_METHODS = ("crowding", "ga")


def evolve_single_objective(problem: SearchProblem, designs: list[Design], fitness: np.ndarray, method: str,
                            steps: int, rng: np.random.Generator, crossover_rate: float = 0.9,
                            mutation_rate: float = 1 / 6, elite: int = 1) -> tuple[list[Design], np.ndarray]:
    """Evolution-guided data creation for one maximised objective on a `robocompose.search` problem.

    "crowding" (EG-GAN-crowding, thesis Alg. 2): `steps` generations of deterministic crowding on the batch
    (random pairs, uniform crossover, mutation, parent-child matching by distance, a child replaces its parent
    only if strictly fitter). "ga" (EG-GAN): `steps` generations of the classic GA (tournament, uniform
    crossover, mutation, `elite` kept). `fitness` is (B,) for `designs`; returns X_pop and its (B,) fitness.
    """
    if method == "crowding":
        config = CrowdingConfig(population=len(designs), crossover_rate=crossover_rate, mutation_rate=mutation_rate)
        generation = partial(crowding_generation, config=config)
    elif method == "ga":
        config = GAConfig(population=len(designs), crossover_rate=crossover_rate, mutation_rate=mutation_rate,
                          elite=elite)
        generation = partial(ga_generation, config=config)
    else:
        raise InputError(f"evolution method {method!r}: expected one of {SINGLE_OBJECTIVE_METHODS}")
    fitness = np.asarray(fitness, dtype=np.float64)
    for _ in range(steps):
        designs, fitness = generation(problem, designs, fitness, rng)
    return list(designs), fitness


def check_problem(problem: EgganProblem) -> None:
    """Fail early with a clear message if a problem does not fit what the trainer needs."""
    for name in ("task_shape", "design_shape", "discrete", "objectives", "evolution_methods", "name"):
        if not hasattr(problem, name):
            raise ValueError(f"EG-GAN problem {type(problem).__name__}: missing attribute {name!r}")
    if not problem.objectives:
        raise ValueError(f"EG-GAN problem {problem.name}: needs at least one objective")
    if len(problem.design_shape) < 1 or any(int(d) < 1 for d in problem.design_shape):
        raise ValueError(f"EG-GAN problem {problem.name}: design_shape must be positive, got {problem.design_shape}")
