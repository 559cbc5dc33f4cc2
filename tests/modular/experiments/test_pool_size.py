"""The pool-size study: one EG-GAN-crowding and one portfolio row per test query and pool size; the portfolio of
each size is the best-on-average design set of exactly that many training terrains."""

from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from robocompose.fanout.executor import Executor
from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams, PoolSizeConfig
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments.pool_size import pool_size_study, study_sizes
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.params import build_config
from tests.modular.plugins.test_eggan_problem import fake_pool

MODULAR = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())


def test_sizes_are_capped_at_the_pool_and_include_it():
    assert study_sizes(PoolSizeConfig(sizes=[8, 16, 32, 40]), 12) == [8, 12]
    assert study_sizes(PoolSizeConfig(sizes=[8, 16]), 16) == [8, 16]


def test_the_study_trains_per_size_and_answers_from_the_tables(tmp_path):
    path = fake_pool(tmp_path, [20_000, 20_001, 20_002, 20_003])  # odd seeds reward wheels, even ones legs
    params = build_config(EgganModularParams, {
        "fitness": {"train_terrains": 2, "validation_seed_base": 20_003, "validation_terrains": 1, "pool": str(path)},
        "network": {"latent": 8, "hidden": 16, "filters": 4},
        "train": {"batch": 16, "tasks": 2, "samples": 4, "log_every": 2, "checkpoint_every": 2, "validate_every": 0},
        "protocol": {"test_terrains": [20_002, 1_010], "samples": 8}}, "test")  # 1010: a partial table's
    pool = pd.read_parquet(path)
    truth = pool[pool.terrain_seed == 20_002]  # stands in for a test terrain's table
    config = PoolSizeConfig(sizes=[1], iterations=4, queries=2, seeds=2)
    study = pool_size_study(MODULAR, params, config, pool, truth, tmp_path / "checkpoints")
    assert sorted(study.pool_terrains.unique()) == [1, 2] and set(study.method) == {"crowding", "portfolio"}
    assert set(study.terrain_seed) == {20_002}  # the study reads full tables only: nothing is simulated
    assert len(study) == 2 * (2 + 1) * 2  # sizes x (crowding's seeds + the portfolio, which has none) x queries
    assert sorted(study[study.method == "crowding"].seed.unique()) == [0, 1]
    portfolio = study[study.method == "portfolio"]
    # one legs terrain (20000): its portfolio's best design is all legs, which scores 6 on the legs test terrain
    assert (portfolio[portfolio.pool_terrains == 1].max_distance == 6.0).all()
    # ... and on its own training terrain too (6 legs); on 2 terrains (legs, wheels) its 10 designs hold both
    assert (portfolio[portfolio.pool_terrains == 1].train_max_distance == 6.0).all()
    assert (study.train_max_distance <= 6.0).all() and (study.train_max_distance > 0).all()
    assert (study.regret >= 0).all() and (study.regret == study.optimum - study.max_distance).all()
    crowding = study[study.method == "crowding"]
    assert (crowding.iterations_done == 4).all() and (crowding.lookups > 0).all()
    assert (tmp_path / "checkpoints" / "crowding_2_seed1.pt").exists()
    with Executor(workers=2) as executor:  # resumed from the checkpoints, side by side: the same table
        again = pool_size_study(MODULAR, params, config, pool, truth, tmp_path / "checkpoints", executor)
    pd.testing.assert_frame_equal(again, study)
    assert dataclasses.asdict(params.fitness)["train_terrains"] == 2  # the study does not change the params


def test_the_study_refuses_test_terrains_without_a_full_table(tmp_path):
    path = fake_pool(tmp_path, [20_000, 20_001, 20_002])
    params = build_config(EgganModularParams, {
        "fitness": {"train_terrains": 2, "validation_seed_base": 20_002, "validation_terrains": 1, "pool": str(path)},
        "protocol": {"test_terrains": [1_010]}}, "test")
    pool = pd.read_parquet(path)
    with pytest.raises(InputError, match="test_terrains: expected at least one with an exhaustive table"):
        pool_size_study(MODULAR, params, PoolSizeConfig(sizes=[1]), pool, pool[pool.terrain_seed == 20_002],
                        tmp_path / "checkpoints")
