import json
import runpy
import shutil
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from robocompose.io import read_table, write_table
from robocompose.modular.params import ModularParams
from robocompose.modular.truth import write_committed
from robocompose.params import load_section

STAGES = Path(__file__).resolve().parents[2] / "stages"
TINY = """
modular:
  eval: {control_steps: 2, settle_steps: 5, terrain: {}}
  fitness: {}
  experiments: {test_terrains: [1007], truth_terrains: [1007, 1008], ga_seeds: [0, 1], generations: 1,
                random_designs: 3, ec_draws: 2}
compute: {workers: 1, cache: data/cache.parquet}
"""
EGGAN_REST = "network: {}, train: {}, pool_size: {}"  # eggan_modular's other sections: their defaults
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
    simulated_best = truth[truth.terrain_seed == 1008].sort_values(["fitness", "design"], ascending=[False, True])
    assert metrics["best_design"] == {"1007": "wwwwww", "1008": simulated_best.design.iloc[0]}
    picture = plt.imread("reports/plots/modular_terrains.png")  # one 400 x 440 px column per gallery terrain
    assert picture.shape[:2] == (440, 400 * params.experiments.gallery)
    first = Path("data/modular/exhaustive.parquet").read_bytes()
    runpy.run_path(str(STAGES / "modular_exhaustive.py"), run_name="__main__")  # from the cache: same bytes
    assert Path("data/modular/exhaustive.parquet").read_bytes() == first

    runpy.run_path(str(STAGES / "modular_baselines.py"), run_name="__main__")
    runs = read_table("data/modular/runs.parquet", "modular_runs")
    assert sorted(runs.method) == sorted(["crowding", "ga20", "ga50", "random"] * 2)
    assert (runs.terrain_seed == 1007).all()
    table = truth[truth.terrain_seed == 1007].set_index("design").distance
    np.testing.assert_array_equal(runs.best_distance, table[runs.best_design])  # a real entry (NaN: unstable)
    assert (runs.optimum == 6.0).all() and (runs.best_distance.dropna() <= 6.0).all()
    assert (runs.ec_distance <= runs.ec_optimum).all()  # a constrained answer never beats the constrained best
    assert runs.groupby("method").evaluations.first().to_dict() == {"crowding": 50, "ga20": 20, "ga50": 50,
                                                                    "random": 3}
    baselines = pd.DataFrame(json.loads(Path("reports/metrics/modular_baselines.json").read_text())).T
    means = runs.groupby("method").best_distance.mean().round(4)
    pd.testing.assert_series_equal(baselines.best_distance.astype(float), means, check_names=False)
    pd.testing.assert_series_equal(baselines.regret.astype(float), (6.0 - means).round(4), check_names=False)
    assert baselines.failed_runs.to_dict() == runs.best_distance.isna().groupby(runs.method).sum().to_dict()
    assert "modular_baselines" in json.loads(Path("reports/timings.json").read_text())


def test_realtime_stops_with_one_line_naming_missing_pool_tables(tmp_path, monkeypatch, capsys, synthetic_truth):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.argv", ["stages/modular_realtime.py"])
    (tmp_path / "params.yaml").write_text(TINY + "eggan_modular: {fitness: {train_seed_base: 20000, train_terrains: 2, "
                                          "surrogate: {}}, protocol: {test_terrains: [1007]}, " + EGGAN_REST + "}\n")
    write_table(synthetic_truth(lambda d: float(d.count("w"))), "data/modular/exhaustive.parquet", "modular_exhaustive")
    with pytest.raises(SystemExit) as exit_:  # no data/modular/pool.parquet: the modular_pool stage has not run
        runpy.run_path(str(STAGES / "modular_realtime.py"), run_name="__main__")
    assert exit_.value.code == 2
    error = capsys.readouterr().err
    assert error.startswith("stage modular_realtime: error: ") and "data/modular/pool.parquet" in error
    assert error.count("\n") == 1 and not Path("data/modular/realtime.parquet").exists()


def test_pool_stage_gathers_the_committed_pool_and_summarises_each_split(tmp_path, monkeypatch, synthetic_truth):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.argv", ["stages/modular_pool.py"])
    (tmp_path / "params.yaml").write_text(TINY + "eggan_modular: {fitness: {train_seed_base: 20000, train_terrains: 2"
                                          ", validation_seed_base: 20002, validation_terrains: 1, surrogate: {}}, "
                                          "protocol: {}, " + EGGAN_REST + "}\n")
    params = load_section(ModularParams, "modular")
    for seed, module in ((20000, "w"), (20001, "l"), (20002, "b")):
        write_committed(synthetic_truth(lambda d, m=module: float(d.count(m)), seed), params.eval, params.fitness,
                        seconds=1.0, directory=Path("measured/modular/pool"))
    runpy.run_path(str(STAGES / "modular_pool.py"), run_name="__main__")
    pool = read_table("data/modular/pool.parquet", "modular_exhaustive")
    assert sorted(pool.terrain_seed.unique()) == [20000, 20001, 20002] and (pool.sim_steps > 0).sum() > 0
    metrics = json.loads(Path("reports/metrics/modular_pool.json").read_text())
    assert metrics["training"]["optimum_designs"] == {"20000": "wwwwww", "20001": "llllll"}
    assert metrics["validation"]["optimum_designs"] == {"20002": "bbbbbb"} and metrics["sources"] == ["committed"]


