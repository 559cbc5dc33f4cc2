import json
import runpy
from pathlib import Path

import pytest

from robocompose.io import read_table, write_table
from robocompose.modular.params import ModularParams
from robocompose.modular.truth import write_committed
from robocompose.params import load_section

STAGES = Path(__file__).resolve().parents[2] / "stages"
TINY = """
modular:
  eval: {control_steps: 2, settle_steps: 5}
  experiments: {test_terrains: [1007], truth_terrains: [1007, 1008], ga_seeds: [0], generations: 1,
                random_designs: 3, ec_draws: 2}
compute: {workers: 1, cache: data/cache.parquet}
"""
SUBSET = ["llllll", "wwwwww", "bbbbbb", "nnnnnn", "lwlwlw"]


def test_exhaustive_then_baselines_write_their_tables_and_metrics(tmp_path, monkeypatch, synthetic_truth):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(TINY)
    params = load_section(ModularParams, "modular")
    # Terrain 1007: a committed one-off (all 4096 designs, made-up distances); 1008: simulated (5 designs).
    write_committed(synthetic_truth(lambda d: float(d.count("w"))), params.eval, params.fitness, seconds=1.0)
    monkeypatch.setattr("robocompose.modular.truth.all_designs", lambda: SUBSET)
    runpy.run_path(str(STAGES / "modular_exhaustive.py"), run_name="__main__")
    truth = read_table("data/modular/exhaustive.parquet", "modular_exhaustive")
    assert len(truth[truth.terrain_seed == 1007]) == 4096 and sorted(truth[truth.terrain_seed == 1008].design) == \
        sorted(SUBSET)
    metrics = json.loads(Path("reports/metrics/modular_exhaustive.json").read_text())
    assert metrics["source"] == {"1007": "committed", "1008": "simulated"} and metrics["optimum"]["1007"] == 6.0
    assert metrics["criterion"]["terrains"] == 2 and len(metrics["criterion"]["per_terrain"]) == 2
    simulated = truth[truth.sim_steps > 0].groupby("terrain_seed").size()
    assert metrics["simulated"] == {str(k): int(v) for k, v in simulated.items()}
    assert set(metrics["tallest_block_cm"]) == {"1007", "1008"}
    picture = Path("reports/plots/modular_terrains.png")  # the report's picture of the first terrains
    assert picture.stat().st_size > 5000
    first = Path("data/modular/exhaustive.parquet").read_bytes()
    runpy.run_path(str(STAGES / "modular_exhaustive.py"), run_name="__main__")  # from the cache: same bytes
    assert Path("data/modular/exhaustive.parquet").read_bytes() == first

    runpy.run_path(str(STAGES / "modular_baselines.py"), run_name="__main__")
    runs = read_table("data/modular/runs.parquet", "modular_runs")
    assert sorted(runs.method) == ["crowding", "ga20", "ga50", "random"] and (runs.terrain_seed == 1007).all()
    assert set(json.loads(Path("reports/metrics/modular_baselines.json").read_text())) == set(runs.method)
    assert "modular_baselines" in json.loads(Path("reports/timings.json").read_text())


def test_realtime_stops_with_one_line_naming_a_missing_pool_table(tmp_path, monkeypatch, capsys, synthetic_truth):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.argv", ["stages/modular_realtime.py"])
    (tmp_path / "params.yaml").write_text(TINY + "eggan_modular: {fitness: {train_seed_base: 20000, train_terrains: 2}"
                                          ", protocol: {test_terrains: [1007]}}\n")
    params = load_section(ModularParams, "modular")
    write_table(synthetic_truth(lambda d: float(d.count("w"))), "data/modular/exhaustive.parquet", "modular_exhaustive")
    write_committed(synthetic_truth(lambda d: float(d.count("l")), 20000), params.eval, params.fitness, seconds=1.0,
                    directory=Path("reports/modular/pool"))  # 20001 is missing
    with pytest.raises(SystemExit) as exit_:
        runpy.run_path(str(STAGES / "modular_realtime.py"), run_name="__main__")
    assert exit_.value.code == 2
    error = capsys.readouterr().err
    assert error.startswith("stage modular_realtime: error: reports/modular/pool/blocks-20001.parquet: training-pool "
                            "table missing") and error.count("\n") == 1
    assert not Path("data/modular/realtime.parquet").exists()
