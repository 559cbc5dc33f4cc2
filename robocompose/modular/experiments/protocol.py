"""The real-time test protocol of Table 5.1, for every method that answers a query in real time (a `Proposer`:
terrain -> candidate designs) on every held-out test terrain and query (`realtime_table`):
- the method outputs `candidates` designs (EG-GAN: the most probable distinct designs among `samples` draws);
- every candidate is answered from the terrain's table (`TableAnswers`: the simulator's measured result
  of every design, or of a design set with the candidates outside it simulated and counted; a test terrain without
  a table is an InputError); max distance = the best valid one;
- distinct solutions = the niching metric (delta 1 Hamming, epsilon 0.5 m) over the valid candidates (0 if none:
  penalty scores are not distances);
- EC: `ec_draws` random caps on one module type; the answer is the best satisfying valid candidate, else a
  random valid satisfying design (modular `ec_answers`), looked up the same way. Answers are valid designs,
  so EC is a distance; a query whose candidates are all invalid is counted as a failure, not averaged;
- regret = the terrain's optimum (exhaustive; on a partial table the best known, a lower bound) minus max distance;
- best of k (`best_of`, asked by the stage for `best_of_ks`: 1, 3 and all the candidates): the best valid one of
  the query's first k candidates (NaN if none), and the distinct look-ups those k cost: the same queries and
  candidates, no further look-up. `best_of_summary` gives each method's mean per k and per terrain for the report
  (a terrain's mean averaged over a learned row's training seeds; `seed_summary`: the mean and sd over its seeds).

Beside the thesis's rows, three from tables (`table_proposers`): the terrain-agnostic portfolio (the designs best on
average over the training pool, `robocompose.modular.experiments.table_designs.portfolio`), the greedy portfolio
(the designs whose best-of-k is best on average over the pool, `table_designs.greedy_portfolio`, answered in pick
order) and the exhaustive optimum (each test terrain's fittest designs, `table_designs.top_designs`: an oracle
upper bound, not a method); and two that read the terrain without training (`table_designs.predict_proposers`):
the designs best in the test terrain's row of the table as predicted from its height map's features and the pool's
tables, by k-NN or ridge (the gate's predictability ceiling, `robocompose.modular.gate`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import EvalSettings, FitnessRule, Result, evaluate_designs
from robocompose.modular.experiments.baselines import DELTA, EPSILON, _seed, ec_answers, emergency_constraints
from robocompose.modular.params import ModularParams
from robocompose.modular.plugins.eggan_problem import ModularEgganProblem
from robocompose.modular.plugins.search_problem import hamming
from robocompose.search.metrics import distinct_solutions

# (problem, terrain seed, query seed, candidates) -> candidate designs, best first
Proposer = Callable[[ModularEgganProblem, int, int, int], list[str]]


def random_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int, candidates: int) -> list[str]:
    """Random sampling (thesis Table 5.1): `candidates` designs drawn uniformly (every port uniform)."""
    rng = np.random.default_rng([query_seed, terrain_seed, 6007])
    return ["".join("nlwb"[int(i)] for i in row) for row in rng.integers(4, size=(candidates, 6))]


def table_proposers(portfolio: list[str], optima: dict[int, list[str]],
                    greedy: list[str] | None = None) -> dict[str, Proposer]:
    """Table 5.1's rows from tables: "portfolio" answers every query with the same `portfolio` designs (best on
    average over the training pool); "portfolio_greedy" (when `greedy` is given) with the greedy portfolio's
    designs in pick order; "optimum" with `optima[terrain]`, the terrain's fittest designs in its exhaustive table
    (the oracle upper bound)."""

    def first(designs: list[str], candidates: int, what: str) -> list[str]:
        if candidates > len(designs):
            raise InputError(f"eggan_modular.protocol.candidates: expected at most the {len(designs)} designs of "
                             f"{what}, found {candidates}")
        return designs[:candidates]

    def portfolio_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int,
                           candidates: int) -> list[str]:
        return first(portfolio, candidates, "the portfolio")

    def greedy_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int,
                        candidates: int) -> list[str]:
        return first(greedy, candidates, "the greedy portfolio")

    def optimum_proposer(problem: ModularEgganProblem, terrain_seed: int, query_seed: int,
                         candidates: int) -> list[str]:
        return first(optima[terrain_seed], candidates, f"terrain {terrain_seed}'s optimum")

    greedy_row = {} if greedy is None else {"portfolio_greedy": greedy_proposer}
    return {"portfolio": portfolio_proposer, **greedy_row, "optimum": optimum_proposer}


class TableAnswers:
    """The measured result of every candidate on the test terrains of `truth`: read from its table, or simulated
    through `cache` and `executor` when a partial table lacks it (`rollouts` counts those per terrain)."""

    def __init__(self, truth: pd.DataFrame, settings: EvalSettings, rule: FitnessRule,
                 cache: EvaluationCache | None = None, executor: Executor | None = None):
        self.settings, self.rule, self.cache, self.executor = settings, rule, cache, executor
        self.known: dict[int, dict[str, Result]] = {}
        self.table_optimum: dict[int, float] = {}
        for seed, table in truth.groupby("terrain_seed"):
            self.known[int(seed)] = {d: Result(None if pd.isna(x) else float(x), s, 0, 0.0)
                                     for d, x, s in zip(table.design, table.distance, table.status, strict=True)}
            self.table_optimum[int(seed)] = float(table.fitness.max())
        self.simulated: dict[int, list[str]] = {seed: [] for seed in self.known}

    def results(self, terrain_seed: int, designs: Sequence[str]) -> list[Result]:
        known = self.known[terrain_seed]
        misses = sorted(set(designs) - set(known))
        if misses:
            results = evaluate_designs(misses, terrain_seed, self.settings, self.rule, self.cache, self.executor)
            for design, result in zip(misses, results, strict=True):
                known[design] = result
                if not self.rule.skips(design):  # a design the rule skips is scored without a rollout
                    self.simulated[terrain_seed].append(design)
        return [known[d] for d in designs]

    def optimum(self, terrain_seed: int) -> float:
        """The best fitness known on the terrain: its table's optimum, or better a design simulated for it."""
        extra = [self.rule.fitness(self.known[terrain_seed][d]) for d in self.simulated[terrain_seed]]
        return max([self.table_optimum[terrain_seed], *extra])

    @property
    def rollouts(self) -> dict[int, int]:
        """Per terrain, the candidates answered by a rollout outside its table."""
        return {seed: len(designs) for seed, designs in self.simulated.items()}


