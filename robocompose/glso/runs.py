"""GLSO search runs: the registered methods on one objective and one budget; runs as step tables; resumable;
fanned out.

    from robocompose.glso.runs import GLSOConfig, RunSpec, run_search, run_all
    steps = run_search(RunSpec("flat", "glso", seed=0), config, evaluation)     # one run -> step table
    steps, seconds = run_all(config, evaluation, Path("data/glso"), executor, cache_file)   # every run

The accounting rule, one for every method: a run is `budget` calls of the objective, and a call is every
design sent to the evaluator: one MPPI episode of a complete design, or the evaluator's verdict that it
cannot be simulated (self-penetrating at rest, or an episode that blew up), which costs the call and is
told to the method as its original's invalid score (`registry.Method.invalid_score`: GLSO's 3.8 / 4.0,
RoboGrammar's -2.0 for the others). A design a method discards before sending it (its own pre-filters: the
grammar methods' depth limit and self-penetration check, random search's dataset filters, the GA's
self-penetration check; GLSO has none) costs no call and is counted in the step's `rejected`. Every method
gets the same budget, the same evaluator settings and the same controller seed (`evaluation.seed`); a
design seen again in a run costs a call and returns its cached score (evaluations are deterministic).
`best_so_far` is the best reward of a simulated design so far (NaN before the first): an invalid score
never counts as a result.

The evaluator: `run_search`, `run_all` and `record_best` score with the `evaluation` they are given. For the
`glso:` section's runs (the stage, `robocompose glso`) that is `GLSOConfig.evaluator`: the `evaluation:`
section at `glso.rung`'s MPPI settings when a rung is named (the default profile's smoke run: a cheap ladder
rung), else as it is. The campaign and the fidelity searches hand in their own rung's evaluator and ignore
`glso.rung`.

Methods: `registry.METHODS` names them; each is a `method.SearchMethod` with its settings in `glso.<section>`.

Resumption: after every call the run's rows (plain data, JSON) are written atomically to the checkpoint
(`robocompose.io.checkpoint`), then its step table. The method object (its RNG, search tree, network,
optimiser) is not saved: objects of other libraries could only be stored by pickle, and unpickling a file a
user can name or hand over runs whatever code it says. A resumed run rebuilds it by replay instead: a fresh
method (`make_method`) proposes each recorded step again, must propose the recorded design, and is told the
recorded score, without a call to the objective. Every method draws from generators of its own, seeded by
the run, so after the replay it is in the state it had when the checkpoint was written, and a run killed at
any point ends with the same table as an uninterrupted run. Replaying costs the method's own work again
(GP fits, network steps), not the simulations. The tables hold no wall times (`run_job` returns a run's
seconds; the stage keeps them in reports/timings.json). The checkpoint key covers the run, the budget, the
method's settings, the settings hash of the evaluator the run uses (its MPPI: a checkpoint written at one rung
is never resumed at another), the VAE file and the code; the stage starts a stale checkpoint (or one whose
replay proposes other designs) over with one warning line, a checkpoint file the user names (`robocompose
glso --checkpoint`) must hold this run or be new.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robocompose.evaluation.evaluate import OK, EvalJob, EvaluationConfig, cached_evaluations, objective
from robocompose.evaluation.fidelity import LADDER, rung_config
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.glso import best_designs
from robocompose.glso.method import Proposal, SearchEnv, SearchMethod
from robocompose.glso.registry import METHODS, settings_sections
from robocompose.grammar.tree import DesignTree
from robocompose.io import get_schema, read_table, write_table
from robocompose.io.checkpoint import load_checkpoint, save_checkpoint
from robocompose.io.errors import ArtifactError, InputError, check_field
from robocompose.io.provenance import INFRASTRUCTURE, code_digest
from robocompose.params import build_config
from robocompose.tasks.terrains import TASKS, get_task


@dataclass(frozen=True)
class RunSettings:
    """The `glso:` section of params.yaml but for the methods' own sections (`GLSOConfig` adds those)."""

    tasks: list = field(default_factory=lambda: list(TASKS))
    methods: list = field(default_factory=lambda: [name for name, method in METHODS.items() if method.groups])
    # (the thesis's methods: those of its figures; GLSO's variants run in the pilot)
    seeds: list = field(default_factory=lambda: [0, 1, 2])  # run seeds (thesis: 3)
    budget: int = 550  # objective calls per run (GLSO: 50 random + 500 BO steps)
    models: str = "models/vae_{variant}.pt"  # where the VAE of each latent method is ({variant}: full, ...)
    thesis_models: str = "measured/vae_thesis/vae_{variant}.pt"  # ... of a method on the thesis-scale VAE
    # The fidelity rung (`evaluation.fidelity.LADDER`) whose MPPI settings score the runs' designs and replay the
    # best ones (`evaluator`); "" = the evaluator's own `evaluation.mppi`. A cheap rung suits a smoke run that only
    # checks every method runs end to end.
    rung: str = ""

    def __post_init__(self) -> None:
        for section, cls in settings_sections().items():
            if isinstance(getattr(self, section), dict):
                object.__setattr__(self, section, build_config(cls, getattr(self, section), "glso." + section))
        unknown = [m for m in self.methods if m not in METHODS]
        check_field(not unknown, "methods", f"some of {list(METHODS)}", unknown[:1])
        for task in self.tasks:
            get_task(task)
        check_field(1 <= self.budget <= MAX_BUDGET, "budget", f"1 .. {MAX_BUDGET} objective calls", self.budget)
        check_field(bool(self.seeds), "seeds", "at least one run seed", self.seeds)
        check_field("{variant}" in self.models, "models", "a path with {variant} in it", self.models)
        check_field("{variant}" in self.thesis_models, "thesis_models", "a path with {variant} in it",
                    self.thesis_models)
        check_field(self.rung == "" or self.rung in LADDER, "rung",
                    f'"" (the evaluator\'s evaluation.mppi) or a fidelity rung of {list(LADDER)}', self.rung)

    def evaluator(self, evaluation: EvaluationConfig) -> EvaluationConfig:
        """The evaluator of the runs: `evaluation` (the `evaluation:` section) with `rung`'s MPPI settings, or as
        it is if `rung` is "". Its settings hash is in every run's checkpoint key."""
        return dataclasses.replace(evaluation, mppi=rung_config(self.rung)) if self.rung else evaluation

    def model_path(self, method: str) -> Path | None:
        """The VAE file a method searches (None for a method without one)."""
        return METHODS[method].model_path(self.thesis_models if METHODS[method].thesis_vae else self.models)

    def settings(self, method: str) -> Any:
        """A method's settings (its section's dataclass)."""
        return getattr(self, METHODS[method].section)


