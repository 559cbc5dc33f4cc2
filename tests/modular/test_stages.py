import json
import runpy
from pathlib import Path

from robocompose.io import read_table

STAGES = Path(__file__).resolve().parents[2] / "stages"
TINY = """
modular:
  eval: {control_steps: 2, settle_steps: 5}
  experiments: {test_terrains: [7], ga_seeds: [0], generations: 1, random_designs: 3, ec_draws: 2}
  workers: 1
  cache: data/cache.parquet
"""
SUBSET = ["llllll", "wwwwww", "bbbbbb", "nnnnnn", "lwlwlw"]


def test_exhaustive_then_baselines_write_their_tables_and_metrics(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(TINY)
    monkeypatch.setattr("robocompose.modular.experiments.all_designs", lambda: SUBSET)  # 5 designs, not 4096
    runpy.run_path(str(STAGES / "modular_exhaustive.py"), run_name="__main__")
    truth = read_table("data/modular/exhaustive.parquet", "modular_exhaustive")
    assert sorted(truth.design) == sorted(SUBSET)
    metrics = json.loads(Path("reports/metrics/modular_exhaustive.json").read_text())
    assert metrics["optimum"]["7"] == round(truth.fitness.max(), 4)
    first = Path("data/modular/exhaustive.parquet").read_bytes()
    runpy.run_path(str(STAGES / "modular_exhaustive.py"), run_name="__main__")  # from the cache: same bytes
    assert Path("data/modular/exhaustive.parquet").read_bytes() == first

    runpy.run_path(str(STAGES / "modular_baselines.py"), run_name="__main__")
    runs = read_table("data/modular/runs.parquet", "modular_runs")
    assert sorted(runs.method) == ["crowding", "ga20", "ga50", "random"]
    assert set(json.loads(Path("reports/metrics/modular_baselines.json").read_text())) == set(runs.method)
    assert "modular_baselines" in json.loads(Path("reports/timings.json").read_text())