BEST_OF = (1, 3)  # best of the first k candidates, beside the best of them all (Table 5.1's max distance)


def best_of_ks(candidates: int) -> tuple[int, ...]:
    """The k of the best-of-k columns for `candidates` candidates per query: those of `BEST_OF` below it, and it."""
    return (*(k for k in BEST_OF if k < candidates), candidates)


def realtime_table(proposers: dict[str, Proposer], problem: ModularEgganProblem, modular: ModularParams,
                   params: EgganModularParams, tables: TableAnswers,
                   best_of: tuple[int, ...] = ()) -> tuple[pd.DataFrame, dict[str, float]]:
    """One row per method x test terrain x query (see the module docstring), every candidate answered by `tables`
    (the test terrains' tables), and each method's median query wall time in ms (kept apart from the table, so that
    the table's bytes depend on the inputs only). For each k of `best_of` the row also holds `best_of_K`, the
    best valid one of the first k candidates, and `lookups_K`, the distinct designs among them."""
    p = params.protocol
    rule = modular.fitness
    missing = sorted(set(p.test_terrains) - set(tables.known))
    if missing:
        raise InputError(f"eggan_modular.protocol.test_terrains: expected every test terrain in the exhaustive table "
                         f"(modular.experiments.truth_terrains, stage modular_exhaustive), missing {missing}")
    rows, query_ms = [], {}
    for terrain_seed in p.test_terrains:
        first_row = len(rows)

        def measured(designs: list[str], terrain_seed=terrain_seed) -> list[Result]:
            """The simulator's measured results, from the terrain's table (or simulated outside a partial one)."""
            return tables.results(terrain_seed, designs)

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
                    "ec_failures": len(ec) - len(ec_ok), **_best_of(candidates, fitness, valid, best_of)})
        # the optimum once every method has answered: on a partial table a simulated candidate may beat its set
        optimum = tables.optimum(terrain_seed)
        for row in rows[first_row:]:
            row["optimum"], row["regret"] = optimum, optimum - row["max_distance"]
    return pd.DataFrame(rows), {method: round(float(np.median(ms)), 3) for method, ms in query_ms.items()}


def _best_of(candidates: list[str], fitness: np.ndarray, valid: np.ndarray, ks: tuple[int, ...]) -> dict:
    """best_of_K (the best valid fitness among the first k candidates, NaN if none) and lookups_K (the distinct
    designs among them) for each k of `ks`."""
    out = {}
    for k in ks:
        first = valid[:k]
        out[f"best_of_{k}"] = float(fitness[:k][first].max()) if first.any() else np.nan
        out[f"lookups_{k}"] = len(set(candidates[:k]))
    return out


def best_of_columns(ks: tuple[int, ...]) -> list[str]:
    """The columns `realtime_table(..., best_of=ks)` adds (not part of the realtime table's schema)."""
    return [f"{name}_{k}" for k in ks for name in ("best_of", "lookups")]


