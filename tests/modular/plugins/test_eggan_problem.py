"""The modular problem on the EG-GAN interface: tensors, the real-rollout budget, the surrogate, resume state.

The simulator is replaced by a fake rollout (distance = 1 m per wheel, minus the terrain's mean block height x 10)
so these tests check the plug-in's bookkeeping; the rollout itself is tested in test_evaluate.py.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
import torch

from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.problem import BudgetSpent
from robocompose.eggan.surrogate import SurrogateConfig, spearman
from robocompose.eggan.train import TrainConfig, train
from robocompose.io import write_table
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem
from robocompose.modular.robot import all_designs

PARAMS = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())
FITNESS = FitnessConfig(source="surrogate", train_terrains=12, warmup=20, warmup_terrains=4, budget=30, real_every=6,
                        real_per_round=4, surrogate=SurrogateConfig(steps=200, hidden=16))


def test_design_tensor_and_sampling_round_trip():
    problem = ModularEgganProblem(PARAMS, FITNESS)
    designs = ["wwwwww", "lnblwb"]
    tensor = problem.design_tensor(designs)  # (2, 6, 4) one-hot
    assert tensor.shape == (2, 6, 4) and torch.equal(tensor.sum(-1), torch.ones(2, 6))
    sampled = problem.sample_designs(tensor, torch.Generator().manual_seed(0))  # a one-hot output is certain
    assert sampled.designs == designs
    assert torch.allclose(sampled.log_prob, torch.zeros(2))
    assert problem.encode_task(20_003).shape == (50, 20)


def test_budget_real_values_and_penalties(fake_rollouts):
    problem = ModularEgganProblem(PARAMS, FITNESS)
    trained = train(problem, NetworkConfig(latent=8, hidden=16),
                    TrainConfig(iterations=6, batch=16, tasks=2, samples=4, evolution_steps=1, log_every=3,
                                checkpoint_every=3))
    simulated = sum(len(d) for _, d in fake_rollouts)
    # warm-up + rounds (a round simulates only designs of its batch without a real value), capped by the budget
    assert FITNESS.warmup + FITNESS.real_per_round < problem.real_evaluations == simulated <= FITNESS.budget
    assert trained.rows[-1]["real_evaluations"] == problem.real_evaluations
    for (seed, design), value in problem.real.items():  # a simulated pair is answered with its real value
        assert problem.evaluate(seed, [design])[0, 0] == value == design.count("w") - seed % 3
    assert problem.evaluate(20_000, ["nnnnnn"])[0, 0] == PARAMS.fitness.penalty  # rejected designs: the penalty
    assert problem.surrogate_error()["heldout"] == len(problem.real) // 5
    # the fake distance (wheels minus terrain_seed % 3) is learnable: on 200 designs it never saw the surrogate
    # ranks better than a model that knows each terrain's offset and nothing of the design (the 6 held-out
    # rollouts alone are too small a sample: their Spearman swings with the designs drawn)
    rng = np.random.default_rng(0)
    seeds, predicted, truth = FITNESS.train_seeds[:4], [], []
    for seed in seeds:
        designs = problem.random_designs(rng, 50)
        predicted += problem.surrogate.predict(problem.encode_task(seed).unsqueeze(0),
                                               torch.zeros(len(designs), dtype=torch.int64),
                                               problem.design_tensor(designs)).tolist()
        truth += [design.count("w") - seed % 3 for design in designs]
    terrain_only = [-(seed % 3) for seed in seeds for _ in range(50)]
    assert spearman(np.array(predicted), np.array(truth)) > spearman(np.array(terrain_only), np.array(truth)) + 0.05


def test_state_round_trip_and_key(fake_rollouts):
    problem = ModularEgganProblem(PARAMS, FITNESS)
    problem.evaluate(20_001, ["wwwwww", "llllll"])
    copy = ModularEgganProblem(PARAMS, FITNESS)
    copy.load_state_dict(problem.state_dict())
    designs = ["wlwlwl", "bbbbbb", "wwwnww"]
    assert np.array_equal(copy.evaluate(20_002, designs), problem.evaluate(20_002, designs))
    other = ModularEgganProblem(PARAMS, dataclasses.replace(FITNESS, budget=31))
    assert other.key() != problem.key()


def test_bad_fitness_config():
    with pytest.raises(InputError, match="warmup"):
        FitnessConfig(warmup=50, budget=40)
    with pytest.raises(InputError, match="fitness.source"):
        FitnessConfig(source="oracle")
    with pytest.raises(InputError, match="fitness.lookups"):
        FitnessConfig(lookups=0)


def test_random_designs_are_uniform_over_the_designs_the_rule_simulates():
    problem = ModularEgganProblem(PARAMS, FITNESS)
    designs = problem.random_designs(np.random.default_rng(0), 4000)
    assert not any(PARAMS.fitness.skips(d) for d in designs)
    assert problem.random_designs(np.random.default_rng(0), 4000) == designs  # seeded
    # 1296 valid designs (no empty corner, at most two empty ports): each mid port is empty 1/4 of the time
    assert len(set(designs)) > 0.9 * 1296 * (1 - np.exp(-4000 / 1296))
    assert abs(np.mean([d[1] == "n" for d in designs]) - 0.25) < 0.03
    everything = ModularEgganProblem(dataclasses.replace(PARAMS, fitness=FitnessRule(invalid="simulate")), FITNESS)
    assert any(d[0] == "n" for d in everything.random_designs(np.random.default_rng(0), 200))  # no rule: any design


def fake_pool(directory, seeds, params=PARAMS):
    """Exhaustive tables whose best design depends on the terrain: an odd seed rewards wheels, an even one legs."""
    tables = []
    for seed in seeds:
        designs = all_designs()
        letter = "w" if seed % 2 else "l"
        distance = [None if params.fitness.skips(d) else float(d.count(letter)) for d in designs]
        table = pd.DataFrame({"terrain_seed": seed, "design": designs,
                              "fitness": [params.fitness.penalty if x is None else x for x in distance],
                              "distance": distance, "status": ["invalid" if x is None else "ok" for x in distance],
                              "sim_steps": [0 if x is None else 10 for x in distance], "seconds": 0.0})
        tables.append(table)
    path = directory / "pool.parquet"
    write_table(pd.concat(tables, ignore_index=True), path, "modular_exhaustive")
    return path


def table_fitness(path, **changes):
    return FitnessConfig(**{"source": "table", "train_seed_base": 20_000, "train_terrains": 3,
                            "validation_seed_base": 20_003, "validation_terrains": 1, "pool": str(path),
                            "lookups": 500, **changes})


def test_table_source_answers_the_tables_entries_and_counts_distinct_look_ups(tmp_path, fake_rollouts):
    problem = ModularEgganProblem(PARAMS, table_fitness(fake_pool(tmp_path, range(20_000, 20_004))))
    values = problem.evaluate(20_001, ["wwwwww", "llllll", "wwwwww", "nnnnnn"])[:, 0]
    assert list(values) == [6.0, 0.0, 6.0, PARAMS.fitness.penalty]  # table entries; the rule's penalty
    assert problem.evaluate(20_002, ["wwwwww", "llllll"])[:, 0].tolist() == [0.0, 6.0]  # another terrain's truth
    assert problem.real_evaluations == 4 and not fake_rollouts  # distinct valid pairs, no rollout
    problem.evaluate(20_001, ["llllll"])
    assert problem.real_evaluations == 4  # a repeat costs nothing
    assert problem.surrogate_error() is None and problem.validation_tasks() == [20_003]
    with pytest.raises(InputError, match="not a training terrain"):
        problem.evaluate(20_003, ["wwwwww"])  # the validation terrain is never a training task


def test_the_look_up_budget_stops_a_call_before_it_counts(tmp_path):
    problem = ModularEgganProblem(PARAMS, table_fitness(fake_pool(tmp_path, range(20_000, 20_004)), lookups=3))
    problem.evaluate(20_000, ["wwwwww", "llllll"])
    with pytest.raises(BudgetSpent):
        problem.evaluate(20_000, ["bbbbbb", "wlwlwl"])
    assert problem.real_evaluations == 2
    problem.evaluate(20_000, ["bbbbbb", "wwwwww"])
    assert problem.real_evaluations == 3


def test_trainers_stop_when_the_look_ups_are_spent(tmp_path):
    problem = ModularEgganProblem(PARAMS, table_fitness(fake_pool(tmp_path, range(20_000, 20_004)), lookups=60))
    trained = train(problem, NetworkConfig(latent=8, hidden=16),
                    TrainConfig(iterations=50, batch=16, tasks=2, samples=4, evolution_steps=1, log_every=5,
                                checkpoint_every=5))
    assert trained.stopped is not None and trained.stopped < 50
    assert trained.rows[-1]["iteration"] == trained.stopped and problem.real_evaluations <= 60


def test_a_missing_pool_table_names_its_file(tmp_path):
    problem = ModularEgganProblem(PARAMS, table_fitness(fake_pool(tmp_path, [20_000])))
    with pytest.raises(InputError, match="no table of pool terrain 20001"):
        problem.evaluate(20_001, ["wwwwww"])
    with pytest.raises(InputError, match="modular_pool"):
        ModularEgganProblem(PARAMS, table_fitness(tmp_path / "none.parquet")).evaluate(20_000, ["wwwwww"])
    with pytest.raises(InputError, match="overlap"):
        table_fitness(tmp_path, validation_seed_base=20_002)