# The `glso:` section of params.yaml: RunSettings and one field per registered method section (`bo`, `ga`, ...:
# that section's dataclass, made from its mapping in params.yaml), so that a new method needs no edit here.
GLSOConfig = dataclasses.make_dataclass(
    "GLSOConfig", [(section, cls, field(default_factory=cls)) for section, cls in settings_sections().items()],
    bases=(RunSettings,), frozen=True,
    namespace={"__module__": __name__, "__doc__": "The `glso:` section of params.yaml."})


@dataclass(frozen=True)
class RunSpec:
    task: str
    method: str
    seed: int

    @property
    def name(self) -> str:
        return f"{self.task}_{self.method}_seed{self.seed}"


def make_method(spec: RunSpec, config: GLSOConfig, env: SearchEnv) -> SearchMethod:
    """The method object of a run, fresh: every random stream from the run's seed, so that replaying a
    checkpoint's steps brings it back to the state it had when the checkpoint was written."""
    return METHODS[spec.method].cls(config.settings(spec.method), spec.seed, config.budget, env)


FRESH_SEEDS = 1_000_000  # first controller seed of the thesis protocol's calls: far from every other seed in use
MAX_BUDGET = 10_000  # calls per run (the thesis protocol gives each run seed 10,000 controller seeds)


