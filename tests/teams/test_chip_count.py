"""The chip-count study: generators trained on N chips, scored on validation chips no N ever trains on."""

import dataclasses
import json
import runpy
from pathlib import Path

import pytest

from robocompose.cli import parser
from robocompose.io import InputError
from robocompose.params import load_section
from robocompose.teams.chip_count import piece_key, read_pieces, training_chips, write_piece
from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import decompose_chip
from robocompose.teams.params import TeamsParams

STAGES = Path(__file__).resolve().parents[2] / "stages"
@pytest.fixture
def params(tmp_path, teams_params) -> TeamsParams:
    (tmp_path / "params.yaml").write_text(teams_params(  # 6 chips, 1 of the 3 training ones for validation
        {"seeds": [0, 1]}, {"iterations": 10, "batch": 8, "samples": 8, "checkpoint_every": 5, "validation_chips": 1,
                            "validate_every": 5, "validation_samples": 4}, {"n_synthetic": 6}))
    return load_section(TeamsParams, "teams", path=tmp_path / "params.yaml")


def split(params: TeamsParams, indices: list[int]):
    return [(chip, decompose_chip(chip, params.decompose))
            for chip in (synthetic_chip(params.chips.seed, index) for index in indices)]


def test_extra_training_chips_come_from_past_the_set_and_the_validation_chips_stay_apart(params):
    train_split = split(params, [0, 2, 5])  # the set's training split; 5 is its validation chip
    few, validation = training_chips(params, train_split, 1)
    assert [c.chip_id for c, _ in few] == ["synthetic-1-00000-000000"]
    assert [c.chip_id for c, _ in validation] == ["synthetic-1-00005-000000"]
    many, same = training_chips(params, train_split, 5)
    assert [c.chip_id for c, _ in many] == [f"synthetic-1-{i:05d}-000000" for i in (0, 2, 6, 7, 8)]
    assert [c.chip_id for c, _ in same] == [c.chip_id for c, _ in validation]
    # an added chip is decomposed as the decompose stage would
    assert (many[2][1].centres == decompose_chip(synthetic_chip(1, 6), params.decompose).centres).all()


def test_the_study_refuses_settings_it_cannot_score(params):
    with pytest.raises(InputError, match="validation_chips: 0"):
        training_chips(dataclasses.replace(params, eggan=dataclasses.replace(params.eggan, validation_chips=0)),
                       split(params, [0, 2]), 2)
    with pytest.raises(InputError, match="teams.chips.directory"):
        training_chips(dataclasses.replace(params, chips=dataclasses.replace(params.chips, directory="labels")),
                       split(params, [0, 2]), 2)


def test_a_piece_is_measured_on_the_validation_chips_and_goes_stale_with_its_settings(tmp_path, params,
                                                                                      monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(STAGES / "decompose.py"), run_name="__main__")
    args = parser().parse_args(["teams", "chip-count", "--train-chips", "4", "--seed", "1"])
    args.handler(args)
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    piece = json.loads(Path(printed["piece"]).read_text())
    assert printed["piece"] == "measured/teams/chip_count/train-4-seed-1.json"
    assert piece["train_chips"] == 4 and piece["seed"] == 1 and len(piece["validation_chips"]) == 1
    assert len(piece["validation_hypervolume_per_seed"]) == 2  # one per search seed
    assert piece["validation_hypervolume"] == pytest.approx(sum(piece["validation_hypervolume_per_seed"]) / 2,
                                                            abs=1e-4)
    assert [iteration for iteration, _ in piece["curve"]] == [5, 10]
    found, stale = read_pieces(params)
    assert [p["train_chips"] for p in found] == [4] and stale == []
    other = dataclasses.replace(params, eggan=dataclasses.replace(params.eggan, lr=0.5))
    assert piece_key(other) != piece_key(params)
    assert piece_key(dataclasses.replace(params, eggan=dataclasses.replace(params.eggan, seed=3))) == piece_key(params)
    write_piece({**piece, "train_chips": 2}, other)
    found, stale = read_pieces(params)
    assert [p["train_chips"] for p in found] == [4] and stale == ["measured/teams/chip_count/train-2-seed-1.json"]
