"""The modular-robot problem on the EG-GAN interface (thesis 5.1), with training fitness from exact tables or
from a surrogate trained on real rollouts.

Task: a block terrain, drawn uniformly from the `train_terrains` seeds starting at `train_seed_base` (disjoint
from the test terrains); its tensor is the 50 x 20 height map. Design: a port string; its tensor is the 6 x 4
one-hot matrix over "nlwb"; the generator's output is a row softmax and a design is drawn per row.
Objective: the distance travelled (maximised), under the modular fitness rule.

Fitness during training, `source: table` (the default profile). Every training terrain has an exhaustive table
in the training pool (`pool`: the `modular_pool` stage's tables, from the committed ones under `pool_dir` where
their provenance matches the current settings, rule and physics code): a design's fitness is its table entry,
the simulator's own result. A method's evaluations are its distinct (terrain, design) look-ups of
designs the rule simulates (`real_evaluations`); once `lookups` are made, a call that asks for a new one raises
`BudgetSpent` and the trainer stops. The pool's validation terrains (`validation_seed_base`, disjoint from the
training seeds) are never a training task, read only to draw validation curves (`validation_tasks`).

`source: surrogate`, for a terrain distribution without tables (the paper profile's continuous one): a rollout
costs ~0.6 s, so the problem answers from (1) the fitness rule where it needs no simulation (designs the
original rejected score the penalty), (2) a real rollout of this (terrain, design) if one was made, else (3) a
surrogate `robocompose.eggan.surrogate.Surrogate` fitted on the real rollouts. Real rollouts are spent in two
ways, all through the shared evaluation cache and executor: `warmup` random valid designs on random training
terrains before the first answer (the same draws for every method with the same seed, so they are simulated
once), and every `real_every` evaluate calls the `real_per_round` fittest unknown designs of that batch are
simulated (their real values answer the call) and the surrogate is refitted on everything, until `budget` real
rollouts are spent. Every fifth real rollout is held out of the fit: `surrogate_error()` reports the model's
error on unseen real data, its Spearman within each terrain (the ranking evolution needs) beside the pooled one.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from robocompose.eggan.problem import (
    BudgetSpent,
    Objective,
    Sampled,
    evolve_single_objective,
    one_hot_rows,
    sample_rows,
)
from robocompose.eggan.surrogate import Surrogate, SurrogateConfig, spearman
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io import read_table
from robocompose.io.errors import InputError, check_field
from robocompose.io.provenance import INFRASTRUCTURE, code_digest
from robocompose.modular.evaluate import evaluate_designs
from robocompose.modular.params import ModularParams
from robocompose.modular.plugins.search_problem import ModularProblem
from robocompose.modular.robot import MODULE_LETTERS, N_PORTS, all_designs, design_to_index, parse_design
from robocompose.modular.terrain import GRID_X, GRID_Y, TerrainConfig, generate_terrain, height_map

HOLDOUT_EVERY = 5  # every fifth real rollout is held out of the surrogate's fit
SOURCES = ("table", "surrogate")


@dataclass(frozen=True)
class FitnessConfig:
    """How training fitness is obtained (see the module docstring)."""

    source: str = "table"  # "table": the pool's exhaustive tables; "surrogate": real rollouts + a learned model
    train_seed_base: int = 20_000  # training terrain seeds: base .. base + train_terrains - 1
    train_terrains: int = 40
    pool_dir: str = "measured/modular/pool"  # the pool's committed exhaustive tables (stage modular_pool reads them)
    pool: str = "data/modular/pool.parquet"  # table source: every pool terrain's table (stage modular_pool's output)
    validation_seed_base: int = 20_040  # the pool's validation terrains: base .. base + validation_terrains - 1
    validation_terrains: int = 8
    lookups: int = 20_000  # table source: distinct (terrain, design) look-ups a method may make
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
        check_field(self.source in SOURCES, "fitness.source", f"one of {list(SOURCES)}", self.source)
        for name in ("train_terrains", "validation_terrains", "lookups", "warmup", "warmup_terrains", "budget",
                     "real_every", "real_per_round"):
            value = getattr(self, name)
            check_field(isinstance(value, int) and not isinstance(value, bool) and value >= 1, f"fitness.{name}",
                        "a positive integer", value)
        if self.source == "table" and set(self.train_seeds) & set(self.validation_seeds):
            raise InputError(f"fitness.validation_seed_base ({self.validation_seed_base}): the validation seeds "
                             f"overlap the training seeds {self.train_seed_base}..{self.train_seeds[-1]}")
        if self.warmup > self.budget:
            raise InputError(f"fitness.warmup ({self.warmup}) exceeds fitness.budget ({self.budget})")
        if self.warmup < 2 * HOLDOUT_EVERY:
            raise InputError(f"fitness.warmup: expected >= {2 * HOLDOUT_EVERY} (the surrogate needs data)")

    @property
    def train_seeds(self) -> list[int]:
        return list(range(self.train_seed_base, self.train_seed_base + self.train_terrains))

    @property
    def validation_seeds(self) -> list[int]:
        return list(range(self.validation_seed_base, self.validation_seed_base + self.validation_terrains))


class ModularSearch(ModularProblem):
    """The `robocompose.search` problem of one terrain (genes, mutation, crossover, Hamming distance as the GA
    baselines have them), scored by the EG-GAN problem's training fitness."""

    def __init__(self, owner: ModularEgganProblem, terrain_seed: int):
        super().__init__(terrain_seed, owner.modular.eval, owner.modular.fitness)
        self.owner = owner

    def evaluate(self, designs: Sequence[str]) -> np.ndarray:
        return self.owner.evaluate(self.terrain_seed, designs)[:, 0]


