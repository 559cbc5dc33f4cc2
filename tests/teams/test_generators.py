"""Independent generators: a committed piece per training seed, made by the stage's own function, taken by the
held-out stage only while its settings and code match."""

import dataclasses
import json
import runpy
from pathlib import Path

import pandas as pd

from robocompose.cli import parser
from robocompose.params import load_section
from robocompose.teams.generators import piece_key
from robocompose.teams.params import TeamsParams

STAGES = Path(__file__).resolve().parents[2] / "stages"
def test_the_piece_key_covers_every_setting_but_the_training_seed(tmp_path, teams_params):
    (tmp_path / "params.yaml").write_text(teams_params({"populations": [4]}))
    params = load_section(TeamsParams, "teams", path=tmp_path / "params.yaml")
    key = piece_key(params)
    assert piece_key(dataclasses.replace(params, eggan=dataclasses.replace(params.eggan, seed=7))) == key
    assert piece_key(dataclasses.replace(params, eggan=dataclasses.replace(params.eggan, lr=0.5))) != key
    assert piece_key(dataclasses.replace(params, coverage=dataclasses.replace(params.coverage, iterations=3))) != key
    other_seeds = dataclasses.replace(params.experiments, seeds=[0, 1])
    assert piece_key(dataclasses.replace(params, experiments=other_seeds)) != key
    # settings that do not shape a generator or its queries leave the key alone
    heldout = dataclasses.replace(params.experiments, heldout_seeds=[200, 201])
    assert piece_key(dataclasses.replace(params, experiments=heldout)) == key


def test_a_committed_generator_stands_beside_the_stages_until_its_settings_change(tmp_path, monkeypatch, capsys,
                                                                                teams_params):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params({"populations": [4]}))
    for stage in ("decompose", "teams_baselines", "teams_eggan"):
        runpy.run_path(str(STAGES / f"{stage}.py"), run_name="__main__")
    args = parser().parse_args(["teams", "generator", "--seed", "1"])
    args.handler(args)
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    piece = Path("measured/teams/generators/seed-1")
    assert printed["piece"] == str(piece) and {p.name for p in piece.iterdir()} == {
        "eggan_queries.parquet", "eggan_fronts.parquet", "piece.json"}
    own = pd.read_parquet("data/teams/eggan_queries.parquet")
    other = pd.read_parquet(piece / "eggan_queries.parquet")
    assert (other.chip_id.tolist(), other.seed.tolist()) == (own.chip_id.tolist(), own.seed.tolist())
    assert other.hypervolume.tolist() != own.hypervolume.tolist()  # another training seed, another generator

    runpy.run_path(str(STAGES / "teams_heldout.py"), run_name="__main__")
    fronts = pd.read_parquet("data/teams/heldout_fronts.parquet")
    assert {"eggan:0", "eggan:1"} <= set(fronts.method)
    metrics = json.loads(Path("reports/metrics/teams_heldout.json").read_text())
    assert metrics["generators"] == [0, 1] and metrics["stale_generator_pieces"] == []

    (tmp_path / "params.yaml").write_text(teams_params({"populations": [4]}, {"latent": 5}))  # a generator setting
    runpy.run_path(str(STAGES / "teams_eggan.py"), run_name="__main__")
    runpy.run_path(str(STAGES / "teams_heldout.py"), run_name="__main__")
    fronts = pd.read_parquet("data/teams/heldout_fronts.parquet")
    assert "eggan:1" not in set(fronts.method)  # never mixed in ...
    metrics = json.loads(Path("reports/metrics/teams_heldout.json").read_text())
    assert metrics["stale_generator_pieces"] == [str(piece)]  # ... but reported
