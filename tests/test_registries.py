"""Each registry is the only list: a GLSO method and a modular learner, each one class here (what its own file
would hold) plus one registry line, run on a tiny config and reach the report's tables under their titles,
which the report reads from the artifacts the stages write (it imports no registry). Nothing else is edited:
no title table, figure group, training order or params class elsewhere."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest

from robocompose.eggan.learners import LEARNERS, Learner, Training
from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.glso.designs import random_grammar_design, run_stream
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.glso.random_search import RandomConfig
from robocompose.glso.registry import METHODS, Method, describe
from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
from robocompose.io import write_table
from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments.generative import (
    make_problem,
    method_info,
    realtime_proposers,
    seeded_realtime_table,
    train_baseline,
)
from robocompose.modular.experiments.protocol import TableAnswers
from robocompose.modular.experiments.table_designs import portfolio, predict_proposers, top_designs
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.params import build_config
from robocompose.report import eggan as eggan_report
from robocompose.report import glso as glso_report
from tests.glso.conftest import fake_objective
from tests.modular.plugins.test_eggan_problem import fake_pool


class FirstDesigns:
    """A GLSO method: the random designs of its stream, in order, learning nothing."""

    def __init__(self, config: RandomConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.stream, self.k = run_stream(seed, "first"), 0

    def propose(self, env: SearchEnv) -> Proposal:
        proposal, self.k = random_grammar_design(self.stream, self.k, 40)
        return proposal

    def tell(self, proposal: Proposal, score: float) -> None:
        pass


def test_a_registered_glso_method_runs_and_reaches_the_reports_tables_and_figure(monkeypatch, tmp_path):
    monkeypatch.setitem(METHODS, "first", Method(FirstDesigns, RandomConfig, "random", "First designs",
                                                 ("baselines",)))
    config = GLSOConfig(tasks=["flat"], methods=["first", "random"], budget=3)
    steps = pd.concat([run_search(RunSpec("flat", m, 0), config, EvaluationConfig(), objective_fn=fake_objective)
                       for m in config.methods], ignore_index=True)
    write_table(steps, tmp_path / "data" / "glso" / "steps.parquet", "glso_steps")
    (tmp_path / "reports" / "metrics").mkdir(parents=True)
    (tmp_path / "reports" / "metrics" / "glso.json").write_text(json.dumps(  # the stage's record
        {"methods": describe(), "rung": "", "mppi": EvaluationConfig().mppi.as_dict()}))
    text = glso_report.section(tmp_path / "reports", tmp_path / "data")
    rows = [line for line in text.splitlines() if line.startswith("| First designs | ")]
    assert len(rows) == 2 and rows[0].startswith("| First designs | 0% |")  # the accounting table ...
    assert rows[1].endswith("(n=1) |")  # ... and the final best's
    assert (tmp_path / "reports" / "figures" / "glso_fig8_1.png").stat().st_size > 0


@dataclass(frozen=True)
class FixedConfig:
    """A learner's settings: it trains in `iterations` x `tasks` evaluate calls (none here) and answers
    `design` to every task."""

    iterations: int = 1
    tasks: int = 1
    design: str = "wwwwww"

    def __post_init__(self) -> None:
        if len(self.design) != 6:
            raise ValueError(f"design: expected one module letter per port (6), found {self.design!r}")


def train_fixed(problem, network, config: FixedConfig, progress: bool) -> tuple[str, list[dict]]:
    return config.design, [{"iteration": 1}]


def save_fixed(design: str, problem, path: Path, meta: dict) -> Path:
    path.write_text(json.dumps({"design": design, **meta}))
    return path


def load_fixed(path: Path, problem) -> tuple[str, dict]:
    info = json.loads(path.read_text())
    return info["design"], info


def fixed_answer(design: str, samples: int):
    return lambda problem, task, query_seed, k: [design]


def test_a_registered_learner_trains_is_checked_by_its_profile_and_reaches_table_5_1(monkeypatch, tmp_path):
    # the modular world with this learner alone (the others would need their models trained first)
    monkeypatch.setitem(LEARNERS, "modular", {"fixed": Learner(
        "Fixed design", load_fixed, fixed_answer, Training(FixedConfig, train_fixed, save_fixed,
                                                           lambda settings, rows: {"design": settings.design}))})
    pool = fake_pool(tmp_path, [20_000, 20_001, 20_002])
    section = {"fitness": {"source": "table", "train_terrains": 2, "validation_seed_base": 20_002,
                           "validation_terrains": 1, "pool": str(pool), "lookups": 40},
               "evolution_steps": {}, "protocol": {"test_terrains": [1001], "queries": 2, "candidates": 1,
                                                   "ec_draws": 2}}
    with pytest.raises(InputError, match=r"^test\.baselines\.fixed\.design: expected one module letter per port"):
        build_config(EgganModularParams, {**section, "baselines": {"fixed": {"design": "ww"}}}, "test")
    with pytest.raises(InputError, match=r"^test\.baselines: expected a settings mapping for each of \['fixed'\]"):
        build_config(EgganModularParams, {**section, "baselines": {}}, "test")
    params = build_config(EgganModularParams, {**section, "baselines": {"fixed": {"design": "wlwlwl"}}}, "test")
    modular = ModularParams(EvalSettings(control_steps=10), FitnessRule(), ExperimentsConfig())
    metrics = {"fixed": train_baseline("fixed", modular, params, None, None, tmp_path)}
    assert metrics["fixed"]["method"] == "Fixed design" and metrics["fixed"]["design"] == "wlwlwl"

    (tmp_path / "truth").mkdir()
    truth = pd.read_parquet(fake_pool(tmp_path / "truth", [1001]))
    train = pd.read_parquet(pool)
    problem = make_problem(modular, params, None, None)
    pool_train = train[train.terrain_seed < 20_002]
    proposers = realtime_proposers(problem, params, tmp_path, portfolio(pool_train, 1), {1001: top_designs(truth, 1)},
                                   ["bbbbbb"], predict_proposers(problem, pool_train))
    assert list(proposers) == ["fixed", "random", "portfolio", "portfolio_greedy", "predict_knn", "predict_ridge",
                               "optimum"]
    table, _ = seeded_realtime_table(proposers, {}, problem, modular, params,
                                     TableAnswers(truth, modular.eval, modular.fitness))
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(table, data / "modular" / "realtime.parquet", "modular_realtime")
    (reports / "metrics").mkdir(parents=True)
    # what stages/modular_realtime.py and stages/train_eggan_modular.py write beside their tables
    (reports / "metrics" / "modular_realtime.json").write_text(json.dumps(
        {m: method_info(m) for m in set(table.method)}))
    (reports / "metrics" / "eggan_modular.json").write_text(json.dumps(metrics))
    text = eggan_report.section(reports, data)
    row = next(line for line in text.splitlines() if line.startswith("| Fixed design | "))
    assert "3.00 ± 0.00" in row  # wlwlwl on an odd (wheels) terrain: 3 wheels, 3 m
    assert f"| {metrics['fixed']['real_evaluations']} | - | - | - | - |" in row  # its training spend; no thesis row
    assert "| Fixed design | exact (pool tables) |" in text  # the training table
