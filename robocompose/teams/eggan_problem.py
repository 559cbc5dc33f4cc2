"""Team formation as an EG-GAN problem (thesis 5.2).

Task: a training chip; its tensor is the K x 4 terrain-feature matrix of its regions (rows: terrain
shares of a region), flattened, so the generator is the thesis's MLP on (z, task).
Design: a K x O allocation, entry (i, j) = the fraction of species j sent to region i. The generator
gives (K + 1) x O logits; per species, the first K give the split over the regions (a softmax) and
the last the deployed share s = sigmoid(logit), so fraction (i, j) = s_j * split_ij and a design can
deploy anywhere from no robot to the whole bank (the group's code split every robot over the regions,
always deploying all of them). This is the factorisation NSGA-II's initial population uses (a share of
each species, split over the regions), and an untrained generator deploys about half the bank with a
spread over z (a softmax over K regions + a depot row would start at K / (K + 1) of the bank and stay
there: we measured every allocation of 100 iterations above 50 robots). The design is continuous (the
output is the design), so the trainer uses the GAN loss of eq. 4.1 and the discriminator sees the
(K + 1) x O matrix [fractions; 1 - s] (the last row: what stays in the depot).
Counts: species.allocation_to_counts, as for NSGA-II.
Objectives, both minimised: coverage cost (ergodic.py) and deployment cost (robots deployed).
Evolution-guided data creation: `steps` NSGA-II generations (nsga2.nsga2_generation: rank, crowding,
roulette-wheel selection, the thesis's crossover and mutation, elitist survival) on the generated
batch, genomes = the K x O fractions.

Fitness: the ergodic trajectory optimiser itself, through the exact team-cost memo of evaluator.py (one
`AllocationEvaluator` per chip on one shared cache: a file shared with the other teams stages, or memory).
A method's spend (`real_evaluations`) is the number of distinct teams it asked for, whatever the cache already
held, so logs and metrics do not depend on a warm cache; those teams' costs are part of the problem's state,
so a resumed training sees the same values without optimising them again.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
import torch

from robocompose.eggan.problem import Objective, Sampled
from robocompose.fanout.cache import EvaluationCache
from robocompose.io.provenance import code_digest
from robocompose.search.nsga2 import nsga2_generation
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition, terrain_features
from robocompose.teams.ergodic import CoverageConfig, allocation_id
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache
from robocompose.teams.nsga2 import AllocationProblem
from robocompose.teams.species import SPECIES, allocation_to_counts


@dataclass(frozen=True)
class EvolutionConfig:
    crossover_probability: float = 0.5  # NSGA-II single-point arithmetic crossover (thesis 0.5)
    mutation_rate: float = 0.1  # NSGA-II per-gene uniform mutation (thesis 0.1)


def task_features(chip: Chip, decomposition: Decomposition) -> np.ndarray:
    """(K, 4) terrain shares of a chip's regions: the task."""
    return terrain_features(chip.terrain, decomposition.raster(chip.terrain), decomposition.n_regions)


def normalised_fractions(fractions: np.ndarray) -> np.ndarray:
    """(..., K, O) fractions with every species column scaled to sum <= 1 (as allocation_to_counts does)."""
    fractions = np.clip(np.asarray(fractions, dtype=np.float64), 0.0, None)
    return fractions / np.maximum(fractions.sum(-2, keepdims=True), 1.0)


def with_depot_row(fractions: np.ndarray) -> np.ndarray:
    """(B, K, O) fractions -> (B, K + 1, O): the last row is the share of each species kept back."""
    fractions = normalised_fractions(fractions)
    return np.concatenate([fractions, 1.0 - fractions.sum(-2, keepdims=True)], axis=-2)


DESIGN_HEAD = "share-split"  # the generator-output -> design map above (stored in generator files)


