"""The EG-GAN report section: Table 5.1 rows with thesis numbers, failures as counts, the plain verdict; the
portfolio and oracle rows and DQN's ceiling from the stage's metrics; Table 5.2 with the thesis's numbers."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from robocompose.io import write_table
from robocompose.io.errors import ArtifactError
from robocompose.modular.experiments.generative import method_info, realtime_methods
from robocompose.report.eggan import section
from robocompose.report.verdicts import find


def _table() -> pd.DataFrame:
    rows = []
    for method, best, distinct in (("crowding", 6.0, 4), ("ga", 5.5, 2), ("fit2form", 5.0, 1), ("molgan", 4.5, 2),
                                   ("dqn", 5.5, 3), ("random", 3.0, 1), ("portfolio", 6.5, 2), ("optimum", 7.0, 5)):
        for query in range(3):
            rows.append({"method": method, "terrain_seed": 1000, "query": query, "candidates": 10, "valid": 10,
                         "best_design": "wwwwww", "max_distance": best if query else np.nan, "distinct": distinct,
                         "ec_distance": best - 1, "ec_failures": 0, "optimum": 7.0, "regret": 7.0 - best,
                         "training_seed": 0})
    return pd.DataFrame(rows)


def _stage_metrics(reports, realtime: dict | None = None, eggan: dict | None = None) -> None:
    """The metrics of `modular_realtime` (each row's title and whether it is learned, as the stage writes them,
    beside `realtime`) and of `train_eggan_modular` (`eggan`, else a training record per learner)."""
    (reports / "metrics").mkdir(parents=True, exist_ok=True)
    rows = {m: method_info(m) for m in realtime_methods()}
    (reports / "metrics" / "modular_realtime.json").write_text(json.dumps({**rows, **(realtime or {})}))
    trained = {m: {"method": info["title"], "real_evaluations": 100} for m, info in rows.items() if info["learned"]}
    (reports / "metrics" / "eggan_modular.json").write_text(json.dumps(trained if eggan is None else eggan))


def test_section_has_table_5_1_with_thesis_numbers_and_a_verdict(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports)
    metrics = json.loads((reports / "metrics" / "eggan_modular.json").read_text())
    metrics["crowding"] = {"method": "EG-GAN-crowding", "iterations": 10, "real_evaluations": 400,
                           "surrogate_heldout": {"mae": 1.0, "rmse": 1.2, "spearman": 0.6, "heldout": 80,
                                                 "real_std": 2.0}}
    (reports / "metrics" / "eggan_modular.json").write_text(json.dumps(metrics))
    text = section(reports, data)
    assert "| EG-GAN-crowding | 6.00 ± 0.00 | 4.0 ± 0.0 | 5.00 ± 0.00 | 1.00 ± 0.00 | 1 / 0 | 400 | - | 5.73 ± 0.22" \
        in text  # a stage record without training seeds: the spread over terrains x queries
    assert "| Random sampling | 3.00" in text and "0.86 ± 0.81" in text  # the thesis's hand-crafted row
    assert "EG-GAN-crowding beats random sampling" in text and "has more distinct solutions than EG-GAN" in text
    assert "It does not beat the terrain-agnostic portfolio (6.50 m). It reaches 86% of the exhaustive optimum" in text
    [stated] = [f for f in find(text) if f.claim.startswith("EG-GAN-crowding the farthest")]  # the summary lists it
    assert stated.outcome == "does NOT hold" and "the farthest other Portfolio" in stated.detail
    portfolio = "| Portfolio (terrain-agnostic baseline) | 6.50 ± 0.00 | 2.0 ± 0.0 | 5.50 ± 0.00 | 0.50 ± 0.00 |"
    assert f"{portfolio} 1 / 0 | - | - | - | - | - | - |" in text  # a row the thesis does not have, not trained
    assert "| Exhaustive optimum (oracle) | 7.00 ± 0.00 | 5.0 ± 0.0 | 6.00 ± 0.00 | 0.00 ± 0.00 |" in text
    assert "DQN builds" not in text  # no ceiling without the stage's metrics
    dqn = next(line for line in text.splitlines() if line.startswith("| DQN |"))
    assert dqn.startswith("| DQN | 5.50 ± 0.00 | 3.0 ± 0.0 |")
    assert dqn.endswith("| 4.31 ± 0.26 | 2.7 ± 0.9 | 3.10 ± 0.92 | - |")  # the thesis's numbers beside ours
    assert "not built" not in text
    molgan = next(line for line in text.splitlines() if line.startswith("| MolGAN |"))
    assert molgan.startswith("| MolGAN | 4.50 ± 0.00 | 2.0 ± 0.0 | 3.50 ± 0.00 |")
    assert molgan.endswith("| 3.82 ± 0.55 | 1.8 ± 0.3 | 2.93 ± 1.00 | - |")  # the thesis's numbers beside ours
    assert "| EG-GAN-crowding | 6.00 ± 0.00 | 4.0 ± 0.0 | not benchmarked" in text  # Table 5.2 without a bench
    (reports / "benchmarks.json").write_text(json.dumps({"eggan.modular.query_ms": 1.234}))
    assert "| 1.2 ms per query | 1000 | 5.73 ± 0.22 | 5.8 ± 1.5 | 0.003 |" in section(reports, data)


def test_the_table_rows_and_dqns_ceiling_come_from_the_stage_metrics(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports, {
        "portfolio_designs": {"pool_terrains": 40, "designs": ["wnbwnw", "bnbwnw"], "greedy": ["wnbwnw", "lblbwb"]},
        "dqn_symmetric_ceiling": {"terrains": 10, "designs": 64, "ceiling": 2.7876, "best_design": "wnwwnw",
                                  "best_design_mean": 2.2283}})
    text = section(reports, data)
    assert "| DQN (symmetric designs only: ceiling 2.79 m) | 5.50 ± 0.00 |" in text
    assert "the best symmetric design of each terrain averages 2.79 m" in text and "`wnwwnw`, 2.23 m" in text
    assert "same 2 designs, those of highest mean fitness over the training pool's 40 exhaustive tables" in text
    assert "`wnbwnw`, `bnbwnw`" in text and "Exhaustive optimum (oracle): each test terrain's" in text
    assert "Portfolio, greedy" not in text  # the table has no greedy row: no paragraph on it
    write_table(pd.concat([_table(), _table().query("method == 'portfolio'").assign(method="portfolio_greedy")]),
                data / "modular" / "realtime.parquet", "modular_realtime")
    text = section(reports, data)
    assert "Portfolio, greedy (terrain-agnostic): the same 2 designs" in text and "`wnbwnw`, `lblbwb`." in text
    diverse = _table().query("method == 'crowding'").assign(method="crowding_diverse")
    write_table(pd.concat([_table(), diverse]), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports, {"diverse_query": {"min_hamming": 2}})
    text = section(reports, data)
    row = next(line for line in text.splitlines() if line.startswith("| EG-GAN-crowding, diverse query |"))
    assert "| 1 / 0 | 100 | - |" in row  # the spend of the crowding generator that answers it; no thesis row
    assert "each skipped if it is within 1 port(s) of one already taken (pairwise Hamming distance >= 2)" in text


def test_section_says_what_is_missing(tmp_path):
    assert "Not run yet" in section(tmp_path / "reports", tmp_path / "data")


def test_a_row_without_a_title_or_a_learner_without_training_stops_the_report(tmp_path):
    """The rows and titles are the stages': a method the realtime metrics do not name, or a learner with no
    training metrics, is an error naming it, never a row silently left out."""
    data, reports = tmp_path / "data", tmp_path / "reports"
    table = _table()
    write_table(pd.concat([table, table[table.method == "ga"].assign(method="sgd")]),
                data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports)
    with pytest.raises(ArtifactError, match=r"modular_realtime\.json: no title for method 'sgd'"):
        section(reports, data)
    write_table(table, data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports, eggan={"crowding": {"method": "EG-GAN-crowding", "real_evaluations": 1}})
    with pytest.raises(ArtifactError, match=r"EG-GAN is a learner, but eggan_modular\.json has no training metrics"):
        section(reports, data)


def test_fig_5_1_is_drawn_from_the_stage_records(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports)
    assert "Fig. 5.1" not in section(reports, data)
    heights = np.zeros((50, 20), dtype=np.float32)
    heights[10:20, 5:8] = 0.125
    records = [{"terrain_seed": 1000, "heights": heights.tolist(), "designs": ["wwwwww", "llllll", "wlwlwl"],
                "constraint": ["w", 1], "surviving": ["llllll"]},
               {"terrain_seed": 1001, "heights": np.zeros((50, 20)).tolist(), "designs": ["bbbbbb"],
                "constraint": ["b", 0], "surviving": []}]
    (data / "modular" / "fig5_1.json").write_text(json.dumps(records))
    text = section(reports, data)
    assert "Constraints drawn: terrain 1000: at most 1 wheels; terrain 1001: at most 0 leg-wheels." in text
    assert "![Fig. 5.1](figures/eggan_fig5_1.png)" in text
    assert (reports / "figures" / "eggan_fig5_1.png").stat().st_size > 5000


def test_training_lines_flag_a_discriminator_at_chance_and_draw_the_validation_curves(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    (reports / "plots").mkdir(parents=True)
    common = {"fitness_source": "table", "iterations": 5000, "evaluation_budget": 20000, "surrogate_heldout": None}
    _stage_metrics(reports, eggan={
        "crowding": {**common, "method": "EG-GAN-crowding", "iterations_done": 1200, "real_evaluations": 19990,
                     "evolution": "crowding", "training_terrains": {"train_max_distance": 3.1, "train_regret": 0.1},
                     "final": {"d_accuracy": 0.81, "pop_new": 0.7, "val_max_distance": 2.4, "val_regret": 0.3}},
        "ga": {**common, "method": "EG-GAN", "iterations_done": 5000, "real_evaluations": 9000, "evolution": "ga",
               "final": {"d_accuracy": 0.52, "val_max_distance": 2.0, "val_regret": 0.7}},
        "dqn": {**common, "method": "DQN", "iterations_done": 150, "real_evaluations": 2500,
                "final": {"val_max_distance": 2.1, "val_regret": 0.6}},
        **{m: {**common, "method": m, "real_evaluations": 1} for m in ("fit2form", "molgan")}})
    for variant in ("crowding", "ga"):
        pd.DataFrame({"iteration": [50, 100], "d_accuracy": [0.5, 0.6],
                      "val_max_distance": [np.nan, 2.0]}).to_csv(reports / "plots" / f"eggan_modular_{variant}.csv")
    text = section(reports, data)
    assert ("| EG-GAN-crowding | exact (pool tables) | 1200 / 5000 | 19990 / 20000 | 0.81 (0.85) | 3.10 | 2.40 | 0.30 "
            "| - |" in text)
    assert "| DQN | exact (pool tables) | 150 / 5000 | 2500 / 20000 | - | - | 2.10 |" in text
    assert "**Discriminator at chance** (accuracy within 0.05 of 0.5 at the end of training): EG-GAN." in text
    assert (reports / "figures" / "eggan_modular_validation.png").stat().st_size > 0
    assert "![validation curves](figures/eggan_modular_validation.png)" in text


def test_the_pool_table_comes_from_the_pool_stage_metrics(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports)
    split = {"terrains": 2, "distinct_optima": 2, "average_design": "llllll", "mean_regret": 3.0,
             "regret_ratio": 0.4615}
    (reports / "metrics" / "modular_pool.json").write_text(json.dumps({
        "training": {"seeds": [20000, 20001], **split}, "validation": {"seeds": [20040, 20040], **split, "terrains": 1},
        "by_size": {"8": {**split, "mean_regret": 1.25}}, "simulated_designs": 3888}))
    text = section(reports, data)
    assert "| training | 2 (20000..20001) | 2 | `llllll` | 3.00 | 46% |" in text
    assert "| validation | 1 (20040..20040) |" in text and "8 terrains: `llllll` 1.25 m" in text


def test_the_pool_size_study_is_a_table_and_a_figure(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports)
    rows = _table()
    rows = rows[rows.method.isin(["crowding", "portfolio"])]
    study = pd.concat([rows.drop(columns="training_seed").assign(pool_terrains=n, seed=0, iterations_done=900,
                                                                 lookups=5000 * n, train_max_distance=6.5)
                       for n in (8, 16)])
    study.loc[(study.pool_terrains == 16) & (study.method == "crowding"), "max_distance"] += 1.0
    write_table(study, data / "modular" / "pool_size.parquet", "modular_pool_size")
    text = section(reports, data)
    assert "| 8 | EG-GAN-crowding | 1 | 6.00 ± 0.00 | 1.00 ± 0.00 | 6.50 ± 0.00 | 900 / 40000 |" in text
    assert "| 16 | EG-GAN-crowding | 1 | 7.00 ± 0.00 |" in text
    assert "| 16 | Portfolio (terrain-agnostic baseline) |" in text
    assert (reports / "figures" / "eggan_modular_pool_size.png").stat().st_size > 0


def test_the_verdict_tests_crowding_against_the_others_paired_by_terrain(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    rng = np.random.default_rng(0)
    rows = []
    for seed in range(1000, 1010):
        base = rng.uniform(1, 3)
        for method, lift in (("crowding", 1.0), ("ga", 0.9), ("random", 0.0), ("portfolio", 1.0)):
            rows.append({"method": method, "terrain_seed": seed, "query": 0, "candidates": 10, "valid": 10,
                         "best_design": "wwwwww", "max_distance": base + lift + (rng.normal(0, 0.3) if method == "ga"
                                                                                 else 0.0),
                         "distinct": 2, "ec_distance": base, "ec_failures": 0, "optimum": 9.0, "regret": 1.0,
                         "training_seed": 0})
    write_table(pd.DataFrame(rows), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports)
    text = section(reports, data)
    assert "Paired by terrain (Wilcoxon signed-rank, 10 terrains): EG-GAN-crowding against every other row but " \
        "the oracle, Holm-corrected over each best-of-k's family of comparisons (2 at best of 10)" in text
    header = "| EG-GAN-crowding vs | paired terrains | best of 10: p | best of 10: Holm p |"
    lines = text.splitlines()
    start = lines.index(header)
    rows = {cells[0]: cells[1:] for cells in ([c.strip() for c in line.strip("|").split("|")]
                                              for line in lines[start + 2:lines.index("", start)])}
    assert set(rows) == {"Random sampling", "EG-GAN"}  # no difference to the portfolio on any terrain: no test
    # crowding is 1 m above random on every terrain: the smallest two-sided p of 10 pairs, 2 / 2^10, doubled by Holm
    assert rows["Random sampling"] == ["10", "0.002", "0.004"]
    ga_p, ga_holm = map(float, rows["EG-GAN"][1:])
    assert ga_holm == max(ga_p, 0.004)  # the larger p: step-down, kept monotone


def test_the_best_of_k_table_and_a_holm_family_per_k_cover_every_row_but_the_oracle(tmp_path):
    """With the stage's best-of-k record: a table of every row's best of 1, 3 and 10 with its look-ups, and per k
    the tests of EG-GAN-crowding against every other row (the oracle excluded), Holm-corrected within that k."""
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    rng = np.random.default_rng(1)
    terrains = [str(seed) for seed in range(1000, 1010)]
    lifts = {"crowding": 1.0, "ga": 0.9, "fit2form": 0.0, "molgan": 0.0, "dqn": 0.0, "random": -1.0,
             "portfolio": 1.0, "optimum": 3.0}
    base = dict(zip(terrains, rng.uniform(1, 3, 10), strict=True))
    per_terrain = {m: {str(k): {t: base[t] + lift + (k == 1) * (m == "crowding") + rng.normal(0, 0.3) * (m == "ga")
                                for t in terrains} for k in (1, 3, 10)} for m, lift in lifts.items()}
    methods = {m: {str(k): {"mean": 2.0 + (k == 10), "std": 0.5, "no_valid": int(m == "random" and k == 1),
                            "lookups": float(k)} for k in (1, 3, 10)} for m in lifts}
    _stage_metrics(reports, {"best_of": {"ks": [1, 3, 10], "methods": methods, "per_terrain": per_terrain}})
    text = section(reports, data)
    assert "| method | best of 1 (m) | look-ups per query | best of 3 (m) | look-ups per query | best of 10 (m) |" \
        in text
    assert "| Random sampling | 2.00 ± 0.50 (1 without a valid one) | 1 | 2.00 ± 0.50 | 3 | 3.00 ± 0.50 | 10 |" in text
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| EG-GAN-crowding vs |"))
    rows = {cells[0]: cells[1:] for cells in ([c.strip() for c in line.strip("|").split("|")]
                                              for line in lines[start + 2:lines.index("", start)])}
    # every row but crowding itself and the oracle; the portfolio only at best of 1, where crowding leads it by 1 m
    assert set(rows) == {"EG-GAN", "Fit2form", "MolGAN", "DQN", "Random sampling",
                         "Portfolio (terrain-agnostic baseline)"}
    assert "(6 at best of 1, 5 at best of 3, 5 at best of 10)" in text
    assert rows["Portfolio (terrain-agnostic baseline)"] == ["10", "0.002", "0.012", "-", "-", "-", "-"]
    # four rows 1 m below on every terrain at best of 10: p 0.002 each, Holm x5, x4, ... kept monotone -> 0.010
    assert rows["Fit2form"][5:] == ["0.002", "0.010"] and rows["Random sampling"][5:] == ["0.002", "0.010"]


def test_partial_test_tables_are_named_with_their_rollouts_and_the_optimum_as_a_lower_bound(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    write_table(_table(), data / "modular" / "realtime.parquet", "modular_realtime")
    _stage_metrics(reports, {"test_tables": {"full": [1000], "partial": {}, "rollouts_outside_tables": 0}})
    assert "Test tables:" not in section(reports, data)  # every terrain exhaustive: nothing to say
    partial = {"1010": {"design_set": "balanced", "designs": 400, "table_optimum": 2.5, "optimum": 2.6,
                        "rollouts": 12},
               "1011": {"design_set": "balanced", "designs": 400, "table_optimum": 2.4, "optimum": 2.4, "rollouts": 3}}
    _stage_metrics(reports, {"test_tables": {"full": [1000], "partial": partial, "rollouts_outside_tables": 15}})
    text = section(reports, data)
    assert "1 terrains have their exhaustive table (all designs: 1000); 2 have a partial one" in text
    assert "`balanced` (400 designs): 1010, 1011" in text and "15 candidate rollouts outside the partial" in text
    assert "a lower bound on its true optimum" in text and "within 0.001 m" in text
    assert "beat the set on 1 of the 2 partial terrains" in text


def test_learned_rows_show_the_mean_and_sd_over_their_training_seeds(tmp_path):
    """With the stage's record over training seeds, a learned row of Table 5.1 and of the best-of-k table is the mean
    ± sd of its seeds' means, with its number of seeds; an unlearned row keeps the spread over terrains x queries."""
    data, reports = tmp_path / "data", tmp_path / "reports"
    table = _table()
    seeded = table[table.method == "crowding"]
    write_table(pd.concat([table, seeded.assign(training_seed=1), seeded.assign(training_seed=2)]),
                data / "modular" / "realtime.parquet", "modular_realtime")

    def over(mean: float, sd: float | None) -> dict:
        return {"mean": mean, "sd": sd, "per_seed": {}}

    seeds = {"seeds": [0, 1, 2], "n": 3, "max_distance": over(5.5, 0.25), "distinct": over(4.0, 0.5),
             "ec_distance": over(4.5, 0.125), "regret": over(1.5, 0.25), "best_of_1": over(3.0, 0.5),
             "best_of_10": over(5.5, 0.25)}
    best_of = {"ks": [1, 10], "per_terrain": {},
               "methods": {m: {str(k): {"mean": 2.0, "std": 1.0, "no_valid": 0, "lookups": float(k)} for k in (1, 10)}
                           for m in set(table.method)}}
    _stage_metrics(reports, {"crowding": {**method_info("crowding"), "training_seeds": seeds}, "best_of": best_of})
    text = section(reports, data)
    row = next(line for line in text.splitlines() if line.startswith("| EG-GAN-crowding |"))
    assert row.startswith("| EG-GAN-crowding | 5.50 ± 0.25 | 4.0 ± 0.5 | 4.50 ± 0.12 | 1.50 ± 0.25 | 3 / 0 | 100 | 3 |")
    assert "| Random sampling | 3.00 ± 0.00 | 1.0 ± 0.0 | 2.00 ± 0.00 | 4.00 ± 0.00 | 1 / 0 | - | - |" in text
    assert "mean ± sd over their training seeds (3 seeds: 0, 1, 2; column `training seeds`)" in text
    assert "n seeds = 1" not in text
    assert "| EG-GAN-crowding | 3.00 ± 0.50 | 1 | 5.50 ± 0.25 | 10 |" in text  # best of k over the seeds
    assert "| Random sampling | 2.00 ± 1.00 | 1 | 2.00 ± 1.00 | 10 |" in text
    _stage_metrics(reports, {"crowding": {**method_info("crowding"), "training_seeds": {
        **seeds, "seeds": [0], "n": 1, "max_distance": over(5.5, None)}}})
    text = section(reports, data)
    assert "| EG-GAN-crowding | 5.50 | 4.0 ± 0.5 |" in text and "n seeds = 1: one training seed per learner" in text


def test_the_table_says_which_rows_kept_their_best_validation_checkpoint():
    from robocompose.report.eggan import _selection_lines

    titles = {"crowding": "EG-GAN-crowding", "dqn": "DQN", "portfolio": "Portfolio"}
    metrics = {"crowding": {"best_iteration": 100}, "dqn": {}}
    [text, _] = _selection_lines(metrics, titles)
    assert text.startswith("Model selection differs: EG-GAN-crowding keep the checkpoint best on the validation")
    assert "; DQN report their final model." in text and "Portfolio" not in text  # untrained rows are not named
    assert _selection_lines({"crowding": {"best_iteration": 100}}, titles) == []  # no asymmetry, no paragraph
