"""Table 5.1 on partial test tables (issue 46, item 2): a candidate outside a partial table is simulated through the
evaluator and counted, never imputed; a partial terrain's optimum takes the simulated candidates in; a full table
is preferred over a partial one; a test terrain with neither is refused naming the command that measures it."""

import json

import pandas as pd
import pytest

from robocompose.cli import main
from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import Result
from robocompose.modular.experiments import protocol
from robocompose.modular.experiments.generative import make_problem
from robocompose.modular.experiments.held_out import (
    FULL,
    design_set_record,
    held_out_metrics,
    held_out_tables,
    read_partial,
)
from robocompose.modular.experiments.protocol import TableAnswers, realtime_table, table_proposers
from robocompose.modular.experiments.table_designs import top_designs
from robocompose.modular.truth import write_committed
from robocompose.params import build_config
from tests.modular.experiments.test_generative import MODULAR, SECTION
from tests.modular.test_cli import TINY


def legs(design: str) -> float:
    return design.count("l") / 2


@pytest.fixture
def simulated(monkeypatch):
    """The evaluator faked (distance = legs / 2, as the synthetic tables); the (terrain, designs) it was asked."""
    calls = []

    def fake(designs, terrain_seed, settings, rule, cache=None, executor=None, save_every=0):
        calls.append((terrain_seed, list(designs)))
        return [Result(None, "invalid", 0, 0.0) if rule.skips(d) else Result(legs(d), "ok", 10, 0.01)
                for d in designs]

    monkeypatch.setattr(protocol, "evaluate_designs", fake)
    return calls


def partial_truth(synthetic_truth) -> pd.DataFrame:
    """Terrain 1008's table over the valid designs with at most three legs: its set's optimum is 1.5 m, the
    terrain's (all six legs) 3 m."""
    table = synthetic_truth(legs, 1008)
    return table[(table.status != "invalid") & (table.design.str.count("l") <= 3)].reset_index(drop=True)


def test_a_candidate_outside_a_partial_table_is_simulated_counted_and_raises_the_optimum(simulated, synthetic_truth):
    full = synthetic_truth(lambda d: float(d.count("w")), 1007)
    truth = pd.concat([full, partial_truth(synthetic_truth)], ignore_index=True)
    params = build_config(EgganModularParams, {**SECTION, "protocol": {"test_terrains": [1007, 1008], "queries": 2,
                                                                       "candidates": 4, "ec_draws": 3}}, "test")
    chosen = ["lwlwlw", "bwbbwb", "nnnnnn", "lllwll"]  # lllwll (2.5 m on 1008) is outside 1008's table
    optima = {seed: top_designs(table, 4) for seed, table in truth.groupby("terrain_seed")}
    answers = TableAnswers(truth, MODULAR.eval, MODULAR.fitness)
    table, _ = realtime_table(table_proposers(chosen, optima), make_problem(MODULAR, params, None, None), MODULAR,
                              params, answers)
    assert {seed for seed, _ in simulated} == {1008}  # the full table answers every design
    assert "lllwll" in answers.simulated[1008] and "nnnnnn" not in answers.simulated[1008]  # skipped: no rollout
    assert answers.rollouts[1007] == 0 and answers.rollouts[1008] == len(answers.simulated[1008])
    assert all(d not in set(truth[truth.terrain_seed == 1008].design) for d in answers.simulated[1008])
    rows = table.set_index(["method", "terrain_seed"])
    assert (rows.loc[("portfolio", 1008), "max_distance"] == 2.5).all()  # measured by the evaluator, not imputed
    assert (rows.loc[("portfolio", 1008), "optimum"] == 2.5).all()  # the set's 1.5 m plus the simulated candidate
    assert (rows.loc[("optimum", 1008), "regret"] == 1.0).all()  # the set's own best is now 1 m below
    assert (rows.loc[("optimum", 1007), "regret"] == 0).all() and (rows.loc[("optimum", 1007), "optimum"] == 6).all()
    metrics = held_out_metrics(truth, {1007: FULL, 1008: "balanced"}, answers)
    assert metrics["full"] == [1007] and metrics["rollouts_outside_tables"] == answers.rollouts[1008] >= 1
    assert metrics["partial"]["1008"]["table_optimum"] == 1.5 and metrics["partial"]["1008"]["optimum"] == 2.5