_DESIGNS = np.array(all_designs())  # (4096,) port strings, port 0 the most significant base-4 digit
_PLACE = len(MODULE_LETTERS) ** np.arange(N_PORTS - 1, -1, -1)  # (6,) base-4 place values
_CODE = {design: code for code, design in enumerate(_DESIGNS.tolist())}
_ONE_HOT = one_hot_rows(np.array([design_to_index(d) for d in _DESIGNS]), len(MODULE_LETTERS))  # (4096, 6, 4)
@functools.lru_cache(maxsize=4096)  # ~13 ms a terrain (Poisson-disk sampling in Python): keep recent ones, bounded
def _height_map(seed: int, terrain: TerrainConfig) -> torch.Tensor:
    return torch.from_numpy(height_map(generate_terrain(seed, terrain)))  # (50, 20), shared: never written to


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
        self.real: dict[tuple[int, str], float] = {}  # (terrain seed, design) -> real fitness, in rollout/look-up order
        self.spent = 0  # real rollouts asked for (cache hits included: the budget counts them), or table look-ups
        self.calls = 0  # evaluate calls answered
        self._valid: list[str] | None = None  # the designs the fitness rule simulates (computed once)
        self._tables: dict[int, dict[str, float]] = {}  # table source: terrain seed -> design -> table fitness

    # --- the EG-GAN interface ---

    def sample_task(self, rng: np.random.Generator) -> int:
        return self.fitness.train_seed_base + int(rng.integers(self.fitness.train_terrains))

    def encode_task(self, task: int) -> torch.Tensor:
        return _height_map(int(task), self.modular.eval.terrain)  # (50, 20)

    def design_head(self, logits: torch.Tensor) -> torch.Tensor:
        return torch.softmax(logits, dim=-1)  # (B, 6, 4): a categorical distribution per port

    def sample_designs(self, output: torch.Tensor, generator: torch.Generator | None) -> Sampled:
        picks, log_prob = sample_rows(output, generator)  # (B, 6), (B,)
        return Sampled(self.designs_from_choices(picks.numpy()), one_hot_rows(picks, len(MODULE_LETTERS)),
                       log_prob)

    def design_tensor(self, designs: Sequence[str]) -> torch.Tensor:
        codes = [_CODE[d] if d in _CODE else _CODE[parse_design(d)] for d in designs]  # parse: a clear error
        return _ONE_HOT[codes]  # (B, 6, 4)

    def designs_from_choices(self, choices: np.ndarray) -> list[str]:
        """(B, 6) module indices -> port strings (the code of a design is its index in `all_designs`)."""
        return _DESIGNS[np.asarray(choices, dtype=np.int64) @ _PLACE].tolist()

    def evaluate(self, task: int, designs: Sequence[str]) -> np.ndarray:
        """(B, 1): the rule's penalty, else the table's entry (table source) or a real rollout's fitness if one
        was made, else the surrogate's."""
        if self.fitness.source == "table":
            return self._look_up(task, designs)[:, None]
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
        """Settings, rule, fitness config, evolution rates, code, and (table source) the pool tables' bytes."""
        pool = self._pool_digest() if self.fitness.source == "table" else None
        text = json.dumps({"settings": self.modular.eval.settings_hash(), "rule": asdict(self.modular.fitness),
                           "fitness": asdict(self.fitness), "mutation": self.mutation_rate,
                           "crossover": self.crossover_rate, "code": code_digest(__name__, exclude=INFRASTRUCTURE),
                           "pool": pool},
                          sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def state_dict(self) -> dict:
        return {"real": [[seed, design, value] for (seed, design), value in self.real.items()], "spent": self.spent,
                "calls": self.calls, "surrogate": self.surrogate.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self.real = {(int(seed), design): float(value) for seed, design, value in state["real"]}
        self.spent, self.calls = int(state["spent"]), int(state["calls"])
        self.surrogate.load_state_dict(state["surrogate"])

    # --- exact fitness from the pool's tables ---

    def table(self, terrain_seed: int) -> dict[str, float]:
        """Design -> fitness on a pool terrain, from the pool's tables (`fitness.pool`, read once)."""
        if not self._tables:
            path = Path(self.fitness.pool)
            if not path.is_file():
                raise InputError(f"{path}: no pool tables (run the modular_pool stage: dvc repro modular_pool)")
            pool = read_table(path, "modular_exhaustive")
            for seed, group in pool.groupby("terrain_seed", sort=True):
                self._tables[int(seed)] = dict(zip(group.design, group.fitness.astype(float), strict=True))
        if terrain_seed not in self._tables:
            raise InputError(f"{self.fitness.pool}: no table of pool terrain {terrain_seed} (it holds "
                             f"{sorted(self._tables)}; rerun the modular_pool stage)")
        return self._tables[terrain_seed]

    def validation_tasks(self) -> list[int]:
        """The pool's validation terrains (table source): never trained on."""
        return self.fitness.validation_seeds

    def _look_up(self, task: int, designs: Sequence[str]) -> np.ndarray:
        """Table fitness of designs on a training terrain; new distinct look-ups count against `lookups`."""
        if int(task) not in self.fitness.train_seeds:
            raise InputError(f"terrain {task}: not a training terrain of the pool {self.fitness.train_seeds[0]}.."
                             f"{self.fitness.train_seeds[-1]}")
        table = self.table(int(task))
        new = {d for d in designs if (task, d) not in self.real and not self.modular.fitness.skips(d)}
        if self.spent + len(new) > self.fitness.lookups:
            raise BudgetSpent(f"{self.spent} of {self.fitness.lookups} look-ups made; this call asks {len(new)} more")
        for design in designs:
            if design in new and (task, design) not in self.real:
                self.real[(task, design)] = table[design]
        self.spent += len(new)
        self.calls += 1
        return np.array([table[d] for d in designs])

    def _pool_digest(self) -> str:
        """sha256 of the pool tables' file (a missing file fails when a table is first read)."""
        path = Path(self.fitness.pool)
        return hashlib.sha256(path.read_bytes()).hexdigest()[:16] if path.is_file() else "missing"

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

    def surrogate_error(self) -> dict[str, float] | None:
        """The surrogate's error on the held-out real rollouts: MAE (m), RMSE (m), pooled Spearman, the mean
        Spearman within a terrain (over terrains with >= 3 held-out rollouts; a predictor that knows only each
        terrain's mean scores well pooled and ~0 within), counts. None with the table source (no surrogate)."""
        if self.fitness.source == "table":
            return None
        held = self._split()[1]
        tasks, index, designs, truth = self._tensors(held)
        predicted = self.surrogate.predict(tasks, index, designs)
        seeds = np.array([seed for (seed, _), _ in held])
        within = [spearman(predicted[seeds == s], truth[seeds == s]) for s in np.unique(seeds)
                  if (seeds == s).sum() >= 3 and np.ptp(truth[seeds == s]) > 0]
        return {"heldout": len(held), "mae": float(np.mean(np.abs(predicted - truth))),
                "rmse": float(np.sqrt(np.mean((predicted - truth) ** 2))), "spearman": spearman(predicted, truth),
                "spearman_within_terrain": float(np.mean(within)) if within else float("nan"),
                "terrains_within": len(within), "real_mean": float(truth.mean()), "real_std": float(truth.std())}
