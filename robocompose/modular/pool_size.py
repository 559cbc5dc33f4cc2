"""Held-out score against the training pool's size (beyond the thesis): how much terrain data buys how much
generalisation.

For each size n of `eggan_modular.pool_size.sizes` (capped at the pool's training terrains), on the first n
training terrains: EG-GAN-crowding trained on exact fitness (the default profile's settings, `iterations`
iterations, the same look-up budget) and the terrain-agnostic portfolio of those n terrains (the 10 designs best
on average: the baseline that needs no learning). Both answer the test protocol (`realtime_table`: the test
terrains x `queries` queries, from their exhaustive tables); the study's table holds every query's row with its
pool size.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd

from robocompose.eggan.learners import generator_answer
from robocompose.eggan.train import train
from robocompose.modular.eggan_params import EgganModularParams, PoolSizeConfig
from robocompose.modular.eggan_problem import ModularEgganProblem
from robocompose.modular.params import ModularParams
from robocompose.modular.protocol import realtime_table, table_proposers
from robocompose.modular.table_designs import portfolio


def study_sizes(config: PoolSizeConfig, train_terrains: int) -> list[int]:
    """The sizes the pool allows: those of `config.sizes` below its training terrains, and the whole pool."""
    return sorted({n for n in config.sizes if n < train_terrains} | {train_terrains})


def pool_size_study(modular: ModularParams, params: EgganModularParams, config: PoolSizeConfig, pool: pd.DataFrame,
                    truth: pd.DataFrame, checkpoints: Path, progress: bool = False) -> pd.DataFrame:
    """Every test query of EG-GAN-crowding and the portfolio per pool size (see the module docstring); `pool`: the
    pool's tables, `truth`: the test terrains' tables. A size's training resumes from its checkpoint."""
    protocol = dataclasses.replace(params.protocol, queries=config.queries)
    frames = []
    for n in study_sizes(config, params.fitness.train_terrains):
        sized = dataclasses.replace(params, protocol=protocol,
                                    fitness=dataclasses.replace(params.fitness, train_terrains=n))
        train_config = dataclasses.replace(sized.train, iterations=config.iterations, evolution="crowding",
                                           evolution_steps=sized.evolution_steps["crowding"], validate_every=0)
        problem = ModularEgganProblem(modular, sized.fitness, mutation_rate=modular.experiments.mutation_rate,
                                      crossover_rate=modular.experiments.crossover_rate)
        trained = train(problem, sized.network, train_config, checkpoints / f"crowding_{n}.pt",
                        progress=progress)
        chosen = portfolio(pool[pool.terrain_seed.isin(sized.fitness.train_seeds)], protocol.candidates)
        proposers = {"crowding": generator_answer(trained.generator, protocol.samples),
                     "portfolio": table_proposers(chosen, {})["portfolio"]}
        table, _ = realtime_table(proposers, problem, modular, sized, truth)
        frames.append(table.assign(pool_terrains=n, iterations_done=trained.stopped or config.iterations,
                                   lookups=problem.real_evaluations))
    return pd.concat(frames, ignore_index=True)
