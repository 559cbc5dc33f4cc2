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

Fitness, `source: exact`: the ergodic trajectory optimiser itself, through the exact team-cost memo of
evaluator.py (one `AllocationEvaluator` per chip on one shared cache: a file shared with the other teams
stages, or memory). Exact training costs ~4 ms per new team, and NSGA-II in the loop asks for thousands of new
teams per iteration, so thousands of iterations would take hours.
`source: model` (the default profile): a learned region-cost model steers training. A team's cost depends only
on (chip, region, team counts), so the model maps [one-hot of the training region, its terrain shares, its area
share] x [counts / robots_per_species, log(1 + counts) / log(1 + robots_per_species)] to log(team cost)
(`robocompose.eggan.surrogate.Surrogate`, sizes `REGION_MODEL`). A team already optimised answers with its exact
cost, any other with the model's. The optimiser runs on `warmup` random allocations per training chip (NSGA-II's
initial sampler) before the first fit and, every `real_every` evaluate calls (the generator's designs of one
task), on that call's unknown teams (their exact costs answer the call), and the model is refitted, until
`budget` teams are optimised. Teams whose key hash is 0 mod 5 are held out of every fit; `model_error()` reports
the model's error on them and on each round's new teams before they were fitted (prospective error). Every
reported number (queries, tables) comes from the optimiser.
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
from robocompose.eggan.surrogate import Surrogate, SurrogateConfig, spearman
from robocompose.fanout.cache import EvaluationCache
from robocompose.io.provenance import INFRASTRUCTURE, code_digest
from robocompose.search.nsga2 import nsga2_generation, survivors
from robocompose.teams.chips import Chip
from robocompose.teams.decompose import Decomposition, terrain_features
from robocompose.teams.ergodic import CoverageConfig, allocation_id
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache
from robocompose.teams.nsga2 import AllocationProblem, deployment_share_draws
from robocompose.teams.params import TeamFitnessConfig
from robocompose.teams.species import SPECIES, allocation_to_counts, deployment_cost


@dataclass(frozen=True)
class EvolutionConfig:
    crossover_probability: float = 0.5  # NSGA-II single-point arithmetic crossover (thesis 0.5)
    mutation_rate: float = 0.1  # NSGA-II per-gene uniform mutation (thesis 0.1)
    archive: bool = False  # evolve X_gen together with the task's last X_pop (module docstring), not alone


HOLDOUT_EVERY = 5  # a team whose key hash is 0 mod 5 is held out of the model's fits


