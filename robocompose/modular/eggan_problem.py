"""The modular-robot problem on the EG-GAN interface (thesis 5.1), with a surrogate fitness trained on real
rollouts gathered during training.

Task: a block terrain, drawn uniformly from a pool of `train_terrains` seeds starting at `train_seed_base`
(disjoint from the test terrains); its tensor is the 50 x 20 height map. Design: a port string; its tensor is
the 6 x 4 one-hot matrix over "nlwb"; the generator's output is a row softmax and a design is drawn per row.
Objective: the distance travelled (maximised), under the modular fitness rule.

Fitness during training. A rollout costs ~0.6 s, and an EG-GAN iteration asks for hundreds of fitness values,
so the problem answers from (1) the fitness rule where it needs no simulation (designs the original rejected
score the penalty), (2) a real rollout of this (terrain, design) if one was made, else (3) a surrogate
`robocompose.eggan.surrogate.Surrogate` fitted on the real rollouts. Real rollouts are spent in two ways, all
through the shared evaluation cache and executor: `warmup` random valid designs on random training terrains
before the first answer (the same draws for every method with the same seed, so they are simulated once), and
every `real_every` evaluate calls the `real_per_round` fittest unknown designs of that batch are simulated
(their real values answer the call) and the surrogate is refitted on everything, until `budget` real rollouts
are spent. Any method that asks this problem for fitness (EG-GAN and the learned baselines) spends its
budget the same way. Every fifth
real rollout is held out of the fit, so `surrogate_error()` reports the model's error on unseen real data.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np
import torch

from robocompose.eggan.problem import Objective, Sampled, evolve_single_objective, one_hot_rows, sample_rows
from robocompose.eggan.surrogate import Surrogate, SurrogateConfig, spearman
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io.provenance import code_digest
from robocompose.modular.evaluate import evaluate_designs
from robocompose.modular.params import ModularParams
from robocompose.modular.problem import ModularProblem
from robocompose.modular.robot import MODULE_LETTERS, N_PORTS, all_designs, design_to_index, index_to_design
from robocompose.modular.terrain import GRID_X, GRID_Y, generate_terrain, height_map

HOLDOUT_EVERY = 5  # every fifth real rollout is held out of the surrogate's fit


@dataclass(frozen=True)
class FitnessConfig:
    """How training fitness is obtained (see the module docstring)."""

    train_seed_base: int = 20_000  # training terrain seeds: base .. base + train_terrains - 1
    train_terrains: int = 200
    warmup: int = 240  # real rollouts of random valid designs before training
    warmup_terrains: int = 40  # ... spread over this many training terrains
    budget: int = 400  # real rollouts in all, warm-up included
    real_every: int = 960  # evaluate calls between real rounds (the experiments space them per method's run)
    real_per_round: int = 16  # rollouts per round: the fittest designs of the batch without a real value
    surrogate: SurrogateConfig = field(default_factory=SurrogateConfig)
    seed: int = 0  # seed of the warm-up draws and the surrogate

    def __post_init__(self):
        if isinstance(self.surrogate, dict):
            object.__setattr__(self, "surrogate", SurrogateConfig(**self.surrogate))
        for name in ("train_terrains", "warmup", "warmup_terrains", "budget", "real_every", "real_per_round"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise ValueError(f"fitness.{name}: expected a positive integer, found {getattr(self, name)!r}")
        if self.warmup > self.budget:
            raise ValueError(f"fitness.warmup ({self.warmup}) exceeds fitness.budget ({self.budget})")
        if self.warmup < 2 * HOLDOUT_EVERY:
            raise ValueError(f"fitness.warmup: expected >= {2 * HOLDOUT_EVERY} (the surrogate needs data)")


class ModularSearch(ModularProblem):
    """The `robocompose.search` problem of one terrain (genes, mutation, crossover, Hamming distance as the GA
    baselines have them), scored by the EG-GAN problem's training fitness."""

    def __init__(self, owner: ModularEgganProblem, terrain_seed: int):
        super().__init__(terrain_seed, owner.modular.eval, owner.modular.fitness)
        self.owner = owner

    def evaluate(self, designs: Sequence[str]) -> np.ndarray:
        return self.owner.evaluate(self.terrain_seed, designs)[:, 0]


_MAPS: dict[tuple[int, str], torch.Tensor] = {}  # (terrain seed, terrain config) -> height map, per process