def test_realtime_answers_the_learned_rows_at_every_committed_training_seed(tmp_path, monkeypatch, capsys,
                                                                            synthetic_truth):
    """Stage modular_realtime with the stage's own tiny models (seed 0) and two further seeds under
    measured/modular/seeds: one set of learned rows per training seed on the same terrains and queries, the unlearned
    rows once, the metrics' mean and sd over the seeds; a seed folder trained under other settings stops the stage
    before any work, naming the file; with the README alone, one seed, and the report says so."""
    import yaml

    from robocompose.eggan.learners import training_order
    from robocompose.modular.eggan_params import EgganModularParams
    from robocompose.modular.experiments.generative import (
        learned_methods,
        realtime_methods,
        train_all,
        train_seed,
        with_seed,
    )
    from robocompose.report.eggan import section
    from tests.modular.experiments.test_training_seeds import params_of, tiny_section
    from tests.modular.plugins.test_eggan_problem import fake_pool

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.argv", ["stages/modular_realtime.py"])
    Path("data/modular").mkdir(parents=True)
    tiny = {**tiny_section(fake_pool(Path("data/modular"), [20_000, 20_001, 20_002]).as_posix()), "pool_size": {}}
    tiny["fitness"] = {**tiny["fitness"], "surrogate": {}}
    Path("params.yaml").write_text(TINY + yaml.safe_dump({"eggan_modular": tiny}))
    write_table(synthetic_truth(lambda d: float(d.count("w"))), "data/modular/exhaustive.parquet", "modular_exhaustive")
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    metrics, _ = train_all(modular, params, None, None, Path("models"))
    Path("reports/metrics").mkdir(parents=True, exist_ok=True)
    Path("reports/metrics/eggan_modular.json").write_text(json.dumps(metrics))
    seeds = Path("measured/modular/seeds")
    for seed in (1, 2):
        for method in training_order("modular"):
            train_seed(method, seed, modular, params, seeds / f"seed-{seed}")
    (seeds / "README.md").write_text("further training seeds\n")
    runpy.run_path(str(STAGES / "modular_realtime.py"), run_name="__main__")

    table = read_table("data/modular/realtime.parquet", "modular_realtime")
    learned = learned_methods()
    assert set(learned) == {"fit2form", "dqn", "molgan", "ga", "crowding", "crowding_diverse"}
    queries = {(1007, 0), (1007, 1)}
    for method, rows in table.groupby("method"):
        answered = {seed: set(zip(group.terrain_seed, group["query"], strict=True))
                    for seed, group in rows.groupby("training_seed")}
        assert answered == ({0: queries, 1: queries, 2: queries} if method in learned else {0: queries}), method
    assert len(table) == (3 * len(learned) + 6) * len(queries)  # random, the portfolios, predict rows, oracle: once
    assert list(dict.fromkeys(table.method)) == list(realtime_methods())  # Table 5.1's rows, in its order
    assert table.optimum.nunique() == 1  # one optimum for every row of the terrain, whichever seed answered
    pd.testing.assert_series_equal(table.regret, table.optimum - table.max_distance, check_names=False)
    # the seeds' models answer for themselves: not three copies of seed 0's answers
    crowding = table[table.method == "crowding"]
    assert crowding.groupby("training_seed").best_design.apply(tuple).nunique() > 1
    summary = json.loads(Path("reports/metrics/modular_realtime.json").read_text())
    assert summary["further_training_seeds"] == [1, 2] and "training_seeds" not in summary["random"]
    assert not summary["predict_knn"]["learned"] and summary["predict_ridge"]["title"] == "Predict the table, ridge"
    assert {k: summary["predict_table"][k] for k in ("pool_terrains", "neighbours", "ridge")} == \
        {"pool_terrains": 2, "neighbours": 3, "ridge": 1.0}
    for method in learned:
        over = summary[method]["training_seeds"]
        means = table[table.method == method].groupby("training_seed").max_distance.mean()
        assert over["seeds"] == [0, 1, 2] and over["n"] == 3
        assert over["max_distance"]["mean"] == round(means.mean(), 4)
        assert over["max_distance"]["sd"] == round(means.std(ddof=1), 4)
    text = section(Path("reports"), Path("data"))
    row = next(line for line in text.splitlines() if line.startswith("| EG-GAN-crowding |"))
    assert f"| {metrics['crowding']['real_evaluations']} | 3 |" in row and "mean ± sd over their training seeds" in text
    assert "| Predict the table, k-NN |" in text and "measured predictability ceiling" in text

    # a further seed trained under other settings (EG-GAN's learning rate): refused before any work
    Path("data/modular/realtime.parquet").unlink()
    train_seed("ga", 3, modular, params_of(tiny, train={"lr_generator": 3e-4}), seeds / "seed-3")
    capsys.readouterr()  # the training's progress bars
    with pytest.raises(SystemExit) as exit_:
        runpy.run_path(str(STAGES / "modular_realtime.py"), run_name="__main__")
    error = capsys.readouterr().err
    assert exit_.value.code == 2 and error.count("\n") == 1
    assert f"{seeds / 'seed-3' / 'eggan_modular_ga.pt'}: train.lr_generator: expected 0.0001" in error
    assert not Path("data/modular/realtime.parquet").exists()
    assert with_seed(params, "ga", 3).train.lr_generator == 1e-4  # the params' own setting, as the error says

    # the README alone: every learner at its one seed, and the report says so
    for folder in ("seed-1", "seed-2", "seed-3"):
        shutil.rmtree(seeds / folder)
    runpy.run_path(str(STAGES / "modular_realtime.py"), run_name="__main__")
    table = read_table("data/modular/realtime.parquet", "modular_realtime")
    assert (table.training_seed == 0).all() and len(table) == (len(learned) + 6) * len(queries)
    summary = json.loads(Path("reports/metrics/modular_realtime.json").read_text())
    assert summary["further_training_seeds"] == [] and summary["crowding"]["training_seeds"]["n"] == 1
    assert summary["crowding"]["training_seeds"]["max_distance"]["sd"] is None
    text = section(Path("reports"), Path("data"))
    assert "n seeds = 1: one training seed per learner" in text
