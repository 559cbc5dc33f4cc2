"""Thesis Fig. 5.1's designs, as the `modular_realtime` stage records them for the report: for a few test terrains,
the task encoding (height map), EG-GAN-crowding's most probable valid designs of one query, a random emergency
constraint and the designs that survive it."""

from __future__ import annotations

import numpy as np

from robocompose.eggan.networks import Generator
from robocompose.eggan.query import generate, rank_distinct
from robocompose.modular.evaluate import FitnessRule
from robocompose.modular.experiments.baselines import emergency_constraints, satisfies
from robocompose.modular.plugins.eggan_problem import ModularEgganProblem

SAMPLES, RANKED = 64, 10  # one query: 64 samples, the ten most probable distinct designs


def figure_5_1(generator: Generator, problem: ModularEgganProblem, rule: FitnessRule,
               terrains: list[int]) -> list[dict]:
    """One record per terrain: terrain_seed, heights (the (50, 20) float32 task encoding as nested lists), designs
    (the ranked valid designs), constraint ([module letter, cap]) and surviving (the designs that satisfy it)."""
    records = []
    for seed in terrains:
        heights = problem.encode_task(int(seed)).numpy()
        ranked = rank_distinct(problem, *generate(generator, problem, int(seed), SAMPLES, seed=0), RANKED)
        valid = [r.design for r in ranked if not rule.skips(r.design)]
        module, cap = emergency_constraints(np.random.default_rng([int(seed), 51]), 1)[0]
        records.append({"terrain_seed": int(seed), "heights": heights.tolist(), "designs": valid,
                        "constraint": [module, cap],
                        "surviving": [d for d in valid if satisfies(d, (module, cap))]})
    return records
