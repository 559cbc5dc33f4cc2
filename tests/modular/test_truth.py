import json
import os
import re
import subprocess
import sys

import pandas as pd
import pytest

from robocompose.fanout.cache import EvaluationCache
from robocompose.io.dispatch import has_baseline, pinned_environment
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.robot import mirror
from robocompose.modular.truth import (
    canonical,
    committed_path,
    exhaustive_terrain,
    pool_metrics,
    read_committed,
    terrain_criterion,
    truth_summary,
    truth_tables,
    verify_committed,
    write_committed,
)

TINY = EvalSettings(control_steps=3, settle_steps=10)
RULE = FitnessRule()
SUBSET = ["llllll", "wwwwww", "bbbbbb", "lwlwlw", "nnnnnn", "lnllnl", "wlwwlw", "bwbbwb"]


def test_exhaustive_terrain_simulates_the_valid_designs_and_summarises_the_optimum():
    cache = EvaluationCache()
    table = exhaustive_terrain(1007, TINY, RULE, cache, None, designs=SUBSET)
    assert list(table.design) == sorted(SUBSET) and (table.terrain_seed == 1007).all()
    invalid = table.set_index("design").loc["nnnnnn"]
    assert invalid.status == "invalid" and invalid.sim_steps == 0 and invalid.seconds == 0 and invalid.fitness == -10
    assert len(cache) == len(SUBSET) - 1 and (table.seconds[table.sim_steps > 0] > 0).all()
    summary = truth_summary(table, epsilon=0.5).iloc[0]
    assert summary.optimum == table.fitness.max()
    assert summary.near_optimal == int((table.fitness >= table.fitness.max() - 0.5).sum())


def test_a_committed_table_is_used_only_under_the_settings_rule_and_physics_it_was_measured_with(tmp_path):
    table = exhaustive_terrain(1007, TINY, RULE, EvaluationCache(), None, designs=SUBSET)
    path = write_committed(table, TINY, RULE, seconds=1.0, directory=tmp_path)
    assert path.name == "blocks-1007.parquet"
    pd.testing.assert_frame_equal(read_committed(1007, TINY, RULE, tmp_path), table)
    assert read_committed(1007, EvalSettings(control_steps=4, settle_steps=10), RULE, tmp_path) is None
    assert read_committed(1007, TINY, FitnessRule(penalty=-5.0), tmp_path) is None
    assert read_committed(1008, TINY, RULE, tmp_path) is None
    record = json.loads(path.with_suffix(".json").read_text())
    path.with_suffix(".json").write_text(json.dumps({**record, "physics_digest": "0" * 16}))
    assert read_committed(1007, TINY, RULE, tmp_path) is None  # other robot / terrain / gait code


def test_verify_rekeys_a_table_only_when_a_resimulated_sample_agrees_bit_for_bit(tmp_path):
    table = exhaustive_terrain(1007, TINY, RULE, EvaluationCache(), None, designs=SUBSET)
    path = write_committed(table, TINY, RULE, seconds=1.0, directory=tmp_path)
    record = json.loads(path.with_suffix(".json").read_text())
    path.with_suffix(".json").write_text(json.dumps({**record, "physics_digest": "0" * 16}))  # an older scheme
    report = verify_committed(path, sample=3, seed=0, rekey=True)
    assert report["mismatches"] == [] and report["sample"] == 3 and report["rekeyed"]
    pd.testing.assert_frame_equal(read_committed(1007, TINY, RULE, tmp_path), table)  # usable again
    assert json.loads(path.with_suffix(".json").read_text())["verified"]["from_digest"] == "0" * 16

    tampered = table.copy()
    tampered.loc[tampered.sim_steps > 0, "distance"] += 1e-12  # one ulp-scale change is a mismatch
    path = write_committed(tampered, TINY, RULE, seconds=1.0, directory=tmp_path)
    path.with_suffix(".json").write_text(json.dumps({**record, "physics_digest": "0" * 16}))
    report = verify_committed(path, sample=3, seed=0, rekey=True)
    assert len(report["mismatches"]) == 3 and not report["rekeyed"]
    assert read_committed(1007, TINY, RULE, tmp_path) is None


