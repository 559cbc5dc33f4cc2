"""EG-GAN on modular robots: training its variants and the learned baselines, and the methods of Table 5.1.

Training (`train_variant`, `train_baseline`): Algorithm 1 on `ModularEgganProblem` with the variant's evolution
(its registry entry's: crowding for EG-GAN-crowding, ga for EG-GAN), resumable from its checkpoint, or a learned
baseline's own trainer, all on the same problem and budget; with the table source each learner's score on the
pool's validation terrains (`validation_scores`) goes into its log and metrics, its score on the training terrains
(`training_scores`) into its metrics. A model is saved with its params, metrics and provenance.

Table 5.1's methods (`realtime_methods`, `realtime_proposers`): the learned ones from their model files, the diverse
query of EG-GAN-crowding's generator (`DIVERSE`: candidates pairwise at Hamming distance >= the protocol's
`diverse_hamming`, `robocompose.modular.diverse`), random sampling and the rows from tables
(`robocompose.modular.experiments.protocol`, which runs the test protocol; the predict rows, which read the
terrain but learn nothing beyond the pool's tables: `robocompose.modular.experiments.table_designs`, imported by
the stage alone so that the learners' code deps stay as they were). The learned rows (`learned_methods`)
are answered again by each further training seed's models (`seeded_realtime_table`; the folders `train_seed` fills,
checked by `robocompose.modular.experiments.training_seeds`).
Every learned row is an entry of `robocompose.eggan.learners.LEARNERS["modular"]`, the only list of them: its title and
whether it trained are written beside its results (`method_info`) for the report.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

import pandas as pd

# The learners this module trains and loads through the registry, which names their modules without importing them:
# imported here so that this module's import closure (its stages' code deps) holds their code. A test checks the list
# against the registry (`robocompose.eggan.learners.ref_modules("modular")`).
from robocompose.eggan import dqn, fit2form, molgan  # noqa: F401
from robocompose.eggan.learners import LEARNERS, Answer, baselines, generator_answer, training_order, variants
from robocompose.eggan.query import save_generator
from robocompose.eggan.selection import ModelSelection
from robocompose.eggan.train import train
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.diverse import diverse_answer
from robocompose.modular.eggan_params import EgganModularParams, network_of
from robocompose.modular.experiments.protocol import (
    Proposer,
    TableAnswers,
    random_proposer,
    realtime_table,
    table_proposers,
    training_scores,
    validation_scores,
    with_optimum,
)
from robocompose.modular.params import ModularParams
from robocompose.modular.plugins.eggan_problem import ModularEgganProblem
from robocompose.params import build_config


def make_problem(modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
                 executor: Executor | None, evaluate_calls: int | None = None) -> ModularEgganProblem:
    """The training problem. `evaluate_calls` (surrogate source): how many evaluate calls the method's run makes;
    the real rounds are then spaced so that every method spends the same budget evenly over its run (the default
    spacing otherwise). With the table source every method has the same budget of distinct look-ups instead."""
    fitness = params.fitness
    if evaluate_calls is not None and fitness.source == "surrogate":
        rounds = max(1, math.ceil((fitness.budget - fitness.warmup) / fitness.real_per_round))
        fitness = dataclasses.replace(fitness, real_every=max(1, evaluate_calls // rounds))
    return ModularEgganProblem(modular, fitness, cache, executor, modular.experiments.mutation_rate,
                               modular.experiments.crossover_rate)


def train_variant(variant: str, modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
                  executor: Executor | None, out: Path, progress: bool = False,
                  plots: Path = Path("reports/plots")) -> dict:
    """Train one EG-GAN variant; writes out/eggan_modular_VARIANT.{pt,json,mcap}, its checkpoint and its curve
    plots/eggan_modular_VARIANT.csv; returns its metrics (no wall times: they go to reports/timings.json, so that
    the files stay byte-reproducible). With `train.best_by` the saved generator is the best-validated one: the
    metrics give its iteration (`best_iteration`) and log row (`best`) beside the last row (`final`)."""
    known = variants("modular")
    if variant not in known:
        raise ValueError(f"variant {variant!r}: expected one of {sorted(known)}")
    learner = known[variant]
    config = training_config(variant, params)
    # per iteration and task: X_gen, then one batch per crowding step / GA generation
    problem = make_problem(modular, params, cache, executor,
                           config.iterations * config.tasks * (1 + config.evolution_steps))
    name = f"eggan_modular_{variant}"
    validate = None
    if problem.fitness.source == "table":
        def validate(generator):
            return validation_scores(problem, generator_answer(generator, params.protocol.samples),
                                     params.protocol.candidates)
    trained = train(problem, network_of(variant, params), config, out / "checkpoints" / f"{name}.pt",
                    plots / f"{name}.csv", out / f"{name}.mcap", progress=progress, validate=validate)
    best = {} if trained.best_iteration is None else {
        "best_iteration": trained.best_iteration,
        "best": next(row for row in trained.rows if row["iteration"] == trained.best_iteration)}
    metrics = {"method": learner.title, **_common_metrics(problem, config.iterations, trained.rows), **best,
               **_training_fit(problem, generator_answer(trained.generator, params.protocol.samples), params),
               "batch": config.batch, "tasks_per_iteration": config.tasks, "evolution": learner.evolution,
               "evolution_steps": config.evolution_steps}
    save_generator(trained.generator, problem, out / f"{name}.pt",
                   {"run_key": trained.key, "settings_hash": modular.eval.settings_hash(),
                    "train": dataclasses.asdict(config), "metrics": metrics})
    return metrics


# the rows that predict the test terrain's row of the table from its height map and the pool's tables (no training:
# `table_designs.predict_proposers`, which the stage builds and `realtime_proposers` is given)
PREDICT = ("predict_knn", "predict_ridge")


def realtime_methods() -> tuple[str, ...]:
    """Table 5.1's rows, in its order: the learned baselines, random sampling, EG-GAN's variants; ours beside them,
    read from tables: the terrain-agnostic portfolios, top-k and greedy (after random sampling), the terrain-reading
    predictions of the table, k-NN and ridge (after the portfolios: the predictability ceiling given the pool), the
    diverse query of a registered variant's generator (after the variants) and the oracle (last). Read from the
    registry at each call, so that a learner registered at run time (a test's) is a row."""
    learned = variants("modular")
    diverse = [row for row, of in DIVERSE.items() if of in learned]
    return (*baselines("modular"), "random", "portfolio", "portfolio_greedy", *PREDICT, *learned, *diverse,
            "optimum")


# the diverse query's rows -> the EG-GAN variant whose trained generator answers them (the same model file)
DIVERSE = {"crowding_diverse": "crowding"}


UNLEARNED = {"random": "Random sampling", "portfolio": "Portfolio (terrain-agnostic baseline)",
             "portfolio_greedy": "Portfolio, greedy (terrain-agnostic)",
             "predict_knn": "Predict the table, k-NN", "predict_ridge": "Predict the table, ridge",
             "crowding_diverse": "EG-GAN-crowding, diverse query",
             "optimum": "Exhaustive optimum (oracle)"}  # the rows no learner answers -> their titles


def method_title(method: str) -> str:
    """The name of a row of Table 5.1 (the thesis's, where it has the row); KeyError for no row."""
    return UNLEARNED[method] if method in UNLEARNED else LEARNERS["modular"][method].title


def method_info(method: str) -> dict:
    """What the stages write beside a row's results for the report (which reads no registry): its title and
    whether it is a learner, whose training metrics the report then requires; a diverse query's row also names
    the learner whose generator answers it (`generator`)."""
    generator = {"generator": DIVERSE[method]} if method in DIVERSE else {}
    return {"title": method_title(method), "learned": method in LEARNERS["modular"], **generator}


def learned_methods() -> tuple[str, ...]:
    """The rows of Table 5.1 a trained model answers, in the table's order: every learner's and each diverse query's
    (whose learner's generator answers it). A further training seed answers these rows again."""
    return tuple(m for m in realtime_methods() if DIVERSE.get(m, m) in LEARNERS["modular"])


def learned_proposers(problem: ModularEgganProblem, params: EgganModularParams, models: Path) -> dict[str, Proposer]:
    """The learned rows of Table 5.1 (`learned_methods`), each from its learner's model `models`/eggan_modular_NAME.pt
    (a folder of the stage's own models, or one of a further training seed's)."""
    proposers: dict[str, Proposer] = {}
    for method in learned_methods():
        trained = DIVERSE.get(method, method)
        path = models / f"eggan_modular_{trained}.pt"
        if not path.exists():
            raise FileNotFoundError(f"{path}: no trained {method_title(trained)} model (run train_eggan_modular)")
        learner = LEARNERS["modular"][trained]
        model = learner.load(path, problem)[0]
        proposers[method] = diverse_answer(model, params.protocol.samples, params.protocol.diverse_hamming) \
            if method in DIVERSE else learner.answer(model, params.protocol.samples)
    return proposers


def realtime_proposers(problem: ModularEgganProblem, params: EgganModularParams, models: Path,
                       portfolio: list[str], optima: dict[int, list[str]], greedy: list[str],
                       predict: dict[str, Proposer]) -> dict[str, Proposer]:
    """Every row of Table 5.1: each learned method from its trained model under `models` (`learned_proposers`),
    random sampling, and the rows from tables (`table_proposers` of the `portfolio` designs, the `greedy`
    portfolio's and each test terrain's fittest designs; `predict`, the rows of `PREDICT`:
    `table_designs.predict_proposers`)."""
    if set(predict) != set(PREDICT):
        raise ValueError(f"predict: expected the rows {list(PREDICT)}, found {list(predict)}")
    tables = {"random": random_proposer, **table_proposers(portfolio, optima, greedy), **predict}
    learned = learned_proposers(problem, params, models)
    return {method: tables[method] if method in tables else learned[method] for method in realtime_methods()}


def seeded_realtime_table(proposers: dict[str, Proposer], seeds: dict[int, Path], problem: ModularEgganProblem,
                          modular: ModularParams, params: EgganModularParams, tables: TableAnswers,
                          best_of: tuple[int, ...] = ()) -> tuple[pd.DataFrame, dict[str, float]]:
    """Table 5.1 over training seeds: every row of `proposers` (the stage's own models and the unlearned rows) on the
    test terrains (`realtime_table`), then the learned rows (`learned_methods`) again from each further training
    seed's folder (`seeds`: seed -> folder, checked by `training_seeds.further_seeds`): the same terrains, queries,
    candidates and look-ups (`tables`). Column `training_seed`: the seed of the model that answered a learned row
    (the learner's configured one for the stage's own), 0 for a row no model answers (answered once). Optimum and
    regret are set from every candidate answered (`with_optimum`). Returns the table and the median query wall
    times of the stage's own rows (`proposers`)."""
    table, query_ms = realtime_table(proposers, problem, modular, params, tables, best_of)
    learned = learned_methods()
    parts = [table.assign(training_seed=[configured_seed(m, params) if m in learned else 0 for m in table.method])]
    for seed, folder in seeds.items():
        seeded = realtime_table(learned_proposers(problem, params, folder), problem, modular, params, tables,
                                best_of)[0]
        parts.append(seeded.assign(training_seed=seed))
    return with_optimum(pd.concat(parts, ignore_index=True), tables), query_ms


def train_baseline(name: str, modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
                   executor: Executor | None, out: Path, progress: bool = False) -> dict:
    """One learned baseline (`robocompose.eggan.learners.baselines("modular")`) on the same problem and budget of real
    rollouts as EG-GAN; writes out/eggan_modular_NAME.{pt,json} and returns its metrics. With its `validate_every`
    and EG-GAN's `train.best_by` it keeps its best validated model, as EG-GAN does (`ModelSelection`)."""
    learner = LEARNERS["modular"][name]
    training = learner.training
    config = training_config(name, params)
    problem = make_problem(modular, params, cache, executor, config.iterations * config.tasks)

    def validate(model) -> dict[str, float]:
        return validation_scores(problem, learner.answer(model, params.protocol.samples), params.protocol.candidates)

    table = problem.fitness.source == "table"
    every = getattr(config, "validate_every", 0)  # a learner whose settings have it takes a `select` keyword
    select = ModelSelection(validate, every, params.train.best_by) if table and every and params.train.best_by \
        else None
    network = network_of(name, params)
    model, rows = training.train(problem, network, config, progress) if select is None else \
        training.train(problem, network, config, progress, select=select)
    if table and select is None:
        rows[-1] = {**rows[-1], **validate(model)}
    best = {} if select is None or select.best is None else {
        "best_iteration": select.best["iteration"],
        "best": next(row for row in rows if row["iteration"] == select.best["iteration"])}
    metrics = {"method": learner.title, **_common_metrics(problem, config.iterations, rows), **best,
               **_training_fit(problem, learner.answer(model, params.protocol.samples), params),
               **training.metrics(config, rows)}
    training.save(model, problem, out / f"eggan_modular_{name}.pt",
                  {"settings_hash": modular.eval.settings_hash(), "train": dataclasses.asdict(config),
                   "metrics": metrics})
    return metrics


def train_method(method: str, modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
                 executor: Executor | None, out: Path, progress: bool = False) -> dict:
    """Train one learner of `training_order("modular")` (an EG-GAN variant or a learned baseline); returns its
    metrics and, under "seconds", its training wall time (which the caller moves to reports/timings.json)."""
    started = time.perf_counter()
    trainer = train_variant if method in variants("modular") else train_baseline
    metrics = trainer(method, modular, params, cache, executor, out, progress)
    return {**metrics, "seconds": round(time.perf_counter() - started, 1)}


def training_config(method: str, params: EgganModularParams) -> Any:
    """The settings learner `method` trains with under `params` (the dataclass its model file records as "train"):
    an EG-GAN variant `params.train` with its evolution and steps, a learned baseline its own settings' dataclass."""
    if method in variants("modular"):
        return dataclasses.replace(params.train, evolution=LEARNERS["modular"][method].evolution,
                                   evolution_steps=params.evolution_steps[method])
    if method not in baselines("modular"):
        raise InputError(f"method: expected one of {list(training_order('modular'))}, found {method!r}")
    return build_config(LEARNERS["modular"][method].training.settings, params.baselines[method],
                        f"eggan_modular.baselines.{method}")


def configured_seed(method: str, params: EgganModularParams) -> int:
    """The training seed learner `method` (or, for a diverse query's row, the learner whose generator answers it)
    trains at under `params`: the seed of the stage's own model; 0 for a learner whose settings have none."""
    return int(getattr(training_config(DIVERSE.get(method, method), params), "seed", 0))


def with_seed(params: EgganModularParams, method: str, seed: int) -> EgganModularParams:
    """`params` with learner `method`'s training seed set to `seed` (`train.seed` for an EG-GAN variant, its own
    `seed` setting for a learned baseline): one of the further training seeds, trained apart from the stage."""
    if method in variants("modular"):
        return dataclasses.replace(params, train=dataclasses.replace(params.train, seed=seed))
    if method not in baselines("modular"):
        raise InputError(f"method: expected one of {list(training_order('modular'))}, found {method!r}")
    return dataclasses.replace(params, baselines={**params.baselines, method: {**params.baselines[method],
                                                                               "seed": seed}})


def train_seed(method: str, seed: int, modular: ModularParams, params: EgganModularParams, out: Path) -> dict:
    """Train learner `method` at training seed `seed` with the stage's settings otherwise, into `out` (its model,
    checkpoint and curve; `robocompose modular train-seed`); returns its metrics with the wall time."""
    seeded = with_seed(params, method, seed)
    started = time.perf_counter()
    if method in variants("modular"):
        metrics = train_variant(method, modular, seeded, None, None, out, progress=True, plots=out)
    else:
        metrics = train_baseline(method, modular, seeded, None, None, out, progress=True)
    return {**metrics, "seed": seed, "seconds": round(time.perf_counter() - started, 1)}


def _train_job(job: tuple[str, ModularParams, EgganModularParams, Path]) -> dict:
    method, modular, params, out = job
    return train_method(method, modular, params, None, None, out, progress=True)


def train_all(modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
              executor: Executor | None, out: Path) -> tuple[dict, dict]:
    """Every learner of Table 5.1: (metrics, training seconds), keyed the EG-GAN variants first, then the
    baselines. They start costliest first (`training_order`; each trains on its own copy of the problem). On exact
    fitness (tables: no rollouts) the learners train side by side on the executor's workers, each in one thread: a
    learner's bytes do not depend on where it ran. With the surrogate source they train one after another, their
    rollouts fanned out on the executor."""
    order, queue = (*variants("modular"), *baselines("modular")), training_order("modular")
    if params.fitness.source == "table" and executor is not None:
        results = dict(zip(queue, executor.map(_train_job, [(m, modular, params, out) for m in queue]), strict=True))
    else:
        results = {m: train_method(m, modular, params, cache, executor, out, progress=True) for m in queue}
    seconds = {m: results[m].pop("seconds") for m in order}
    return {m: results[m] for m in order}, seconds


def _training_fit(problem: ModularEgganProblem, answer: Answer, params: EgganModularParams) -> dict:
    """With the table source, the learner's score on its training terrains (`training_scores`)."""
    if problem.fitness.source != "table":
        return {}
    return {"training_terrains": training_scores(problem, answer, params.protocol.candidates)}


def _common_metrics(problem: ModularEgganProblem, iterations: int, rows: list[dict]) -> dict:
    """What every learner's metrics say: its fitness source and evaluations (distinct table look-ups or real
    rollouts), the iterations asked for and done (fewer: the budget ran out), its surrogate's error if it had
    one, and its last log row (with the validation scores on the table source)."""
    final = dict(rows[-1]) if rows else {}
    return {"fitness_source": problem.fitness.source, "iterations": iterations,
            "iterations_done": int(final.get("iteration", 0)), "real_evaluations": problem.real_evaluations,
            "evaluation_budget": problem.fitness.lookups if problem.fitness.source == "table"
            else problem.fitness.budget, "surrogate_heldout": problem.surrogate_error(), "final": final}


