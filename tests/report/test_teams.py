import runpy
from pathlib import Path

from robocompose.report.teams import section

STAGES = Path(__file__).resolve().parents[2] / "stages"
TINY_PARAMS = """
teams:
  chips: {n_synthetic: 4, seed: 1}
  decompose: {n_regions: 3, test_fraction: 0.5}
  coverage: {iterations: 2, n_observations: 4}
  experiments: {populations: [20, 50], generations: 1, table_5_4_chips: 1, table_5_5_chips: 1, seeds: [0],
                budgets: [15, 30, 45]}
  eggan: {iterations: 2, batch: 8, tasks: 2, samples: 16, checkpoint_every: 1, latent: 4, fitness: {}}
compute: {workers: 1}
"""


def test_section_says_not_run_yet_without_stage_outputs(tmp_path):
    text = section(tmp_path / "reports", tmp_path / "data")
    assert "Not run yet" in text and "regions.parquet" in text


def test_section_has_both_tables_beside_the_thesis_and_its_figures(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(TINY_PARAMS)
    for stage in ("decompose", "teams_baselines", "teams_eggan"):
        runpy.run_path(str(STAGES / f"{stage}.py"), run_name="__main__")
    text = section(tmp_path / "reports", tmp_path / "data")
    assert "| NSGA-II:20 | 9.4 ± 1.0 | 43.1 |" in text and "| NSGA-II:50 | 11.9 ± 1.5 | 107.6 |" in text
    assert "| No decomposition | 0.365 | 0.153 | 0.056 |" in text
    assert "| Dec + random allocation (random non-empty teams, the thesis's) | 0.732 | 0.401 | 0.062 |" in text
    assert "| Dec + uniform random robots (ours: each robot to a uniform region, regions may stay empty) | - |" in text
    assert "synthetic label chips" in text
    assert "| terrain-driven (weight 0.3) |" in text and "| random-seed Voronoi" in text
    assert "every row on the same chip x seed pairs" in text and "WARNING" not in text
    assert "(no timings)" not in text  # runtimes come from reports/timings.json
    assert "share of draws with at least one empty region" in text
    assert "| EG-GAN | 11.8 ± 0.8 | 0.02 |" in text and "| Dec + EG-GAN (best front point" in text
    assert "NSGA-II:50 > NSGA-II:20 in hypervolume" in text and "Dec + EG-GAN best at every budget" in text
    assert "EG-GAN ~ NSGA-II:50 (>= 95% of its hypervolume)" in text
    for figure in ("teams_decomposition", "teams_pareto", "teams_trajectories", "teams_coverage"):
        assert f"figures/{figure}.png" in text
        assert (tmp_path / "reports" / "figures" / f"{figure}.png").stat().st_size > 1000