def call_seeds(spec: RunSpec, evaluation: EvaluationConfig, first_step: int = 0) -> Iterator[int]:
    """The controller seed of each call of a run from step `first_step` on: `evaluation.seed` for every method
    (a repeat is served from the cache), but for a method of the original's protocol (`Method.fresh_seeds`) seed
    FRESH_SEEDS + MAX_BUDGET x run seed + step, one of its own per call, as run_bo.py draws an opt_seed per call
    (there unseeded), so a repeat is simulated again. Never a held-out or re-score seed (those are < 1e6)."""
    if not METHODS[spec.method].fresh_seeds:
        return itertools.repeat(evaluation.seed)
    return itertools.count(FRESH_SEEDS + MAX_BUDGET * spec.seed + first_step)


class Objective:
    """The one objective of every method: one MPPI episode on the task through the evaluation cache, at the
    controller seeds `seeds` yields, one per call (default: `evaluation.seed` for every call)."""

    def __init__(self, task: str, evaluation: EvaluationConfig, cache: EvaluationCache | None = None,
                 seeds: Iterator[int] | None = None):
        self.task, self.evaluation = task, evaluation
        self.cache = EvaluationCache() if cache is None else cache
        self.seeds = itertools.repeat(evaluation.seed) if seeds is None else seeds

    def __call__(self, tree: DesignTree) -> dict:
        """The evaluator's row {reward, status, sim_steps, seconds, ...} of `tree` at the next seed (cached if
        known; a new result is saved to the cache at once)."""
        seed = next(self.seeds)
        evaluation = dataclasses.replace(self.evaluation, seed=seed)
        return cached_evaluations([EvalJob(tree, self.task, evaluation, seed)], self.cache)[0]


