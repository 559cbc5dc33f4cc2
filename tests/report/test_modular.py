import pandas as pd

from robocompose.io import write_table
from robocompose.modular.robot import all_designs
from robocompose.report.modular import section

TINY_PARAMS = """
modular:
  eval: {control_steps: 2, settle_steps: 5}
  experiments: {test_terrains: [11], ga_seeds: [0, 1], gallery: 1}
"""


def _tables(data):
    designs = all_designs()
    fitness = [float(d.count("w")) for d in designs]  # the optimum is wwwwww with 6 m
    truth = pd.DataFrame({"terrain_seed": 11, "design": designs, "fitness": fitness, "distance": fitness,
                          "status": "ok", "sim_steps": 100})
    write_table(truth, data / "modular" / "exhaustive.parquet", "modular_exhaustive")
    rows = []
    for method, best in [("ga20", 5.0), ("ga50", 6.0), ("crowding", 6.0), ("random", 3.0)]:
        for seed in (0, 1):
            rows.append({"method": method, "terrain_seed": 11, "seed": seed, "best_design": "wwwwww",
                         "best_fitness": best, "distinct": 2, "ec_fitness": 1.0, "ec_optimum": 2.0, "optimum": 6.0,
                         "evaluations": 1000, "sim_steps": 6_000_000})
    write_table(pd.DataFrame(rows), data / "modular" / "runs.parquet", "modular_runs")


def test_section_says_not_run_yet_without_stage_outputs(tmp_path):
    assert "Not run yet" in section(tmp_path / "reports", tmp_path / "data")


def test_section_puts_ours_beside_the_thesis_with_regret_and_the_picture(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(TINY_PARAMS)
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / "benchmarks.json").write_text('{"modular.steps_per_s": 5000.0}')
    _tables(tmp_path / "data")
    text = section(tmp_path / "reports", tmp_path / "data")
    # GA-20: best 5 m on a 6 m optimum -> regret 1; runtime 6e6 steps / 5000 steps/s = 20 min.
    assert ("| GA-20 | 5.00 ± 0.00 | 2.0 ± 0.0 | 1.00 ± 0.00 | 1000 | 20.0 ± 0.0 "
            "| 4.21 ± 1.43 | 1.8 ± 0.8 | 25.4 ± 0.7 |") in text
    assert "| GA-crowding | 6.00 ± 0.00 |" in text and "5.33 ± 0.25" in text
    assert ("| Random sampling (10 designs) | 3.00 ± 0.00 | 1.00 ± 0.00 | 2.00 ± 0.00 "
            "| 0.72 ± 0.64 | 0.63 ± 0.69 |") in text
    assert "| 11 | 4096 | 6.00 | `wwwwww` | 1 | 1.00 ± 0.00 | 0.00 ± 0.00 | 0.00 ± 0.00 | 3.00 ± 0.00 |" in text
    assert "GA-50 100%" in text and "GA-20 0%" in text
    assert (tmp_path / "reports" / "figures" / "modular_terrains.png").stat().st_size > 5000