class ModularEgganProblem:
    """Modular robot design for a terrain, as an `EgganProblem` (see the module docstring)."""

    name = "modular"
    task_shape = (GRID_X, GRID_Y)
    design_shape = (N_PORTS, len(MODULE_LETTERS))
    discrete = True
    objectives = (Objective("distance", maximise=True),)
    evolution_methods = ("crowding", "ga")
    # Mirrored port pairs (front-left/front-right, mid-left/mid-right, back-left/back-right): a sequential
    # designer (Whitman's DQN) makes one module choice per pair, so its designs are left-right symmetric.
    decision_groups = ((0, 5), (1, 4), (2, 3))

    def __init__(self, modular: ModularParams, fitness: FitnessConfig, cache: EvaluationCache | None = None,
                 executor: Executor | None = None, mutation_rate: float = 1 / 6, crossover_rate: float = 0.9):
        self.modular, self.fitness = modular, fitness
        self.cache, self.executor = cache, executor
        self.mutation_rate, self.crossover_rate = mutation_rate, crossover_rate
        self.surrogate = Surrogate(self.task_shape, self.design_shape, fitness.surrogate, fitness.seed)
        self.real: dict[tuple[int, str], float] = {}  # (terrain seed, design) -> real fitness, in rollout order
        self.spent = 0  # real rollouts asked for (cache hits included: the budget counts them)
        self.calls = 0  # evaluate calls answered
        self._valid: list[str] | None = None  # the designs the fitness rule simulates (computed once)

    # --- the EG-GAN interface ---

    def sample_task(self, rng: np.random.Generator) -> int:
        return self.fitness.train_seed_base + int(rng.integers(self.fitness.train_terrains))

    def encode_task(self, task: int) -> torch.Tensor:
        key = (int(task), json.dumps(asdict(self.modular.eval.terrain), sort_keys=True))
        if key not in _MAPS:  # ~70 ms per terrain (Poisson-disk sampling in Python): keep them
            _MAPS[key] = torch.from_numpy(height_map(generate_terrain(int(task), self.modular.eval.terrain)))
        return _MAPS[key]  # (50, 20)

    def design_head(self, logits: torch.Tensor) -> torch.Tensor:
        return torch.softmax(logits, dim=-1)  # (B, 6, 4): a categorical distribution per port

    def sample_designs(self, output: torch.Tensor, generator: torch.Generator | None) -> Sampled:
        picks, log_prob = sample_rows(output, generator)  # (B, 6), (B,)
        return Sampled(self.designs_from_choices(picks.numpy()), one_hot_rows(picks, len(MODULE_LETTERS)),
                       log_prob)

    def design_tensor(self, designs: Sequence[str]) -> torch.Tensor:
        return one_hot_rows(np.array([design_to_index(d) for d in designs]).reshape(-1, N_PORTS),
                            len(MODULE_LETTERS))

    def designs_from_choices(self, choices: np.ndarray) -> list[str]:
        return [index_to_design(row) for row in np.asarray(choices)]  # (B, 6) module indices -> port strings

    def evaluate(self, task: int, designs: Sequence[str]) -> np.ndarray:
        """(B, 1): the rule's penalty, else a real rollout's fitness if one was made, else the surrogate's."""
        self._warm_up()
        values = np.empty(len(designs))
        unknown = []
        for i, design in enumerate(designs):
            if self.modular.fitness.skips(design):
                values[i] = self.modular.fitness.penalty
            elif (task, design) in self.real:
                values[i] = self.real[(task, design)]
            else:
                unknown.append(i)
        if unknown:
            values[unknown] = self.surrogate.predict(self.encode_task(task).unsqueeze(0),
                                                     torch.zeros(len(unknown), dtype=torch.int64),
                                                     self.design_tensor([designs[i] for i in unknown]))
        self.calls += 1
        if self.calls % self.fitness.real_every == 0:
            values = self._real_round(task, list(designs), values)
        return values[:, None]

    def evolve(self, task: int, designs: list[str], objectives: np.ndarray, method: str, steps: int,
               rng: np.random.Generator) -> tuple[list[str], np.ndarray]:
        population, fitness = evolve_single_objective(ModularSearch(self, task), designs, objectives[:, 0], method,
                                                      steps, rng, self.crossover_rate, self.mutation_rate)
        return population, fitness[:, None]

    def random_designs(self, rng: np.random.Generator, n: int) -> list[str]:
        valid = self._valid_designs()
        return [valid[i] for i in rng.integers(len(valid), size=n)]

    def design_id(self, design: str) -> str:
        return design

    @property
    def real_evaluations(self) -> int:
        return self.spent

    def key(self) -> str:
        text = json.dumps({"settings": self.modular.eval.settings_hash(), "rule": asdict(self.modular.fitness),
                           "fitness": asdict(self.fitness), "mutation": self.mutation_rate,
                           "crossover": self.crossover_rate, "code": code_digest(__name__)}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def state_dict(self) -> dict:
        return {"real": [[seed, design, value] for (seed, design), value in self.real.items()], "spent": self.spent,
                "calls": self.calls, "surrogate": self.surrogate.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self.real = {(int(seed), design): float(value) for seed, design, value in state["real"]}
        self.spent, self.calls = int(state["spent"]), int(state["calls"])
        self.surrogate.load_state_dict(state["surrogate"])

    # --- real rollouts and the surrogate ---

    def simulate(self, terrain_seed: int, designs: Sequence[str]) -> np.ndarray:
        """Real fitness of designs on one terrain (cache, executor), recorded and counted against the budget."""
        results = evaluate_designs(list(designs), terrain_seed, self.modular.eval, self.modular.fitness, self.cache,
                                   self.executor)
        values = np.array([self.modular.fitness.fitness(r) for r in results])
        for design, value in zip(designs, values, strict=True):
            self.real.setdefault((terrain_seed, design), float(value))
        self.spent += len(designs)
        return values

    def _valid_designs(self) -> list[str]:
        """The designs the fitness rule simulates (not scored by the penalty), in `all_designs` order."""
        if self._valid is None:
            self._valid = [d for d in all_designs() if not self.modular.fitness.skips(d)]
        return self._valid

    def _warm_up(self) -> None:
        if self.real:
            return
        f = self.fitness
        rng = np.random.default_rng([f.seed, 3301])
        valid = self._valid_designs()
        terrains = f.train_seed_base + rng.choice(f.train_terrains, size=f.warmup_terrains, replace=False)
        picks = rng.choice(len(valid), size=f.warmup, replace=f.warmup > len(valid))
        for k, terrain_seed in enumerate(terrains):
            chosen = [valid[i] for i in picks[k::f.warmup_terrains]]
            self.simulate(int(terrain_seed), list(dict.fromkeys(chosen)))
        self._fit()

    def _real_round(self, task: int, population: list[str], fitness: np.ndarray) -> np.ndarray:
        """Simulate the fittest designs of a batch that have no real value yet; refit; the batch's new values."""
        room = self.fitness.budget - self.spent
        if room <= 0:
            return fitness
        order = np.argsort(-fitness, kind="stable")
        chosen: list[str] = []
        for k in order:
            design = population[k]
            if (task, design) not in self.real and not self.modular.fitness.skips(design) and design not in chosen:
                chosen.append(design)
            if len(chosen) == min(self.fitness.real_per_round, room):
                break
        if not chosen:
            return fitness
        real = dict(zip(chosen, self.simulate(task, chosen), strict=True))
        self._fit()
        return np.array([real.get(d, v) for d, v in zip(population, fitness, strict=True)])

    def _split(self) -> tuple[list, list]:
        items = list(self.real.items())
        train = [item for i, item in enumerate(items) if i % HOLDOUT_EVERY != HOLDOUT_EVERY - 1]
        held = [item for i, item in enumerate(items) if i % HOLDOUT_EVERY == HOLDOUT_EVERY - 1]
        return train, held

    def _tensors(self, items: list) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, np.ndarray]:
        """Surrogate data: distinct tasks (U, 50, 20), task index (N,), designs (N, 6, 4), values (N,)."""
        seeds = sorted({seed for (seed, _), _ in items})
        where = {seed: i for i, seed in enumerate(seeds)}
        tasks = torch.stack([self.encode_task(seed) for seed in seeds])
        index = torch.tensor([where[seed] for (seed, _), _ in items], dtype=torch.int64)
        designs = self.design_tensor([design for (_, design), _ in items])
        return tasks, index, designs, np.array([value for _, value in items])

    def _fit(self) -> None:
        self.surrogate.fit(*self._tensors(self._split()[0]))

    def surrogate_error(self) -> dict[str, float]:
        """The surrogate's error on the held-out real rollouts: MAE (m), RMSE (m), Spearman, count."""
        held = self._split()[1]
        tasks, index, designs, truth = self._tensors(held)
        predicted = self.surrogate.predict(tasks, index, designs)
        return {"heldout": len(held), "mae": float(np.mean(np.abs(predicted - truth))),
                "rmse": float(np.sqrt(np.mean((predicted - truth) ** 2))), "spearman": spearman(predicted, truth),
                "real_mean": float(truth.mean()), "real_std": float(truth.std())}
