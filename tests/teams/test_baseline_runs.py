"""Tables 5.4 and 5.5's baselines as a committed piece: made by the stage's own function, taken by the stage byte
for byte while its settings, chips and code match, measured afresh otherwise."""

import dataclasses
import json
import runpy
from pathlib import Path

import pytest

from robocompose.cli import parser
from robocompose.io import read_table
from robocompose.io.timings import read_timings
from robocompose.params import load_section
from robocompose.teams.baseline_runs import PIECE, TABLES, piece_key
from robocompose.teams.experiments import decomposed_chips
from robocompose.teams.params import TeamsParams

STAGES = Path(__file__).resolve().parents[2] / "stages"


def run_stage(name: str) -> None:
    runpy.run_path(str(STAGES / f"{name}.py"), run_name="__main__")


def teams(*arguments: str) -> None:
    args = parser().parse_args(["teams", *arguments])
    args.handler(args)


def test_the_piece_key_covers_the_settings_the_chips_and_nothing_else(tmp_path, monkeypatch, teams_params):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params({"populations": [4]}))
    run_stage("decompose")
    params = load_section(TeamsParams, "teams")
    chips = decomposed_chips(read_table("data/regions.parquet", "regions"), "test")
    key = piece_key(params, chips)
    assert piece_key(dataclasses.replace(params, coverage=dataclasses.replace(params.coverage, iterations=3)),
                     chips) != key
    assert piece_key(dataclasses.replace(params, experiments=dataclasses.replace(params.experiments, seeds=[0, 1])),
                     chips) != key
    relabelled = dataclasses.replace(chips[0][0], classes=chips[0][0].classes.copy())
    relabelled.classes[0, 0] += 1
    assert piece_key(params, [(relabelled, chips[0][1]), *chips[1:]]) != key  # a chip's labels, not just its id
    # settings no baseline reads (the held-out seeds, the generator) leave the key alone
    heldout = dataclasses.replace(params.experiments, heldout_seeds=[200, 201])
    assert piece_key(dataclasses.replace(params, experiments=heldout), chips) == key
    assert piece_key(dataclasses.replace(params, eggan=dataclasses.replace(params.eggan, lr=0.5)), chips) == key


def test_the_stage_takes_the_committed_piece_byte_for_byte_until_a_setting_changes(tmp_path, monkeypatch, capsys,
                                                                                   teams_params):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params({"populations": [4]}))
    run_stage("decompose")
    teams("baselines", "--workers", "1")
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["piece"] == str(PIECE)
    assert {p.name for p in PIECE.iterdir()} == {"piece.json", *(f"{stem}.parquet" for stem in TABLES)}
    run_stage("teams_baselines")
    assert "measuring" not in capsys.readouterr().err
    timing = read_timings()["teams_baselines"]
    assert timing["source"] == f"{PIECE}/ (committed)" and len(timing["nsga2_alone"]) == 1  # the piece's run times
    for stem in TABLES:
        assert Path(f"data/teams/{stem}.parquet").read_bytes() == (PIECE / f"{stem}.parquet").read_bytes()

    # measuring again (what the stage does without the piece: the same function and writer) gives the same bytes
    teams("baselines", "--check", "--workers", "1")
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["identical"] is True
    nsga2 = read_table(PIECE / "nsga2.parquet", "teams_nsga2")
    nsga2.loc[0, "hypervolume"] += 0.5
    nsga2.to_parquet(PIECE / "nsga2.parquet")
    with pytest.raises(SystemExit) as exited:
        teams("baselines", "--check", "--workers", "1")
    assert exited.value.code == 1 and json.loads(capsys.readouterr().out.strip())["differ"] == ["nsga2"]

    (tmp_path / "params.yaml").write_text(teams_params({"populations": [4], "generations": 1}))
    run_stage("teams_baselines")  # another setting: the piece is not taken
    assert "measuring the baselines" in capsys.readouterr().err
    assert read_timings()["teams_baselines"]["source"] == "measured"
    assert read_table("data/teams/nsga2.parquet", "teams_nsga2").generations.tolist() == [1]