REGION_MODEL = SurrogateConfig(hidden=128, layers=3, steps=1500, batch=256, lr=3e-3, weight_decay=1e-5)


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
                 cache: EvaluationCache | None = None, fitness: TeamFitnessConfig | None = None,
                 region_model: SurrogateConfig = REGION_MODEL):
        if not chips:
            raise ValueError("teams EG-GAN: no training chips")
        self.chips = list(chips)
        self.coverage, self.evolution, self.seed = coverage, evolution, seed
        self.fitness = fitness or TeamFitnessConfig()
        self.n_regions = self.chips[0][1].n_regions
        self.n_species = len(SPECIES)
        self.task_shape = (self.n_regions * 4,)
        self.design_shape = (self.n_regions + 1, self.n_species)
        self.features = [task_features(chip, decomposition) for chip, decomposition in self.chips]
        self.cache = teams_cache() if cache is None else cache
        self._evaluators: dict[int, AllocationEvaluator] = {}  # built on first use (phi of every region)
        self._resumed_lookups = 0  # team look-ups before a resume
        self.region_model = region_model
        self.model = Surrogate((len(self.chips) * self.n_regions + 5,), (2 * self.n_species,), region_model,
                               self.fitness.seed)
        self.calls = 0  # evaluate calls (model source: rounds every `real_every`)
        self.prospective: list[list[float]] = []  # [log predicted, log exact] of each round's new teams
        self._archive: dict[int, np.ndarray] = {}  # task -> its last X_pop's (B, K*O) genomes (archive)
        self._region_vectors: torch.Tensor | None = None  # (R, R + 5) the model's region inputs, built on first use

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
        self.calls += 1
        if self.fitness.source == "model" and self.calls % self.fitness.real_every == 0:
            self._real_round(task, counts)
        return self.objectives_of_counts(task, counts)

    def evolve(self, task: int, designs: list[np.ndarray], objectives: np.ndarray, method: str, steps: int,
               rng: np.random.Generator) -> tuple[list[np.ndarray], np.ndarray]:
        if method != "nsga2":
            raise ValueError(f"evolution method {method!r}: the teams problem supports {list(self.evolution_methods)}")
        problem = AllocationProblem(self.n_regions, self.n_species, self.coverage.robots_per_species,
                                    lambda counts: self.objectives_of_counts(task, counts))
        genomes = np.stack(designs).reshape(len(designs), -1)  # (B, K*O)
        if self.evolution.archive and task in self._archive:  # one survival over X_gen and the last X_pop
            merged = np.concatenate([genomes, self._archive[task]])
            genomes, objectives = survivors(merged, np.concatenate([objectives, problem.objectives(
                self._archive[task])]), problem, len(designs), rng)
        for _ in range(steps):
            genomes, objectives = nsga2_generation(genomes, objectives, problem,
                                                   self.evolution.crossover_probability,
                                                   self.evolution.mutation_rate, rng)
        if self.evolution.archive:
            self._archive[task] = genomes
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
        text = json.dumps([asdict(self.coverage), asdict(self.evolution), self.seed, chips, asdict(self.fitness),
                           asdict(self.region_model),
                           code_digest(__name__, exclude=INFRASTRUCTURE)])  # the closure that shapes the fitness
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def state_dict(self) -> dict:
        rows = [[*key, self.cache.get(key)["team_cost"]] for evaluator in self._evaluators.values()
                for key in sorted(evaluator.asked)]
        return {"team_costs": sorted(rows), "team_lookups": self.team_lookups, "calls": self.calls,
                "model": self.model.state_dict(), "prospective": self.prospective,
                "archive": {task: genomes.tolist() for task, genomes in sorted(self._archive.items())}}

    def load_state_dict(self, state: dict) -> None:
        task_of = {chip.chip_id: task for task, (chip, _) in enumerate(self.chips)}
        for *key, cost in state["team_costs"]:
            self.cache.put(tuple(key), team_cost=cost)
            self.evaluator(task_of[key[1]]).asked.add(tuple(key))
        self._resumed_lookups = state["team_lookups"] - sum(e.lookups for e in self._evaluators.values())
        self.calls, self.prospective = state["calls"], state["prospective"]
        self.model.load_state_dict(state["model"])
        self._archive = {int(task): np.asarray(genomes) for task, genomes in state["archive"].items()}

    # ---- fitness from the optimiser, through the team-cost memo ----------------------------------------
    def evaluator(self, task: int) -> AllocationEvaluator:
        """The objectives of training chip `task` (built on first use)."""
        if task not in self._evaluators:
            chip, decomposition = self.chips[task]
            self._evaluators[task] = AllocationEvaluator(chip_coverage(chip, decomposition, self.coverage),
                                                         chip.chip_id, self.seed, self.cache)
        return self._evaluators[task]

    def objectives_of_counts(self, task: int, counts: np.ndarray) -> np.ndarray:
        """(B, 2) [coverage cost, deployment cost] of (B, K, O) counts on training chip `task`: exact, or (model
        source) exact where the team was optimised and the model's elsewhere."""
        if self.fitness.source == "exact":
            return self.evaluator(task)(counts)
        self._warm_up()
        costs = self.evaluator(task).team_costs(counts, lambda teams: self.predict(task, teams))  # (B, K)
        return np.stack([costs.sum(1), deployment_cost(counts).astype(np.float64)], axis=-1)

    # ---- the region-cost model (model source) --------------------------------------------------------------
    def _features(self, rows: Sequence[tuple[int, int, tuple[int, ...]]]) -> tuple[torch.Tensor, torch.Tensor,
                                                                                    torch.Tensor]:
        """Model inputs of (task, region, counts) rows: ((R, R + 5) region vectors, (N,) region index, (N, 2O)
        count features), R = training regions."""
        if self._region_vectors is None:
            vectors = []
            for task, (chip, decomposition) in enumerate(self.chips):
                raster = decomposition.raster(chip.terrain)
                area = np.bincount(raster.ravel(), minlength=self.n_regions) / raster.size  # (K,)
                vectors.append(np.concatenate([self.features[task], area[:, None]], axis=1))  # (K, 5)
            vectors = np.concatenate(vectors)  # (R, 5)
            self._region_vectors = torch.as_tensor(np.concatenate([np.eye(len(vectors)), vectors], axis=1),
                                                   dtype=torch.float32)  # (R, R + 5)
        index = torch.as_tensor([task * self.n_regions + region for task, region, _ in rows], dtype=torch.int64)
        counts = np.asarray([c for _, _, c in rows], dtype=np.float64).reshape(len(rows), self.n_species)
        n = self.coverage.robots_per_species
        design = np.concatenate([counts / n, np.log1p(counts) / np.log1p(n)], axis=1)  # (N, 2O)
        return self._region_vectors, index, torch.as_tensor(design, dtype=torch.float32)

    def predict(self, task: int, teams: Sequence[tuple[int, tuple[int, ...]]]) -> np.ndarray:
        """(N,) model costs of teams (region, counts) of training chip `task`."""
        return np.exp(self.model.predict(*self._features([(task, region, counts) for region, counts in teams])))

    def _exact_rows(self) -> tuple[list[tuple[int, int, tuple[int, ...]]], np.ndarray, np.ndarray]:
        """Every optimised team as (task, region, counts), its log cost and whether it is held out."""
        rows, values, held = [], [], []
        for task in sorted(self._evaluators):
            for key in sorted(self._evaluators[task].asked):
                region, counts = key[0].split(":")
                rows.append((task, int(region), tuple(int(n) for n in counts.split("-"))))
                values.append(np.log(self.cache.get(key)["team_cost"]))
                held.append(int(hashlib.sha1(key[0].encode() + key[1].encode()).hexdigest(), 16)
                            % HOLDOUT_EVERY == 0)
        return rows, np.asarray(values), np.asarray(held, dtype=bool)

    def _fit(self) -> None:
        rows, values, held = self._exact_rows()
        keep = [row for row, h in zip(rows, held, strict=True) if not h]
        self.model.fit(*self._features(keep), values[~held])

    def _warm_up(self) -> None:
        if self.model.net is not None:
            return
        rng = np.random.default_rng([self.fitness.seed, 5201])
        for task in range(len(self.chips)):
            fractions = deployment_share_draws(rng, self.fitness.warmup, self.n_regions, self.n_species)
            self.evaluator(task).team_costs(allocation_to_counts(fractions, self.coverage.robots_per_species))
        self._fit()

    def _real_round(self, task: int, counts: np.ndarray) -> None:
        """Optimise the unknown teams of a batch (within the budget), note the model's error on them, refit."""
        self._warm_up()
        evaluator = self.evaluator(task)
        teams = {(int(i), tuple(int(n) for n in allocation[i])) for allocation in counts
                 for i in np.flatnonzero(allocation.sum(1))}
        new = sorted(team for team in teams if evaluator.key(team) not in self.cache)
        if not new or self.real_evaluations + len(new) > self.fitness.budget:
            return
        predicted = np.log(self.predict(task, new))
        exact = np.log(evaluator.team_costs(np.stack([self._single(team) for team in new]))[
            np.arange(len(new)), [region for region, _ in new]])
        self.prospective += [[float(p), float(e)] for p, e in zip(predicted, exact, strict=True)]
        self._fit()

    def _single(self, team: tuple[int, tuple[int, ...]]) -> np.ndarray:
        """(K, O) counts of an allocation holding only `team`."""
        single = np.zeros((self.n_regions, self.n_species), dtype=np.int64)
        single[team[0]] = team[1]
        return single

    def model_error(self) -> dict[str, float]:
        """The model's error on held-out optimised teams (log-cost RMSE, R^2 of log cost against its mean,
        Spearman, median relative error of the cost) and, prospective_*, on each round's new teams before they
        were fitted; {} for the exact source."""
        if self.fitness.source == "exact" or self.model.net is None:
            return {}
        rows, values, held = self._exact_rows()
        test = [row for row, h in zip(rows, held, strict=True) if h]
        by_task: dict[int, list[int]] = {}
        for k, (task, _, _) in enumerate(test):
            by_task.setdefault(task, []).append(k)
        predicted = np.empty(len(test))
        for task, ks in by_task.items():
            predicted[ks] = np.log(self.predict(task, [(test[k][1], test[k][2]) for k in ks]))
        error = {"model_teams": int((~held).sum()), **_errors("model_heldout", predicted, values[held])}
        if self.prospective:
            pairs = np.asarray(self.prospective)
            error.update(_errors("model_prospective", pairs[:, 0], pairs[:, 1]))
        return error


def _errors(prefix: str, predicted: np.ndarray, exact: np.ndarray) -> dict[str, float]:
    """Errors of predicted against exact log costs."""
    residual = predicted - exact
    return {f"{prefix}_n": int(len(exact)), f"{prefix}_log_rmse": float(np.sqrt(np.mean(residual ** 2))),
            f"{prefix}_log_r2": float(1 - np.mean(residual ** 2) / np.var(exact)),
            f"{prefix}_spearman": spearman(predicted, exact),
            f"{prefix}_median_relative_error": float(np.median(np.abs(np.expm1(residual))))}
