import json

import pandas as pd
import pytest

from robocompose.io import write_table
from robocompose.io.errors import ArtifactError
from robocompose.modular.experiments.baselines import METHODS
from robocompose.modular.robot import all_designs
from robocompose.modular.terrain import TerrainConfig
from robocompose.modular.truth import exhaustive_metrics
from robocompose.report.modular import section
from robocompose.report.verdicts import find

MODULAR = {"eval": {"control_steps": 2, "sim_steps_per_control": 20, "time_step": 0.25,
                    "terrain": {"x_range": [-1.0, 5.0], "max_height_range": [0.0, 0.4]}},
           "experiments": {"ec_draws": 5}}


def _tables(data):
    designs = all_designs()
    truth = []
    for seed, module in ((1011, "w"), (1012, "l")):  # wheels best on 1011, legs on 1012
        distance = [float(d.count(module)) for d in designs]
        truth.append(pd.DataFrame({"terrain_seed": seed, "design": designs, "fitness": distance,
                                   "distance": distance, "status": "ok", "sim_steps": 100, "seconds": 0.2}))
    metrics = exhaustive_metrics(pd.concat(truth), {1011: "simulated", 1012: "simulated"}, 0.5, TerrainConfig())
    (data.parent / "reports" / "metrics").mkdir(parents=True, exist_ok=True)
    (data.parent / "reports" / "metrics" / "modular_exhaustive.json").write_text(json.dumps(metrics))
    rows = []
    for method, best in [("ga20", 5.0), ("ga50", 6.0), ("crowding", 6.0), ("random", 3.0)]:
        for seed in (0, 1):
            rows.append({"method": method, "terrain_seed": 1011, "seed": seed, "best_design": "wwwwww",
                         "best_distance": None if (method, seed) == ("random", 1) else best, "distinct": 2,
                         "ec_distance": 1.0, "ec_failures": seed, "ec_optimum": 2.0, "optimum": 6.0,
                         "evaluations": 10 if method == "random" else 1000, "sim_steps": 6_000_000,
                         "sim_seconds": 1200.0})
    write_table(pd.DataFrame(rows), data / "modular" / "runs.parquet", "modular_runs")
    (data.parent / "reports" / "metrics" / "modular_baselines.json").write_text(json.dumps(
        {method: {"title": title} for method, title in METHODS.items()}))  # what the stage records beside its means


def test_section_says_not_run_yet_without_stage_outputs(tmp_path):
    assert "Not run yet" in section(tmp_path / "reports", tmp_path / "data", MODULAR)


def test_section_shows_the_criterion_and_ours_beside_the_thesis_counting_failures(tmp_path):
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / "benchmarks.json").write_text('{"modular.steps_per_s": 5000.0}')
    _tables(tmp_path / "data")
    text = section(tmp_path / "reports", tmp_path / "data", MODULAR)
    assert "episode 2 control steps x 20 sim steps (10.0 s) on a course x in [-1, 5] m" in text
    tallest = json.loads((tmp_path / "reports" / "metrics" / "modular_exhaustive.json").read_text())["tallest_block_cm"]
    assert f"| 1011 | {tallest['1011']:.1f} | `wwwwww` |" in text  # the stage's terrain, not regenerated here
    # Optima wwwwww (6 m) and llllll (6 m); every all-leg-and-wheel design averages 3 m, the first port string
    # (llllll) is taken: regret 6 m on 1011, 0 on 1012, 50% of the mean optimum.
    assert "2 distinct optimal designs" in text and "`llllll`, loses 3.00 m" in text
    assert "50% of the mean optimum (6.00 m)" in text
    # 2 terrains, 2 optima: short of the criterion, stated as a verdict the report's summary lists
    [stated] = find(text)
    assert stated.claim.startswith("The best design depends on the terrain") and stated.outcome == "does NOT hold"
    assert "| `wwwwww` | 6.00 | 0.00 | 6.00 |" in text and "| `llllll` | 6.00 | 6.00 | 0.00 |" in text
    # GA-20: best 5 m on a 6 m optimum -> regret 1; 6e6 steps / 5000 steps/s = 20 min; 1200 s measured = 20 min.
    assert ("| GA-20 | 5.00 ± 0.00 | 2.0 ± 0.0 | 1.00 ± 0.00 | 0 of 2 | 1000 | 20.0 ± 0.0 | 20.0 ± 0.0 "
            "| 4.21 ± 1.43 | 1.8 ± 0.8 | 25.4 ± 0.7 |") in text
    assert "| GA-crowding | 6.00 ± 0.00 |" in text and "5.33 ± 0.25" in text
    # The random run without a distance is a failure, not a -10 averaged into the metres.
    assert ("| Random sampling (10 designs) | 3.00 ± 0.00 | 1 of 2 | 1.00 ± 0.00 | 1 of 10 | 2.00 ± 0.00 "
            "| 0.72 ± 0.64 | 0.63 ± 0.69 |") in text
    assert "| 1011 | 4096 | 6.00 | `wwwwww` | 1 | 1.00 ± 0.00 | 0.00 ± 0.00 | 0.00 ± 0.00 | 3.00 ± 0.00 |" in text
    assert "| 1012 | 4096 |" not in text  # not a test terrain: in the criterion only
    assert "GA-50 100%" in text and "GA-20 0%" in text
    assert "modular_terrains.png" not in text  # the modular_exhaustive stage has not drawn it
    (tmp_path / "reports" / "plots").mkdir()
    (tmp_path / "reports" / "plots" / "modular_terrains.png").write_bytes(b"png")
    assert "![test terrains and their best designs](plots/modular_terrains.png)" in section(
        tmp_path / "reports", tmp_path / "data", MODULAR)


def test_section_refuses_a_baselines_record_without_a_method_title(tmp_path):
    _tables(tmp_path / "data")
    record = tmp_path / "reports" / "metrics" / "modular_baselines.json"
    record.write_text(json.dumps({"ga20": {"title": "GA-20"}}))  # written before the stage recorded titles
    with pytest.raises(ArtifactError, match=r"modular_baselines.json: no title for methods \['ga50', 'crowding', "
                                            r"'random'\]"):
        section(tmp_path / "reports", tmp_path / "data", MODULAR)