def best_of_summary(table: pd.DataFrame, ks: tuple[int, ...]) -> dict:
    """Per method and k of `ks` (the table's best_of_K columns): the mean and std (population) over terrains x
    queries of the best of the first k candidates, its queries without a valid one among them and the mean distinct
    look-ups a query spent on them; and per method, k and terrain the mean over its queries (the pairs of the
    report's tests). Keys are strings (JSON); numbers rounded to 4 places."""
    def number(value: float) -> float | None:
        return None if value != value else round(float(value), 4)

    methods, per_terrain = {}, {}
    for method, group in table.groupby("method", sort=False):
        methods[method] = {str(k): {"mean": number(group[f"best_of_{k}"].mean()),
                                    "std": number(group[f"best_of_{k}"].std(ddof=0)),
                                    "no_valid": int(group[f"best_of_{k}"].isna().sum()),
                                    "lookups": number(group[f"lookups_{k}"].mean())} for k in ks}
        per_terrain[method] = {str(k): {str(seed): number(v)
                                        for seed, v in terrain_means(group, f"best_of_{k}").items()} for k in ks}
    return {"ks": list(ks), "methods": methods, "per_terrain": per_terrain}


def terrain_means(rows: pd.DataFrame, column: str) -> pd.Series:
    """Per test terrain, one method's mean of `column` over its queries, averaged over its training seeds when
    `rows` has them (column `training_seed`): the pairs of the report's tests (one score per terrain)."""
    if "training_seed" not in rows:
        return rows.groupby("terrain_seed")[column].mean()
    return rows.groupby(["training_seed", "terrain_seed"])[column].mean().groupby("terrain_seed").mean()


SEED_COLUMNS = ("max_distance", "distinct", "ec_distance", "regret")  # Table 5.1's columns, summarised over seeds


def seed_summary(table: pd.DataFrame, methods: Sequence[str], ks: tuple[int, ...] = ()) -> dict:
    """Per method of `methods` in the table (its learned rows, column `training_seed`): over its training seeds, the
    mean and the sd (sample, ddof 1; None for one seed) of each seed's mean over terrains x queries, of max distance,
    distinct, EC distance, regret and each k's best_of_K (as "best_of_K"), with every seed's mean ("per_seed"), the
    seeds and their number ("n"). Keys are strings (JSON); numbers rounded to 4 places."""
    def number(value: float) -> float | None:
        return None if value != value else round(float(value), 4)

    columns = [*SEED_COLUMNS, *(f"best_of_{k}" for k in ks)]
    out = {}
    for method, group in table[table.method.isin(list(methods))].groupby("method", sort=False):
        per_seed = group.groupby("training_seed")[columns].mean()
        out[method] = {"seeds": [int(seed) for seed in per_seed.index], "n": len(per_seed),
                       **{column: {"mean": number(per_seed[column].mean()),
                                   "sd": number(per_seed[column].std(ddof=1)) if len(per_seed) > 1 else None,
                                   "per_seed": {str(seed): number(v) for seed, v in per_seed[column].items()}}
                          for column in columns}}
    return out


def with_optimum(table: pd.DataFrame, tables: TableAnswers) -> pd.DataFrame:
    """`table` with each row's optimum and regret set from every candidate `tables` answered so far: on a partial
    table a candidate of a later run (another training seed's) may beat the set, and every row of a terrain must
    share one optimum."""
    optimum = table.terrain_seed.map(tables.optimum)
    return table.assign(optimum=optimum, regret=optimum - table.max_distance)


def summarise(table: pd.DataFrame) -> pd.DataFrame:
    """Per method: mean and std over terrains x queries of max distance, distinct, EC, regret; failure counts."""
    grouped = table.groupby("method", sort=False)
    out = grouped[["max_distance", "distinct", "ec_distance", "regret"]].agg(["mean", "std"])
    out.columns = [f"{a}_{b}" for a, b in out.columns]
    out["queries"] = grouped.size()
    out["no_valid_candidate"] = grouped.max_distance.apply(lambda s: int(s.isna().sum()))
    out["ec_failures"] = grouped.ec_failures.sum()
    return out.reset_index()


def table_scores(problem: ModularEgganProblem, answer: Proposer, candidates: int, seeds: list[int],
                 prefix: str) -> dict[str, float]:
    """A learner's score on pool terrains, from their tables: per terrain the best table fitness among its
    `candidates` answers (query seed 0) and the regret to the terrain's optimum, averaged, as PREFIX_max_distance
    and PREFIX_regret."""
    best, regret = [], []
    for seed in seeds:
        table = problem.table(seed)
        top = max(table[d] for d in answer(problem, seed, 0, candidates))
        best.append(top)
        regret.append(max(table.values()) - top)
    return {f"{prefix}_max_distance": float(np.mean(best)), f"{prefix}_regret": float(np.mean(regret))}


def validation_scores(problem: ModularEgganProblem, answer: Proposer, candidates: int) -> dict[str, float]:
    """The score on the pool's validation terrains (never trained on): the validation curve of training and the
    final check of every learner."""
    return table_scores(problem, answer, candidates, problem.validation_tasks(), "val")


def training_scores(problem: ModularEgganProblem, answer: Proposer, candidates: int) -> dict[str, float]:
    """The same score on the training terrains: beside the validation score, how far a learner fits the terrains
    it was trained on and how much of that carries to terrains it never saw."""
    return table_scores(problem, answer, candidates, problem.fitness.train_seeds, "train")
