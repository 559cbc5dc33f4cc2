"""Fig. 5.1's records: the task encoding, the ranked valid designs of one query, the constraint and its survivors."""

import json

import numpy as np
import torch

from robocompose.eggan.networks import Generator, NetworkConfig
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments.baselines import satisfies
from robocompose.modular.experiments.figure_5_1 import RANKED, figure_5_1
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem


def test_records_hold_the_encoding_valid_ranked_designs_and_the_constraint_survivors():
    params = ModularParams(EvalSettings(), FitnessRule(), ExperimentsConfig())
    problem = ModularEgganProblem(params, FitnessConfig())
    torch.manual_seed(0)
    generator = Generator(problem.task_shape, problem.design_shape, NetworkConfig(latent=8, hidden=16)).eval()
    records = figure_5_1(generator, problem, params.fitness, [1000, 1001])
    assert [r["terrain_seed"] for r in records] == [1000, 1001]
    for record in records:
        heights = np.asarray(record["heights"], dtype=np.float32)
        assert np.array_equal(heights, problem.encode_task(record["terrain_seed"]).numpy())  # exact through JSON
        assert 0 < len(record["designs"]) <= RANKED and len(set(record["designs"])) == len(record["designs"])
        assert not any(params.fitness.skips(d) for d in record["designs"])
        constraint = tuple(record["constraint"])
        assert record["surviving"] == [d for d in record["designs"] if satisfies(d, constraint)]
    again = figure_5_1(generator, problem, params.fitness, [1000, 1001])
    assert json.dumps(again) == json.dumps(json.loads(json.dumps(records)))  # deterministic, JSON round trip