def run_key(spec: RunSpec, config: GLSOConfig, evaluation: EvaluationConfig, model_path: Path | None) -> str:
    """What a checkpoint must match to be resumed."""
    model = hashlib.sha256(model_path.read_bytes()).hexdigest()[:16] if model_path else None
    text = json.dumps([dataclasses.asdict(spec), config.budget, dataclasses.asdict(config.settings(spec.method)),
                       evaluation.settings_hash(spec.task), evaluation.seed, model,
                       code_digest("robocompose.glso.runs", exclude=INFRASTRUCTURE)],
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def step_row(spec: RunSpec, step: int, proposal: Proposal, result: dict, score: float, repeat: bool,
             best: float) -> dict:
    """One row of a `glso_steps` table."""
    from robocompose.latent.constraints import grammar_rules, is_derivable

    tree = proposal.tree
    rules = proposal.rules if proposal.rules is not None else (grammar_rules(tree) if is_derivable(tree) else ())
    return {"step": step, "method": spec.method, "task": spec.task, "seed": spec.seed,
            "design_id": tree.design_id, "rules": list(rules), "parents": list(tree.parents),
            "tokens": list(tree.tokens), "latent": [] if proposal.z is None else proposal.z.tolist(),
            "score": score, "reward": result["reward"], "status": result["status"], "repeat": repeat,
            "rejected": int(proposal.rejected), "best_so_far": best}


class ReplayMismatch(Exception):
    """A checkpoint's rows that the run's method does not reproduce: the message says at which step."""


def replay(method: SearchMethod, rows: Any, env: SearchEnv, budget: int) -> list[dict]:
    """Bring a fresh `method` to the state after the checkpoint's `rows` (a run's step rows, as loaded) by
    proposing each step again and telling it the recorded score; the rows. ReplayMismatch if they are not
    step rows of at most `budget` steps or the method proposes another design than a step recorded (the
    checkpoint was written by other code, or by hand).

    The design is compared, not every bit of the step (a latent point's last digits may differ on another
    CPU): a run resumed elsewhere continues that machine's search from the recorded history."""
    if not isinstance(rows, list) or len(rows) > budget:
        raise ReplayMismatch(f"not a list of at most {budget} step rows")
    columns = set(get_schema("glso_steps").names)  # the values' types are checked when the table is written
    for step, row in enumerate(rows):
        score = row.get("score") if isinstance(row, dict) else None
        if not (isinstance(row, dict) and set(row) == columns and row["step"] == step
                and isinstance(row["design_id"], str) and isinstance(score, (int, float))
                and not isinstance(score, bool) and math.isfinite(score)):  # as every score told in a run
            raise ReplayMismatch(f"step {step} is not a step row of this run")
        proposal = method.propose(env)
        if proposal.tree.design_id != row["design_id"]:
            raise ReplayMismatch(f"step {step} recorded design {row['design_id']}, replaying it proposes "
                                 f"{proposal.tree.design_id} (the checkpoint does not match this code or run)")
        method.tell(proposal, score)
    return rows


def run_search(spec: RunSpec, config: GLSOConfig, evaluation: EvaluationConfig,
               objective_fn: Callable[[DesignTree], dict] | None = None, checkpoint: Path | None = None,
               table: Path | None = None, on_step: Callable[[dict], None] | None = None,
               model_path: Path | None = None, named_checkpoint: bool = False,
               cache: EvaluationCache | None = None) -> pd.DataFrame:
    """One run of `config.budget` objective calls: its step table (resumed from `checkpoint` if it matches).

    `evaluation` is the run's evaluator as given (`config.rung` is not read here: `GLSOConfig.evaluator` applies
    it for the `glso:` section's runs). `objective_fn(tree)` returns an evaluator row {reward, status, ...}
    (default: the real evaluator through `cache`, memory only if None); `on_step(row)` sees each new row after it
    is checkpointed; `model_path` overrides the latent method's VAE file. `named_checkpoint`: the user named
    `checkpoint`, so a file there that is not this run's checkpoint is an InputError (else it is started over
    with a warning).
    """
    import torch
    from threadpoolctl import threadpool_limits

    # One thread for torch and BLAS: the networks and the GP are small, runs go in parallel, and the
    # results do not depend on how many cores a worker happens to get.
    torch.set_num_threads(1)
    threadpool_limits(1)
    check_field(spec.method in METHODS, "method", f"one of {list(METHODS)}", spec.method)
    init = getattr(config.settings(spec.method), "init", None)
    if METHODS[spec.method].variant is not None and init is not None and init >= config.budget:
        warnings.warn(f"glso: {spec.method} has init {init} >= budget {config.budget}: every call is a random "
                      "latent point, no BO step is taken", stacklevel=2)
    model_path = model_path or config.model_path(spec.method)
    env = SearchEnv(get_task(spec.task).name)
    if model_path is not None:
        from robocompose.latent.train import load_model

        env.model = load_model(model_path)
    key = run_key(spec, config, evaluation, model_path)
    saved = load_checkpoint(checkpoint, key, named=named_checkpoint)
    method, rows = make_method(spec, config, env), []
    if saved is not None:
        try:
            rows = replay(method, saved, env, config.budget)
        except ReplayMismatch as mismatch:
            if named_checkpoint:
                raise InputError(f"{checkpoint}: {mismatch}; name a checkpoint of this run or a new file") from None
            warnings.warn(f"{checkpoint}: {mismatch}: starting afresh", stacklevel=2)
            method = make_method(spec, config, env)  # the replay left the first one part-way
    if objective_fn is None:
        objective_fn = Objective(env.task, evaluation, cache, call_seeds(spec, evaluation, len(rows)))
    seen = {row["design_id"] for row in rows}
    best = rows[-1]["best_so_far"] if rows else np.nan
    invalid = METHODS[spec.method].invalid_score
    for step in range(len(rows), config.budget):
        proposal = method.propose(env)
        result = objective_fn(proposal.tree)
        score = objective(result, invalid)
        method.tell(proposal, score)
        if result["status"] == OK:
            best = float(np.fmax(best, result["reward"]))
        repeat = proposal.tree.design_id in seen
        seen.add(proposal.tree.design_id)
        rows.append(step_row(spec, step, proposal, result, score, repeat, best))
        if checkpoint is not None:
            save_checkpoint(checkpoint, key, rows, kind="json")
        if table is not None:
            write_table(pd.DataFrame(rows), table, "glso_steps")
        if on_step is not None:
            on_step(rows[-1])
    frame = pd.DataFrame(rows)
    if table is not None:
        write_table(frame, table, "glso_steps")
    return frame


@dataclass(frozen=True)
class RunJob:
    """One run as a picklable work item for the Executor."""

    spec: RunSpec
    config: GLSOConfig
    evaluation: EvaluationConfig
    out_dir: str
    cache: str = ""  # the shared evaluation cache's file ("" = memory only)


def run_job(job: RunJob) -> tuple[str, float]:
    """(the run's step table, the seconds this process spent on it: a resumed run counts only its new steps)."""
    out = Path(job.out_dir)
    table = out / "runs" / f"{job.spec.name}.parquet"
    started = time.perf_counter()
    run_search(job.spec, job.config, job.evaluation, checkpoint=out / "checkpoints" / f"{job.spec.name}.ckpt",
               table=table, cache=EvaluationCache(job.cache or None))
    return str(table), time.perf_counter() - started


def run_specs(config: GLSOConfig) -> list[RunSpec]:
    return [RunSpec(task, method, seed) for task in config.tasks for method in config.methods for seed in config.seeds]


def run_all(config: GLSOConfig, evaluation: EvaluationConfig, out_dir: Path, executor: Executor | None = None,
            cache: str = "") -> tuple[pd.DataFrame, dict[str, float]]:
    """Every (task, method, seed) run, fanned out over `executor`, scored by `evaluation` (`config.evaluator`'s)
    through the cache file `cache`: all step tables, concatenated in run order, and each run's wall seconds by run
    name (reports/timings.json)."""
    from tqdm import tqdm

    for method in config.methods:
        path = config.model_path(method)
        if path is not None and not path.exists():
            raise ArtifactError(f"{path}: the VAE of method {method} is missing (dvc repro train_vae)")
    jobs = [RunJob(spec, config, evaluation, str(out_dir), cache) for spec in run_specs(config)]
    executor = executor or Executor(workers=1)
    done = list(tqdm(executor.imap(run_job, jobs), total=len(jobs), desc="glso runs", unit="run"))
    steps = pd.concat([read_table(table, "glso_steps") for table, _ in done], ignore_index=True)
    return steps, {job.spec.name: round(seconds, 1) for job, (_, seconds) in zip(jobs, done, strict=True)}


def summarise(steps: pd.DataFrame) -> dict:
    """Final best per (task, method) as mean, min and max over seeds, with the seed count and budget."""
    final = steps.sort_values("step").groupby(["task", "method", "seed"], sort=False)["best_so_far"].last()
    out: dict[str, dict] = {}
    for (task, method), values in final.groupby(level=[0, 1], sort=False):
        out.setdefault(task, {})[method] = {
            "mean": round(float(values.mean()), 4), "min": round(float(values.min()), 4),
            "max": round(float(values.max()), 4), "seeds": int(len(values)),
            "budget": int(steps[(steps.task == task) & (steps.method == method)]["step"].max() + 1)}
    return out


def record_best(steps: pd.DataFrame, evaluation: EvaluationConfig, out_dir: Path,
                executor: Executor | None = None, gif_size: tuple[int, int] = (320, 240)) -> pd.DataFrame:
    """Replay each task's best design at `evaluation` (the evaluator its run used) into out_dir/<task>.mcap and
    .gif; the rows replayed."""
    from robocompose.evaluation.evaluate import EvalJob
    from robocompose.evaluation.references import record_rollout

    best = best_designs(steps)
    jobs = [(EvalJob(DesignTree(tuple(row.parents), tuple(row.tokens)), row.task, evaluation, evaluation.seed),
             gif_size) for row in best.itertuples()]
    for row, (replay, recorder) in zip(best.itertuples(), (executor or Executor(workers=1)).map(record_rollout, jobs),
                                       strict=True):
        if replay["reward"] != row.reward:
            raise RuntimeError(f"glso: the best design of {row.task} replayed to {replay['reward']}, its run scored "
                               f"{row.reward} (the simulation is not deterministic here)")
        recorder.write_mcap(out_dir / f"{row.task}.mcap")
        recorder.write_gif(out_dir / f"{row.task}.gif")
    return best
