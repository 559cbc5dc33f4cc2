"""Re-keying committed teams pieces: only after one of them is re-made under today's code with the same results,
and only the pieces that shared its old key."""

import json
import runpy
from pathlib import Path

import pandas as pd

from robocompose.cli import parser
from robocompose.io import write_table
from robocompose.params import load_section
from robocompose.teams import chip_count, generators
from robocompose.teams.experiments import decomposed_chips
from robocompose.teams.params import TeamsParams
from robocompose.teams.pieces import verify_chip_count, verify_generators

STAGES = Path(__file__).resolve().parents[2] / "stages"


def _made(tmp_path, monkeypatch, teams_params, command: list[str]) -> TeamsParams:
    """A tiny teams world with one piece made by `command`, in tmp_path."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text(teams_params(
        {"populations": [4]}, {"iterations": 10, "batch": 8, "samples": 8, "checkpoint_every": 5,
                               "validation_chips": 1, "validate_every": 5, "validation_samples": 4},
        {"n_synthetic": 6}))
    runpy.run_path(str(STAGES / "decompose.py"), run_name="__main__")
    args = parser().parse_args(command)
    args.handler(args)
    return load_section(TeamsParams, "teams", path=tmp_path / "params.yaml")


def _split(name: str):
    from robocompose.io import read_table

    return decomposed_chips(read_table("data/regions.parquet", "regions"), name)


def test_a_chip_count_piece_that_reproduces_is_rekeyed_and_one_of_other_settings_is_not(tmp_path, monkeypatch,
                                                                                        teams_params):
    params = _made(tmp_path, monkeypatch, teams_params, ["teams", "chip-count", "--train-chips", "2", "--seed", "1"])
    made = Path("measured/teams/chip_count/train-2-seed-1.json")
    old = json.loads(made.read_text())["key"]
    foreign = made.with_name("train-4-seed-1.json")  # made under other settings: another old key
    foreign.write_text(json.dumps({**json.loads(made.read_text()), "train_chips": 4, "key": "0123456789abcdef"}))
    monkeypatch.setattr(chip_count, "piece_key", lambda params: "code-of-today")  # a code change: all stale
    result = verify_chip_count(params, _split("train"), rekey=True)
    assert result["reproduced"] == str(made) and result["differences"] == []  # the fewest chips re-made
    assert result["rekeyed"] == [str(made)]
    record = json.loads(made.read_text())
    assert record["key"] == "code-of-today" and record["rekeyed"] == {"from": old, "reproduced_by": made.name}
    assert json.loads(foreign.read_text())["key"] == "0123456789abcdef"  # its settings were never re-made


def test_a_chip_count_piece_whose_result_moved_keeps_its_stale_key(tmp_path, monkeypatch, teams_params):
    params = _made(tmp_path, monkeypatch, teams_params, ["teams", "chip-count", "--train-chips", "2", "--seed", "1"])
    made = Path("measured/teams/chip_count/train-2-seed-1.json")
    record = json.loads(made.read_text())
    made.write_text(json.dumps({**record, "validation_hypervolume": record["validation_hypervolume"] + 0.001}))
    monkeypatch.setattr(chip_count, "piece_key", lambda params: "code-of-today")
    result = verify_chip_count(params, _split("train"), rekey=True)
    assert result["differences"] == ["validation_hypervolume"] and result["rekeyed"] == []
    assert json.loads(made.read_text())["key"] == record["key"]


def test_a_generator_piece_is_rekeyed_only_while_its_tables_reproduce_cell_for_cell(tmp_path, monkeypatch,
                                                                                    teams_params):
    params = _made(tmp_path, monkeypatch, teams_params, ["teams", "generator", "--seed", "1"])
    piece = Path("measured/teams/generators/seed-1")
    stored = (piece / "eggan_fronts.parquet").read_bytes()
    fronts = pd.read_parquet(piece / "eggan_fronts.parquet")
    fronts.loc[0, "coverage_cost"] += 1e-9  # a result that moved in the 9th digit
    write_table(fronts, piece / "eggan_fronts.parquet", "teams_eggan_fronts")
    monkeypatch.setattr(generators, "piece_key", lambda params: "code-of-today")
    moved = verify_generators(params, _split("train"), _split("test"), rekey=True)
    assert moved["differences"] == ["eggan_fronts.parquet"] and moved["rekeyed"] == []
    (piece / "eggan_fronts.parquet").write_bytes(stored)
    same = verify_generators(params, _split("train"), _split("test"), rekey=True)
    assert same["differences"] == [] and same["rekeyed"] == [str(piece)]
    assert json.loads((piece / "piece.json").read_text())["key"] == "code-of-today"
