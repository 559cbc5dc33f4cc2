import json
import runpy
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robocompose.teams.chips import read_chip

STAGES = Path(__file__).resolve().parents[2] / "stages"
def run_stage(name: str) -> None:
    runpy.run_path(str(STAGES / f"{name}.py"), run_name="__main__")


def test_stages_write_their_tables_deterministically(tmp_path, monkeypatch, teams_params):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params())
    run_stage("decompose")
    regions_bytes = Path("data/regions.parquet").read_bytes()
    regions = pd.read_parquet("data/regions.parquet")
    assert len(regions) == 4 * 3 and set(regions.source) == {str(p) for p in Path("data/teams/chips").glob("*.png")}
    for (chip_id, source), chip_regions in regions.groupby(["chip_id", "source"]):  # the regions partition the chip
        assert chip_regions.n_pixels.sum() == read_chip(chip_id, source).classes.size
    run_stage("decompose")
    assert Path("data/regions.parquet").read_bytes() == regions_bytes
    run_stage("teams_baselines")
    outputs = ["nsga2", "fronts", "coverage", "trajectories", "team_costs"]
    first = {name: Path(f"data/teams/{name}.parquet").read_bytes() for name in outputs}
    random = pd.read_parquet("data/teams/random_fronts.parquet")
    assert random.draws.tolist() == [64, 512] and random.hypervolume.is_monotonic_increasing
    outputs += ["random_fronts", "random_points"]
    first |= {name: Path(f"data/teams/{name}.parquet").read_bytes() for name in outputs[-2:]}
    nsga2 = pd.read_parquet("data/teams/nsga2.parquet")
    assert nsga2.population.tolist() == [4, 6] and (nsga2.distinct_teams < nsga2.team_lookups).all()
    run_stage("teams_baselines")  # every memo starts empty again: the same bytes
    for name in outputs:
        assert Path(f"data/teams/{name}.parquet").read_bytes() == first[name], name


def test_eggan_stage_trains_queries_and_resumes(tmp_path, monkeypatch, teams_params):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params())
    run_stage("decompose")
    run_stage("teams_eggan")
    queries = pd.read_parquet("data/teams/eggan_queries.parquet")
    front = pd.read_parquet("data/teams/eggan_fronts.parquet")
    assert len(queries) == 1 and queries.front_size[0] == len(front) <= queries.distinct[0]
    assert (front.deployment_cost == front.counts.map(sum)).all()  # a robot deployed costs 1
    cost, deployed = front.coverage_cost.to_numpy(), front.deployment_cost.to_numpy()
    assert (np.diff(deployed) > 0).all() and (np.diff(cost) < 0).all()  # by deployment: mutually non-dominated
    inside = (cost < 0.25) & (deployed < 60)  # the box up to the reference point (0.25, 60)
    widths = np.diff(np.append(deployed[inside], 60.0))
    assert queries.hypervolume[0] == pytest.approx(float(((0.25 - cost[inside]) * widths).sum()))
    metrics = json.loads(Path("reports/metrics/teams_eggan.json").read_text())
    assert metrics["mean_hypervolume"] == round(queries.hypervolume[0], 4)
    examples = pd.read_parquet("data/teams/coverage_examples.parquet")
    assert {"dec_random_allocation", "no_decomposition"} <= set(examples.method)
    model = Path("models/teams_eggan.pt").read_bytes()
    run_stage("teams_eggan")  # the checkpoint holds the finished run: same generator file
    assert Path("models/teams_eggan.pt").read_bytes() == model
    # the split at stage level: the generator trained on training chips only, and was queried on test chips only
    trained_on = set(json.loads(Path("models/teams_eggan.json").read_text())["train_chip_ids"])
    regions = pd.read_parquet("data/regions.parquet")
    assert trained_on and trained_on <= set(regions[regions.split == "train"].chip_id)
    assert set(queries.chip_id) <= set(regions[regions.split == "test"].chip_id)

    run_stage("teams_baselines")
    run_stage("teams_heldout")
    fronts = pd.read_parquet("data/teams/heldout_fronts.parquet")
    assert set(fronts.method) == {"nsga2:fractions:4", "nsga2:fractions:6", "nsga2-matched:share_split:20",
                                  "random:64", "random:512", "eggan:0"}
    matched = pd.read_parquet("data/teams/matched_nsga2.parquet")
    assert (matched.distinct_teams >= queries.distinct_teams).all()  # NSGA-II spent at least EG-GAN's teams
    spent = fronts.set_index("method").distinct_teams
    assert spent["eggan:0"] == queries.distinct_teams[0] and spent["nsga2-matched:share_split:20"] == \
        matched.distinct_teams[0]
    picks = pd.read_parquet("data/teams/heldout_picks.parquet")
    single = {"dec_random_allocation", "dec_uniform_robots", "no_decomposition"}
    assert single <= set(picks.method) <= single | set(fronts.method)
    assert picks[picks.method.isin(single)].selected_cost.isna().all()  # single draws: nothing selected
    assert (picks.deployment_cost <= picks.budget).all()