def test_truth_tables_read_committed_terrains_and_simulate_the_others(tmp_path, monkeypatch):
    monkeypatch.setattr("robocompose.modular.truth.all_designs", lambda: SUBSET)
    committed = exhaustive_terrain(1007, TINY, RULE, EvaluationCache(), None)
    committed.loc[committed.design == "llllll", "distance"] = 99.0  # marks the committed copy
    write_committed(committed, TINY, RULE, seconds=1.0, directory=tmp_path)
    table, sources = truth_tables([1007, 1008], TINY, RULE, EvaluationCache(), None, tmp_path)
    assert sources == {1007: "committed", 1008: "simulated"}
    assert table.set_index(["terrain_seed", "design"]).loc[(1007, "llllll"), "distance"] == 99.0
    assert sorted(table.terrain_seed.unique()) == [1007, 1008] and len(table) == 2 * len(SUBSET)


def test_a_committed_table_holds_one_terrain(tmp_path):
    two = pd.concat([exhaustive_terrain(s, TINY, RULE, EvaluationCache(), None, designs=["nnnnnn"])
                     for s in (1, 2)])
    with pytest.raises(ValueError, match="one terrain"):
        write_committed(two, TINY, RULE, 1.0, tmp_path)


def test_mirror_swaps_left_and_right_ports():
    assert mirror("lwbnnn") == "nnnbwl" and mirror(mirror("lwbnln")) == "lwbnln"
    assert canonical("nnnbwl") == canonical("lwbnnn") == "lwbnnn"


def _table(distances: dict[int, dict[str, float | None]]) -> pd.DataFrame:
    rows = []
    for seed, by_design in distances.items():
        for design, distance in by_design.items():
            rows.append({"terrain_seed": seed, "design": design, "distance": distance,
                         "fitness": -10.0 if distance is None else distance})
    return pd.DataFrame(rows)


def test_terrain_criterion_counts_optima_up_to_mirror_and_the_regret_of_the_best_average_design():
    table = _table({
        1: {"wwwwww": 4.0, "llllll": 1.0, "lwwwww": 3.0, "wwwwwl": 2.0, "bbbbbb": 9.0},
        2: {"wwwwww": 1.0, "llllll": 3.0, "lwwwww": 2.0, "wwwwwl": 2.5, "bbbbbb": None},  # bbbbbb unstable
        3: {"wwwwww": 4.0, "llllll": 2.0, "lwwwww": 1.0, "wwwwwl": 5.0, "bbbbbb": 9.0},
    })
    per_terrain, totals = terrain_criterion(table)
    assert list(per_terrain.optimum_design) == ["bbbbbb", "llllll", "bbbbbb"]
    # bbbbbb has no distance on terrain 2, so it is never averaged: the best on average is wwwwwl (9.5 / 3).
    assert totals["average_design"] == "wwwwwl" and list(per_terrain.regret) == [7.0, 0.5, 4.0]
    assert totals["distinct_optima"] == 2 and totals["mean_optimum"] == pytest.approx(7.0)
    assert totals["regret_ratio"] == pytest.approx((11.5 / 3) / 7.0)
    mirrored = _table({1: {"lwwwww": 2.0, "wwwwwl": 1.0}, 2: {"lwwwww": 1.0, "wwwwwl": 2.0}})
    assert terrain_criterion(mirrored)[1]["distinct_optima"] == 1  # each other's mirror image




def test_pool_metrics_count_each_splits_optima_and_the_regret_of_its_best_average_design(synthetic_truth):
    wheels = synthetic_truth(lambda d: d.count("w"), terrain_seed=20000)  # optimum wwwwww (6)
    legs = synthetic_truth(lambda d: d.count("l") + 1.0, terrain_seed=20001)  # optimum llllll (7)
    also_wheels = synthetic_truth(lambda d: d.count("w") + 0.5, terrain_seed=20002)
    table = pd.concat([wheels, legs, also_wheels], ignore_index=True)
    metrics = pool_metrics(table, {"training": [20000, 20001], "validation": [20002]}, sizes=[1, 2, 8])
    training = metrics["training"]
    assert training["distinct_optima"] == 2 and training["terrains"] == 2
    assert training["optimum_designs"] == {"20000": "wwwwww", "20001": "llllll"}
    # best on average: every design of legs and wheels only scores 3.5 (ties: the first port string, llllll),
    # its regret (6 - 0 + 7 - 7) / 2 = 3
    assert training["average_design"] == "llllll" and training["mean_regret"] == 3.0
    assert metrics["validation"]["distinct_optima"] == 1 and metrics["validation"]["mean_regret"] == 0.0
    assert set(metrics["by_size"]) == {"1", "2"} and metrics["by_size"]["1"]["mean_regret"] == 0.0


