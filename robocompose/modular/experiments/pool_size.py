"""Held-out score against the training pool's size (beyond the thesis): how much terrain data buys how much
generalisation.

For each size n of `eggan_modular.pool_size.sizes` (capped at the pool's training terrains), on the first n
training terrains: EG-GAN-crowding trained on exact fitness (the default profile's settings, `iterations`
iterations, the same look-up budget) with `seeds` training seeds, and the terrain-agnostic portfolio of those n
terrains (the 10 designs best on average: the baseline that needs no learning). Both answer the test protocol
(`realtime_table`: the test terrains that have an exhaustive table x `queries` queries: a study of many
trainings reads no partial table, so it simulates nothing); the study's table holds
every query's row with its pool size, training seed and the method's score on its own n training terrains
(`train_max_distance`): the gap between that and the test score is what the method fits but does not carry
to terrains it never saw. The (size, seed) runs are independent: they run side by side on an executor.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd

from robocompose.eggan.learners import generator_answer
from robocompose.eggan.train import train
from robocompose.fanout.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams, PoolSizeConfig, network_of
from robocompose.modular.experiments.protocol import TableAnswers, realtime_table, table_proposers, training_scores
from robocompose.modular.experiments.table_designs import portfolio
from robocompose.modular.params import ModularParams
from robocompose.modular.plugins.eggan_problem import ModularEgganProblem


def study_sizes(config: PoolSizeConfig, train_terrains: int) -> list[int]:
    """The sizes the pool allows: those of `config.sizes` below its training terrains, and the whole pool."""
    return sorted({n for n in config.sizes if n < train_terrains} | {train_terrains})


def pool_size_study(modular: ModularParams, params: EgganModularParams, config: PoolSizeConfig, pool: pd.DataFrame,
                    truth: pd.DataFrame, checkpoints: Path, executor: Executor | None = None) -> pd.DataFrame:
    """Every test query of EG-GAN-crowding and the portfolio per pool size and training seed (see the module
    docstring); `pool`: the pool's tables, `truth`: the test terrains' tables. A run resumes from its checkpoint."""
    if not set(params.protocol.test_terrains) & set(truth.terrain_seed):
        raise InputError(f"eggan_modular.protocol.test_terrains: expected at least one with an exhaustive table "
                         f"(modular.experiments.truth_terrains) for the pool-size study, found none of "
                         f"{list(params.protocol.test_terrains)}")
    jobs = [(modular, params, config, pool, truth, checkpoints, n, seed)
            for n in study_sizes(config, params.fitness.train_terrains) for seed in range(config.seeds)]
    frames = executor.map(_study_run, jobs) if executor is not None else [_study_run(job) for job in jobs]
    return pd.concat(frames, ignore_index=True)


def _study_run(job: tuple) -> pd.DataFrame:
    """One (size n, training seed) run: EG-GAN-crowding trained on the first n terrains, and (seed 0 only, it has
    no randomness) the portfolio of those terrains, on the test protocol."""
    modular, params, config, pool, truth, checkpoints, n, seed = job
    full = set(truth.terrain_seed)
    protocol = dataclasses.replace(params.protocol, queries=config.queries,
                                   test_terrains=[t for t in params.protocol.test_terrains if t in full])
    sized = dataclasses.replace(params, protocol=protocol,
                                fitness=dataclasses.replace(params.fitness, train_terrains=n))
    train_config = dataclasses.replace(sized.train, iterations=config.iterations, evolution="crowding",
                                       evolution_steps=sized.evolution_steps["crowding"], validate_every=0,
                                       best_by="", seed=sized.train.seed + seed)  # no validation: the last model
    problem = ModularEgganProblem(modular, sized.fitness, mutation_rate=modular.experiments.mutation_rate,
                                  crossover_rate=modular.experiments.crossover_rate)
    trained = train(problem, network_of("crowding", sized), train_config, checkpoints / f"crowding_{n}_seed{seed}.pt")
    chosen = portfolio(pool[pool.terrain_seed.isin(sized.fitness.train_seeds)], protocol.candidates)
    proposers = {"crowding": generator_answer(trained.generator, protocol.samples)}
    if seed == 0:
        proposers["portfolio"] = table_proposers(chosen, {})["portfolio"]
    fit = {method: training_scores(problem, answer, protocol.candidates)["train_max_distance"]
           for method, answer in proposers.items()}
    lookups = problem.real_evaluations  # the learner's look-ups, before the scores above read the tables
    table, _ = realtime_table(proposers, problem, modular, sized,
                              TableAnswers(truth, modular.eval, modular.fitness))
    return table.assign(pool_terrains=n, seed=seed, iterations_done=trained.stopped or config.iterations,
                        lookups=lookups, train_max_distance=table.method.map(fit))