class TeamsProblem:
    """The teams EG-GAN problem on a set of training chips (see the module docstring)."""

    name = "teams"
    discrete = False
    objectives = (Objective("coverage_cost", maximise=False), Objective("deployment_cost", maximise=False))
    evolution_methods = ("nsga2",)

    def __init__(self, chips: Sequence[tuple[Chip, Decomposition]], coverage: CoverageConfig,
                 evolution: EvolutionConfig = EvolutionConfig(), seed: int = 0,
                 cache: EvaluationCache | None = None):
        if not chips:
            raise ValueError("teams EG-GAN: no training chips")
        self.chips = list(chips)
        self.coverage, self.evolution, self.seed = coverage, evolution, seed
        self.n_regions = self.chips[0][1].n_regions
        self.n_species = len(SPECIES)
        self.task_shape = (self.n_regions * 4,)
        self.design_shape = (self.n_regions + 1, self.n_species)
        self.features = [task_features(chip, decomposition) for chip, decomposition in self.chips]
        self.cache = teams_cache() if cache is None else cache
        self._evaluators: dict[int, AllocationEvaluator] = {}  # built on first use (phi of every region)
        self._resumed_lookups = 0  # team look-ups before a resume

    # ---- the EG-GAN interface ----------------------------------------------------------------------
    def sample_task(self, rng: np.random.Generator) -> int:
        return int(rng.integers(len(self.chips)))

    def encode_task(self, task: int) -> torch.Tensor:
        return torch.as_tensor(self.features[task].ravel(), dtype=torch.float32)  # (K*4,)

    def design_head(self, logits: torch.Tensor) -> torch.Tensor:
        split = torch.softmax(logits[:, :-1], dim=1)  # (B, K, O): each species' split over the regions
        share = torch.sigmoid(logits[:, -1:])  # (B, 1, O): each species' deployed share
        return torch.cat([split * share, 1.0 - share], dim=1)  # (B, K+1, O), columns sum to 1

    def sample_designs(self, output: torch.Tensor, generator: torch.Generator | None) -> Sampled:
        designs = list(output[:, :self.n_regions].detach().double().numpy())  # B (K, O) fractions
        return Sampled(designs, output, None)

    def design_tensor(self, designs: Sequence[np.ndarray]) -> torch.Tensor:
        return torch.as_tensor(with_depot_row(np.stack(designs)), dtype=torch.float32)

    def evaluate(self, task: int, designs: Sequence[np.ndarray]) -> np.ndarray:
        counts = allocation_to_counts(np.stack(designs), self.coverage.robots_per_species)
        return self.objectives_of_counts(task, counts)

    def evolve(self, task: int, designs: list[np.ndarray], objectives: np.ndarray, method: str, steps: int,
               rng: np.random.Generator) -> tuple[list[np.ndarray], np.ndarray]:
        if method != "nsga2":
            raise ValueError(f"evolution method {method!r}: the teams problem supports {list(self.evolution_methods)}")
        problem = AllocationProblem(self.n_regions, self.n_species, self.coverage.robots_per_species,
                                    lambda counts: self.objectives_of_counts(task, counts))
        genomes = np.stack(designs).reshape(len(designs), -1)  # (B, K*O)
        for _ in range(steps):
            genomes, objectives = nsga2_generation(genomes, objectives, problem,
                                                   self.evolution.crossover_probability,
                                                   self.evolution.mutation_rate, rng)
        return list(genomes.reshape(-1, self.n_regions, self.n_species)), objectives

    def design_id(self, design: np.ndarray) -> str:
        return allocation_id(allocation_to_counts(design, self.coverage.robots_per_species))

    @property
    def real_evaluations(self) -> int:
        """Distinct teams asked for so far (each one trajectory optimisation without a cache)."""
        return sum(len(evaluator.asked) for evaluator in self._evaluators.values())

    @property
    def team_lookups(self) -> int:
        """Non-empty teams asked for so far, repeats included: against `real_evaluations`, what the memo saved."""
        return self._resumed_lookups + sum(evaluator.lookups for evaluator in self._evaluators.values())

    def key(self) -> str:
        chips = [(chip.chip_id, hashlib.sha1(chip.classes.tobytes()).hexdigest()[:12],
                  decomposition.centres.round(12).tolist(), decomposition.terrain_weight)
                 for chip, decomposition in self.chips]
        text = json.dumps([asdict(self.coverage), asdict(self.evolution), self.seed, chips,
                           code_digest(__name__)])  # this module's import closure: the whole fitness
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def state_dict(self) -> dict:
        rows = [[*key, self.cache.get(key)["team_cost"]] for evaluator in self._evaluators.values()
                for key in sorted(evaluator.asked)]
        return {"team_costs": sorted(rows), "team_lookups": self.team_lookups}

    def load_state_dict(self, state: dict) -> None:
        task_of = {chip.chip_id: task for task, (chip, _) in enumerate(self.chips)}
        for *key, cost in state["team_costs"]:
            self.cache.put(tuple(key), team_cost=cost)
            self.evaluator(task_of[key[1]]).asked.add(tuple(key))
        self._resumed_lookups = state["team_lookups"] - sum(e.lookups for e in self._evaluators.values())

    # ---- fitness from the optimiser, through the team-cost memo ----------------------------------------
    def evaluator(self, task: int) -> AllocationEvaluator:
        """The objectives of training chip `task` (built on first use)."""
        if task not in self._evaluators:
            chip, decomposition = self.chips[task]
            self._evaluators[task] = AllocationEvaluator(chip_coverage(chip, decomposition, self.coverage),
                                                         chip.chip_id, self.seed, self.cache)
        return self._evaluators[task]

    def objectives_of_counts(self, task: int, counts: np.ndarray) -> np.ndarray:
        """(B, 2) [coverage cost, deployment cost] of (B, K, O) counts on training chip `task`."""
        return self.evaluator(task)(counts)
