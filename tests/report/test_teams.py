import runpy
from pathlib import Path

from robocompose.report.teams import section
from robocompose.report.verdicts import find

STAGES = Path(__file__).resolve().parents[2] / "stages"
def test_section_says_not_run_yet_without_stage_outputs(tmp_path):
    text = section(tmp_path / "reports", tmp_path / "data")
    assert "Not run yet" in text and "regions.parquet" in text


def test_section_has_both_tables_beside_the_thesis_and_its_figures(tmp_path, monkeypatch, teams_params):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params({"populations": [20, 50], "genomes": ["fractions",
                                                                                          "share_split"],
                                                         "generations": 1, "budgets": [15, 30, 45]}))
    for stage in ("decompose", "teams_baselines", "teams_eggan", "teams_heldout"):
        runpy.run_path(str(STAGES / f"{stage}.py"), run_name="__main__")
    text = section(tmp_path / "reports", tmp_path / "data")
    # Table 5.4: every row re-measured at held-out seeds, spend and time beside it, the goal's verdict first
    assert "| NSGA-II:20, genome raw fractions (thesis) | 9.4 ± 1.0 | 43.1 |" in text
    assert "| NSGA-II:50, genome raw fractions (thesis) | 11.9 ± 1.5 | 107.6 |" in text
    assert "| EG-GAN, mean of 1 generator | 11.8 ± 0.8 | 0.02 |" in text and "no spread across training seeds" in text
    assert "| NSGA-II:20, genome share x split, stopped at EG-GAN's spend | - | - |" in text
    assert "| random allocations, front of 512 draws | - | - |" in text
    table_5_4 = text[text.index("### Table 5.4"):]
    assert table_5_4.split("\n")[2].startswith("Goal (EG-GAN >= 95% of the best NSGA-II:50 row")  # leads
    # the 4 NSGA-II rows timed alone by teams_eggan, in the run that timed EG-GAN's queries
    main = next(block for block in table_5_4.split("\n\n") if block.startswith("| method | thesis HV"))
    alone = [row for row in main.split("\n") if row.startswith("| NSGA-II:") and "stopped" not in row]
    assert len(alone) == 4 and all("(one run)" in row for row in alone), alone
    assert "timed in the same run of stage teams_eggan" in table_5_4
    assert "Holm-corrected over the 7 comparisons" in text and "| method | EG-GAN minus method |" in text
    # Table 5.5: held-out costs, a front's pick labelled, then the thesis's protocol
    assert "| No decomposition | 0.365 | 0.153 | 0.056 |" in text
    assert "| Dec + random allocation (random non-empty teams, the thesis's) | 0.732 | 0.401 | 0.062 |" in text
    assert "| Dec + uniform random robots (ours: each robot to a uniform region, regions may stay empty) | - |" in text
    assert "none of which any method searched or selected on" in text and "seed-to-seed noise" in text
    table_5_5 = text[text.index("### Table 5.5"):]
    lead = "Dec + EG-GAN lowest at every budget, at held-out seeds (thesis: it is): **"
    assert table_5_5.split("\n")[2].startswith(lead)
    # every claim the section tests is a verdict the report's summary lists: the goal, both protocols of Table 5.5
    claims = [f.claim for f in find(text)]
    assert claims[0].startswith("Goal (EG-GAN") and len(claims) == 4, claims
    assert "EG-GAN against each row at each budget" in table_5_5 and "| method | budget | EG-GAN minus method" in text
    assert "As the thesis measured it" in text and "| Dec + EG-GAN (best front point" in text
    assert "synthetic label chips" in text
    assert "| terrain-driven (weight 0.3) |" in text and "| random-seed Voronoi" in text
    assert "every row on the same chip x seed pairs" in text and "WARNING" not in text
    assert "share of draws with at least one empty region" in text
    for figure in ("teams_decomposition", "teams_pareto", "teams_trajectories", "teams_coverage"):
        assert f"figures/{figure}.png" in text
        assert (tmp_path / "reports" / "figures" / f"{figure}.png").stat().st_size > 1000


def test_the_chip_count_table_averages_each_count_over_its_seeds_and_names_stale_pieces():
    from robocompose.report.teams import _chip_count

    pieces = [{"train_chips": n, "seed": seed, "validation_hypervolume": hv, "distinct_teams": 100,
               "training_seconds": 120.0} for n, seed, hv in [(16, 0, 10.0), (16, 1, 11.0), (64, 0, 12.5)]]
    lines = _chip_count({"chip_count": pieces, "stale_chip_count_pieces": ["measured/teams/chip_count/x.json"]})
    rows = [line for line in lines if line.startswith("| 16") or line.startswith("| 64")]
    assert "10.50 ± 0.50" in rows[0] and "0, 1" in rows[0] and "12.50 ± 0.00" in rows[1]
    assert any("1 stale piece(s)" in line and "x.json" in line for line in lines)
    assert any("No piece of the current settings" in line for line in _chip_count({}))
