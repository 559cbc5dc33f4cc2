"""Benchmark: EG-GAN on modular robots: the real-time query and the training throughput.

eggan.modular.query_ms: one query of a generator of the default size (thesis 5.1 networks) on one terrain's
    50 x 20 height map, 64 samples, one thread: encode the terrain, draw 64 z, the generator pass, the row
    softmax, one design per row and the ranking of the distinct ones (median of 50 queries after a warm-up).
    Goal <= 5 ms; thesis 0.003 min (180 ms). The shipped generator when present, else an untrained one.
eggan.modular.query_vs_rollout: one default rollout (the cheapest real evaluation of one design) / one query.
eggan.modular.train_iterations_per_s: Algorithm 1 iterations per second at the default profile's batch (4 tasks x
    32 z, M = 20, 3 crowding steps) with exact fitness from tables (made-up values of the same size as the pool's
    tables), one thread.
"""

from __future__ import annotations

import dataclasses
import statistics
import time

import numpy as np
import torch

from robocompose.eggan.networks import Discriminator, Generator, NetworkConfig
from robocompose.eggan.query import load_generator, top_distinct
from robocompose.eggan.train import TrainConfig, train_step
from robocompose.modular.compose import SHIPPED_MODEL
from robocompose.modular.evaluate import EvalSettings, FitnessRule, rollout
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem
from robocompose.modular.robot import all_designs
from robocompose.modular.terrain import generate_terrain

TERRAIN = 1000
PARAMS = ModularParams(EvalSettings(control_steps=100), FitnessRule(), ExperimentsConfig())


def _query_ms(generator: Generator, problem: ModularEgganProblem, tensor: torch.Tensor) -> float:
    for seed in range(5):
        top_distinct(generator, problem, TERRAIN, 10, 64, seed, tensor)
    times = []
    for seed in range(50):
        started = time.perf_counter()
        top_distinct(generator, problem, TERRAIN, 10, 64, seed, tensor)
        times.append(time.perf_counter() - started)
    return statistics.median(times) * 1000


def run() -> dict[str, float]:
    torch.set_num_threads(1)
    problem = ModularEgganProblem(PARAMS, FitnessConfig())
    if SHIPPED_MODEL.exists():
        generator = load_generator(SHIPPED_MODEL, problem)[0]
    else:
        generator = Generator(problem.task_shape, problem.design_shape, NetworkConfig()).eval()
    tensor = problem.encode_task(TERRAIN)
    query_ms = _query_ms(generator, problem, tensor)
    rollout_s = rollout("wwwwww", generate_terrain(TERRAIN, PARAMS.eval.terrain), PARAMS.eval).seconds

    # Training throughput on table fitness (the default source), with made-up tables of 8 training terrains.
    fitness = FitnessConfig(source="table", train_terrains=8)
    bench = ModularEgganProblem(PARAMS, fitness)
    rng = np.random.default_rng(0)
    designs = all_designs()
    for seed in fitness.train_seeds:
        bench._tables[seed] = dict(zip(designs, rng.normal(3, 1, len(designs)).tolist(), strict=True))
    config = dataclasses.replace(TrainConfig(), batch=128, tasks=4, evolution_steps=3)
    network = NetworkConfig()
    g, d = Generator(bench.task_shape, bench.design_shape, network), Discriminator(bench.task_shape,
                                                                                  bench.design_shape, network)
    opt_g, opt_d = torch.optim.Adam(g.parameters()), torch.optim.Adam(d.parameters())
    train_step(bench, g, d, opt_g, opt_d, config, 0)  # warm-up (height maps, allocator)
    started, iterations = time.perf_counter(), 10
    for t in range(1, iterations + 1):
        train_step(bench, g, d, opt_g, opt_d, config, t % 4)  # tasks repeat: height maps are not timed
    rate = iterations / (time.perf_counter() - started)
    return {"eggan.modular.query_ms": query_ms, "eggan.modular.query_vs_rollout": rollout_s * 1000 / query_ms,
            "eggan.modular.train_iterations_per_s": rate}