def test_full_tables_are_preferred_and_a_terrain_without_a_table_is_refused_naming_the_command(tmp_path,
                                                                                                synthetic_truth):
    full = synthetic_truth(lambda d: float(d.count("w")), 1007)
    chosen = design_set_record("balanced", ["llllll", "lwlwlw"])
    for seed in (1007, 1008):  # a partial table of 1007 too, with other numbers: the full one wins
        part = partial_truth(synthetic_truth).assign(terrain_seed=seed)
        write_committed(part, MODULAR.eval, MODULAR.fitness, 1.0, tmp_path, chosen)
    truth, sources = held_out_tables([1007, 1008], full, MODULAR.eval, MODULAR.fitness, tmp_path)
    assert sources == {1007: FULL, 1008: "balanced"}
    pd.testing.assert_frame_equal(truth[truth.terrain_seed == 1007].reset_index(drop=True), full)
    assert len(truth[truth.terrain_seed == 1008]) == len(partial_truth(synthetic_truth))
    with pytest.raises(InputError, match=r"test_terrains: terrain 1009 has no table .* robocompose modular "
                                         r"exhaustive --terrain-seed 1009 --design-set balanced$"):
        held_out_tables([1007, 1009], full, MODULAR.eval, MODULAR.fitness, tmp_path)
    other = build_config(type(MODULAR.fitness), {"penalty": -5.0}, "test")  # measured under another rule: refused
    with pytest.raises(InputError, match="terrain 1008 has no table"):
        held_out_tables([1008], full, MODULAR.eval, other, tmp_path)
    assert read_partial(1008, MODULAR.eval, MODULAR.fitness, tmp_path, chosen) is not None
    assert read_partial(1008, MODULAR.eval, MODULAR.fitness, tmp_path, design_set_record("top", ["llllll"])) is None


def test_exhaustive_measures_a_design_set_as_a_partial_table_and_keeps_it(tmp_path, capsys, monkeypatch, cli_error):
    monkeypatch.setattr("robocompose.modular.family_truth.design_set", lambda name: ["llllll", "wwwwww"])
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    flags = ["modular", "exhaustive", "--terrain-seed", "1010", "--design-set", "balanced", "--out-dir",
             str(tmp_path / "partial"), "--params", str(params)]
    assert main(flags) == 0
    assert json.loads(capsys.readouterr().out)["source"] == "measured"
    record = json.loads((tmp_path / "partial" / "blocks-1010.json").read_text())
    assert record["designs"] == record["simulated"] == 2 and record["design_set"] == "balanced"
    assert record["design_set_digest"] == design_set_record("balanced", ["wwwwww", "llllll"])["design_set_digest"]
    assert main(flags) == 0 and json.loads(capsys.readouterr().out)["source"] == "kept"
    cli_error(["modular", "exhaustive", "--terrain-seed", "1010", "--design-set", "balanced", "--out-dir",
               "measured/modular/exhaustive", "--params", str(params)],
              "--out-dir measured/modular/exhaustive", "a directory for partial tables")


def test_the_rollouts_outside_the_tables_round_trip_through_their_committed_file_and_are_not_simulated_again(
        tmp_path, monkeypatch):
    """What a run simulated outside a partial table is written as evaluation-cache rows; served from that file, the
    next run asks the evaluator nothing and still counts the candidate as outside the table."""
    from robocompose.fanout.cache import EvaluationCache, committed_cache
    from robocompose.io import write_table
    from robocompose.modular import evaluate
    from robocompose.modular.experiments.held_out import outside_rollouts

    settings_hash = MODULAR.eval.settings_hash()
    cache = EvaluationCache()
    cache.put(("lllwll", evaluate.task_id(1008), settings_hash, evaluate.SEED), reward=2.5, status="ok",
              sim_steps=10, seconds=0.01)
    cache.put(("wwwwww", evaluate.task_id(1008), settings_hash, evaluate.SEED), reward=9.0, status="ok",
              sim_steps=10, seconds=0.01)  # in the cache, but no candidate of this run: not committed
    answers = TableAnswers(pd.DataFrame(columns=["terrain_seed", "design", "fitness", "distance", "status"]),
                           MODULAR.eval, MODULAR.fitness)
    answers.simulated = {1008: ["lllwll"]}
    rows = outside_rollouts(answers, cache)
    assert list(rows.design_id) == ["lllwll"] and list(rows.reward) == [2.5]
    write_table(rows, tmp_path / "outside.parquet", "eval_cache")

    def no_rollout(*args, **kwargs):
        raise AssertionError("simulated a committed candidate")

    monkeypatch.setattr(evaluate, "simulate", no_rollout)
    served = evaluate.evaluate_designs(["lllwll"], 1008, MODULAR.eval, MODULAR.fitness,
                                       committed_cache(tmp_path / "outside.parquet"))
    assert served[0].distance == 2.5 and served[0].status == "ok"
