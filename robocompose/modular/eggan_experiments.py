"""EG-GAN on modular robots: training the two variants, and the real-time test protocol of Table 5.1.

Training (`train_variant`): Algorithm 1 on `ModularEgganProblem` with the variant's evolution (crowding:
EG-GAN-crowding; ga: EG-GAN), resumable from its checkpoint; the generator is saved with its params, metrics
and code provenance.

Protocol (`realtime_table`), for every method that answers a query in real time (a `Proposer`: terrain ->
candidate designs) on every held-out test terrain and query:
- the method outputs `candidates` designs (EG-GAN: the most probable distinct designs among `samples` draws);
- every candidate is answered from the terrain's exhaustive table (the simulator's measured result of every
  design: no new rollout; a test terrain without a table is an InputError); max distance = the best valid one;
- distinct solutions = the niching metric (delta 1 Hamming, epsilon 0.5 m) over the valid candidates (0 if none:
  penalty scores are not distances);
- EC: `ec_draws` random caps on one module type; the answer is the best satisfying valid candidate, else a
  random valid satisfying design (modular `ec_answers`), looked up the same way. Answers are valid designs,
  so EC is a distance; a query whose candidates are all invalid is counted as a failure, not averaged;
- regret = the terrain's exhaustive optimum minus max distance.

Beside the thesis's rows, two from tables (`table_proposers`): the terrain-agnostic portfolio (the designs best on
average over the training pool, `robocompose.modular.truth.portfolio`) and the exhaustive optimum (each test
terrain's fittest designs, `robocompose.modular.truth.top_designs`: an oracle upper bound, not a method).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.eggan.learners import LEARNERS, Answer, Learner, baselines, generator_answer
from robocompose.eggan.query import save_generator
from robocompose.eggan.train import train
from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import VARIANTS, EgganModularParams
from robocompose.modular.eggan_problem import ModularEgganProblem
from robocompose.modular.evaluate import Result
from robocompose.modular.experiments import DELTA, EPSILON, _seed, ec_answers, emergency_constraints
from robocompose.modular.params import ModularParams
from robocompose.modular.problem import hamming
from robocompose.params import build_config
from robocompose.search.metrics import distinct_solutions

# (problem, terrain seed, query seed, candidates) -> candidate designs, best first
Proposer = Callable[[ModularEgganProblem, int, int, int], list[str]]


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


def validation_scores(problem: ModularEgganProblem, answer: Answer, candidates: int) -> dict[str, float]:
    """A learner's score on the pool's validation terrains (never trained on), from their tables: per terrain the
    best table fitness among its `candidates` answers (query seed 0) and the regret to the terrain's optimum,
    averaged; the validation curve of training and the final check of every learner."""
    best, regret = [], []
    for seed in problem.validation_tasks():
        table = problem.table(seed)
        top = max(table[d] for d in answer(problem, seed, 0, candidates))
        best.append(top)
        regret.append(max(table.values()) - top)
    return {"val_max_distance": float(np.mean(best)), "val_regret": float(np.mean(regret))}


def train_variant(variant: str, modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
                  executor: Executor | None, out: Path, progress: bool = False) -> dict:
    """Train one EG-GAN variant; writes out/eggan_modular_VARIANT.{pt,json,mcap,csv} and its checkpoint; returns
    its metrics (no wall times: they go to reports/timings.json, so that the files stay byte-reproducible)."""
    if variant not in VARIANTS:
        raise ValueError(f"variant {variant!r}: expected one of {sorted(VARIANTS)}")
    config = dataclasses.replace(params.train, evolution=variant, evolution_steps=params.evolution_steps[variant])
    # per iteration and task: X_gen, then one batch per crowding step / GA generation
    problem = make_problem(modular, params, cache, executor,
                           config.iterations * config.tasks * (1 + config.evolution_steps))
    name = f"eggan_modular_{variant}"
    validate = None
    if problem.fitness.source == "table":
        def validate(generator):
            return validation_scores(problem, generator_answer(generator, params.protocol.samples),
                                     params.protocol.candidates)
    trained = train(problem, params.network, config, out / "checkpoints" / f"{name}.pt",
                    Path("reports/plots") / f"{name}.csv", out / f"{name}.mcap", progress=progress, validate=validate)
    metrics = {"method": VARIANTS[variant], **_common_metrics(problem, config.iterations, trained.rows),
               "batch": config.batch, "tasks_per_iteration": config.tasks, "evolution": variant,
               "evolution_steps": config.evolution_steps}
    save_generator(trained.generator, problem, out / f"{name}.pt",
                   {"run_key": trained.key, "settings_hash": modular.eval.settings_hash(),
                    "train": dataclasses.asdict(config), "metrics": metrics})
    return metrics


# Table 5.1's rows, in its order: the learned baselines, random sampling, EG-GAN's two variants; ours beside them,
# read from tables: the terrain-agnostic portfolio (after random sampling) and the oracle (last)
REALTIME_METHODS = (*baselines("modular"), "random", "portfolio", "ga", "crowding", "optimum")
TABLE_METHODS = {"portfolio": "Portfolio (terrain-agnostic)", "optimum": "Exhaustive optimum (oracle)"}


def method_title(method: str) -> str:
    """The name of a row of Table 5.1 (the thesis's, where it has the row)."""
    if method == "random":
        return "Random sampling"
    return TABLE_METHODS.get(method) or VARIANTS.get(method) or LEARNERS["modular"][method].title


def learner_of(method: str) -> Learner:
    """The learner of a learned row of Table 5.1 (an EG-GAN variant is the EG-GAN learner)."""
    return LEARNERS["modular"]["eggan"] if method in VARIANTS else LEARNERS["modular"][method]


def realtime_proposers(problem: ModularEgganProblem, params: EgganModularParams, models: Path,
                       portfolio: list[str], optima: dict[int, list[str]]) -> dict[str, Proposer]:
    """Every row of Table 5.1: each learned method from its trained model under `models`, random sampling, and the
    rows from tables (`table_proposers` of the `portfolio` designs and each test terrain's fittest designs)."""
    tables = table_proposers(portfolio, optima)
    proposers: dict[str, Proposer] = {}
    for method in REALTIME_METHODS:
        path = models / f"eggan_modular_{method}.pt"
        if method == "random":
            proposers[method] = random_proposer
        elif method in tables:
            proposers[method] = tables[method]
        elif path.exists():
            learner = learner_of(method)
            proposers[method] = learner.answer(learner.load(path, problem)[0], params.protocol.samples)
        else:
            raise FileNotFoundError(f"{path}: no trained {method_title(method)} model (run train_eggan_modular)")
    return proposers


def train_baseline(name: str, modular: ModularParams, params: EgganModularParams, cache: EvaluationCache | None,
                   executor: Executor | None, out: Path, progress: bool = False) -> dict:
    """One learned baseline (`robocompose.eggan.learners.baselines("modular")`) on the same problem and budget of real
    rollouts as EG-GAN; writes out/eggan_modular_NAME.{pt,json} and returns its metrics."""
    learner = LEARNERS["modular"][name]
    training = learner.training
    config = build_config(training.settings, params.baselines.get(name, {}), f"eggan_modular.baselines.{name}")
    problem = make_problem(modular, params, cache, executor, config.iterations * config.tasks)
    model, rows = training.train(problem, params.network, config, progress)
    if problem.fitness.source == "table":
        rows[-1] = {**rows[-1], **validation_scores(problem, learner.answer(model, params.protocol.samples),
                                                    params.protocol.candidates)}
    metrics = {"method": learner.title, **_common_metrics(problem, config.iterations, rows),
               **training.metrics(config, rows)}
    training.save(model, problem, out / f"eggan_modular_{name}.pt",
                  {"settings_hash": modular.eval.settings_hash(), "train": dataclasses.asdict(config),
                   "metrics": metrics})
    return metrics


def _common_metrics(problem: ModularEgganProblem, iterations: int, rows: list[dict]) -> dict:
    """What every learner's metrics say: its fitness source and evaluations (distinct table look-ups or real
    rollouts), the iterations asked for and done (fewer: the budget ran out), its surrogate's error if it had
    one, and its last log row (with the validation scores on the table source)."""
    final = dict(rows[-1]) if rows else {}
    return {"fitness_source": problem.fitness.source, "iterations": iterations,
            "iterations_done": int(final.get("iteration", 0)), "real_evaluations": problem.real_evaluations,
            "evaluation_budget": problem.fitness.lookups if problem.fitness.source == "table"
            else problem.fitness.budget, "surrogate_heldout": problem.surrogate_error(), "final": final}


def random_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int, candidates: int) -> list[str]:
    """Random sampling (thesis Table 5.1): `candidates` designs drawn uniformly (every port uniform)."""
    rng = np.random.default_rng([query_seed, terrain_seed, 6007])
    return ["".join("nlwb"[int(i)] for i in row) for row in rng.integers(4, size=(candidates, 6))]