def test_the_physics_digest_follows_what_a_rollout_runs(monkeypatch):
    import robocompose.modular.robot as robot
    from robocompose.modular.truth import physics_digest

    before = physics_digest()
    monkeypatch.setattr(robot, "CHASSIS_MASS", robot.CHASSIS_MASS * 2)  # a part's mass: reached by the rollout
    assert physics_digest() != before
    monkeypatch.undo()
    assert physics_digest() == before


REPRODUCE = """
import json, sys
from robocompose.modular.evaluate import EvalSettings, rollouts
from robocompose.modular.terrain import generate_terrain
from robocompose.modular.truth import committed_path
seed, designs = int(sys.argv[1]), sys.argv[2:]
settings = EvalSettings(**json.loads(committed_path(seed).with_suffix(".json").read_text())["settings"])
print(json.dumps([[r.distance, r.status, r.sim_steps]
                  for r in rollouts(designs, generate_terrain(seed, settings.terrain), settings)]))
"""


@pytest.mark.skipif(not has_baseline(), reason="the committed tables were measured under the x86-64-v3 pin")
@pytest.mark.parametrize("terrain_seed, designs", [(1000, ("bbbbbb", "lwlwlw")),
                                                   (1004, ("lwbbnw", "lnllnl", "wwwwww"))])  # ok, flipped, stalled
def test_rollouts_reproduce_the_committed_tables_to_the_byte(terrain_seed, designs):
    # The tables were measured under the dispatch pin (docs/dispatch.md), the test process is not pinned:
    # the rollouts run in a pinned child process.
    out = subprocess.run([sys.executable, "-c", REPRODUCE, str(terrain_seed), *designs], capture_output=True,
                         text=True, check=True,
                         env=pinned_environment({**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})).stdout
    table = pd.read_parquet(committed_path(terrain_seed)).set_index("design")
    for design, (distance, status, sim_steps) in zip(designs, json.loads(out.splitlines()[-1]), strict=True):
        row = table.loc[design]
        assert (distance, status, sim_steps) == (row.distance, row.status, row.sim_steps)


@pytest.mark.parametrize(("change", "message"), [
    (lambda record: [record], "expected a JSON object with fields ['settings', 'fitness', 'physics_digest']"),
    (lambda record: {**record, "settings": {**record["settings"], "gravity": 9.81}},
     "settings.gravity: unknown field; expected one of"),
    (lambda record: {**record, "fitness": {**record["fitness"], "invalid": "ignore"}},
     "fitness.invalid: expected 'penalty' or 'simulate'"),
    (lambda record: {k: v for k, v in record.items() if k != "settings"}, "settings: missing field"),
    (lambda record: {**record, "physics_digest": 7}, "physics_digest: expected a string of hex digits, found 7"),
])
def test_every_reader_of_a_committed_table_refuses_a_bad_record_the_same_way(tmp_path, change, message):
    from robocompose.io.errors import InputError
    from robocompose.modular.experiments.terrain_study import directory_criterion
    from robocompose.modular.truth import read_record

    path = write_committed(exhaustive_terrain(1007, TINY, RULE, None, None, designs=["nnnnnn", "llllll"]), TINY,
                          RULE, 1.0, tmp_path)
    good = json.loads(path.with_suffix(".json").read_text())
    assert read_record(path).settings == TINY
    path.with_suffix(".json").write_text(json.dumps(change(good)))
    for read in (lambda: read_record(path), lambda: read_committed(1007, TINY, RULE, tmp_path),
                 lambda: directory_criterion(tmp_path), lambda: verify_committed(path, 1, 0),
                 lambda: truth_tables([1007], TINY, RULE, None, None, tmp_path)):
        with pytest.raises(InputError, match=re.escape(message)):
            read()