def table_proposers(portfolio: list[str], optima: dict[int, list[str]]) -> dict[str, Proposer]:
    """Table 5.1's rows from tables: "portfolio" answers every query with the same `portfolio` designs (best on
    average over the training pool); "optimum" with `optima[terrain]`, the terrain's fittest designs in its
    exhaustive table (the oracle upper bound)."""

    def first(designs: list[str], candidates: int, what: str) -> list[str]:
        if candidates > len(designs):
            raise InputError(f"eggan_modular.protocol.candidates: expected at most the {len(designs)} designs of "
                             f"{what}, found {candidates}")
        return designs[:candidates]

    def portfolio_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int,
                           candidates: int) -> list[str]:
        return first(portfolio, candidates, "the portfolio")

    def optimum_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int,
                         candidates: int) -> list[str]:
        return first(optima[terrain_seed], candidates, f"terrain {terrain_seed}'s optimum")

    return {"portfolio": portfolio_proposer, "optimum": optimum_proposer}


def realtime_table(proposers: dict[str, Proposer], problem: ModularEgganProblem, modular: ModularParams,
                   params: EgganModularParams, truth: pd.DataFrame) -> tuple[pd.DataFrame, dict[str, float]]:
    """One row per method x test terrain x query (see the module docstring), every candidate answered from the
    exhaustive table `truth`, and each method's median query wall time in ms (kept apart from the table, so that
    the table's bytes depend on the inputs only)."""
    p = params.protocol
    rule = modular.fitness
    missing = sorted(set(p.test_terrains) - set(truth.terrain_seed.unique()))
    if missing:
        raise InputError(f"eggan_modular.protocol.test_terrains: expected every test terrain in the exhaustive table "
                         f"(modular.experiments.truth_terrains, stage modular_exhaustive), missing {missing}")
    rows, query_ms = [], {}
    for terrain_seed in p.test_terrains:
        table = truth[truth.terrain_seed == terrain_seed]
        optimum = float(table.fitness.max())
        known = {d: Result(None if pd.isna(x) else float(x), s, 0, 0.0)
                 for d, x, s in zip(table.design, table.distance, table.status, strict=True)}

        def measured(designs: list[str], known=known) -> list[Result]:
            """The simulator's measured results, from the terrain's exhaustive table."""
            return [known[d] for d in designs]

        for method, propose in proposers.items():
            problem.encode_task(terrain_seed)  # the height map is the query's input: not part of its time
            for query in range(p.queries):
                query_seed = _seed(query, terrain_seed, 4999)
                started = time.perf_counter()
                candidates = propose(problem, terrain_seed, query_seed, p.candidates)
                query_ms.setdefault(method, []).append((time.perf_counter() - started) * 1000)
                results = measured(candidates)
                fitness = np.array([rule.fitness(r) for r in results])
                valid = np.array([r.distance is not None for r in results])
                rng = np.random.default_rng([query_seed, terrain_seed, 7919])  # the same caps for every method
                constraints = emergency_constraints(rng, p.ec_draws)
                ok = [c for c, v in zip(candidates, valid, strict=True) if v]
                answers = ec_answers(ok, fitness[valid], constraints, rng, valid=lambda d: not rule.skips(d))
                ec = measured(answers)
                ec_ok = [r.distance for r in ec if r.distance is not None]
                best = float(fitness[valid].max()) if valid.any() else np.nan
                rows.append({
                    "method": method, "terrain_seed": int(terrain_seed), "query": query,
                    "candidates": len(candidates), "valid": int(valid.sum()),
                    "best_design": candidates[int(np.argmax(np.where(valid, fitness, -np.inf)))] if valid.any()
                    else "", "max_distance": best,
                    "distinct": distinct_solutions(ok, fitness[valid], lambda a, b: float(hamming(a, b)), DELTA,
                                                   EPSILON),
                    "ec_distance": float(np.mean(ec_ok)) if ec_ok else np.nan,
                    "ec_failures": len(ec) - len(ec_ok), "optimum": optimum, "regret": optimum - best})
    return pd.DataFrame(rows), {method: round(float(np.median(ms)), 3) for method, ms in query_ms.items()}


def summarise(table: pd.DataFrame) -> pd.DataFrame:
    """Per method: mean and std over terrains x queries of max distance, distinct, EC, regret; failure counts."""
    grouped = table.groupby("method", sort=False)
    out = grouped[["max_distance", "distinct", "ec_distance", "regret"]].agg(["mean", "std"])
    out.columns = [f"{a}_{b}" for a, b in out.columns]
    out["queries"] = grouped.size()
    out["no_valid_candidate"] = grouped.max_distance.apply(lambda s: int(s.isna().sum()))
    out["ec_failures"] = grouped.ec_failures.sum()
    return out.reset_index()
