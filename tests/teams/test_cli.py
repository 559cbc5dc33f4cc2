import argparse
import json

import numpy as np
import pytest

from robocompose.teams.chips import write_label_png
from robocompose.teams.cli import register


def run(argv: list[str], capsys) -> dict:
    parser = argparse.ArgumentParser(prog="robocompose")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    args.handler(args)
    return json.loads(capsys.readouterr().out)


def test_coverage_prints_costs_of_one_allocation(tmp_path, capsys):
    classes = np.full((300, 300), 4, dtype=np.uint8)  # all GROUND: Plain
    write_label_png(classes, tmp_path / "plain.png")
    out = run(["teams", "coverage", "--chip", str(tmp_path / "plain.png"), "--regions", "2",
               "--allocation", "0.1,0,0;0.05,0.05,0"], capsys)
    assert out["deployment_cost"] == 4 and out["counts"] == [[2, 0, 0], [1, 1, 0]]
    assert 0 < out["coverage_cost"] < 0.25


def test_nsga2_prints_hypervolume_seconds_and_a_front(capsys):
    out = run(["teams", "nsga2", "--synthetic-seed", "1", "--regions", "3", "--pop", "6",
               "--generations", "2"], capsys)
    assert set(out) == {"hypervolume", "seconds", "front"}
    assert out["hypervolume"] > 0 and out["seconds"] > 0
    assert all(len(point) == 2 for point in out["front"])


@pytest.mark.parametrize(("allocation", "fragments"), [
    ("0.1,0,0;0,0,0", ["--allocation has 2 rows, expected one per region (--regions 3)"]),
    ("2,2,2;0,0,0;0,0,0", ["--allocation: region 0, ground: expected a fraction in [0, 1], found 2"]),
    ("0.5,0,0;0.6,0,0;0,0,0", ["--allocation: the ground fractions sum to 1.1", "expected at most 1"]),
    ("0,0.4,0;0,0.4,0;0,0.4,0", ["the aerial fractions sum to 1.2"]),
    ("0,0,0;0,nan,0;0,0,0", ["region 1, aerial: expected a fraction in [0, 1], found nan"]),
    ("0,0;0,0;0,0", ["expected rows 'f_ground,f_aerial,f_aquatic'"]),
])
def test_allocations_are_rejected_never_rescaled(cli_error, allocation, fragments):
    cli_error(["teams", "coverage", "--synthetic-seed", "0", "--regions", "3", "--allocation", allocation], *fragments)


@pytest.mark.parametrize(("flags", "fragments"), [
    (["--pop", "-4"], ["argument --pop", "expected an integer >= 2, found -4"]),
    (["--generations", "-1"], ["argument --generations", "expected an integer >= 1, found -1"]),
    (["--regions", "0"], ["argument --regions", "expected an integer >= 1, found 0"]),
    (["--regions", "100000"], ["--regions: expected an integer in 1..64, found 100000"]),
    (["--seed", "-1"], ["argument --seed", "expected an integer >= 0, found -1"]),
])
def test_nsga2_bad_numbers_fail_fast(cli_error, flags, fragments):
    cli_error(["teams", "nsga2", "--synthetic-seed", "0", *flags], *fragments)


def test_chip_that_is_not_an_image_is_named(tmp_path, cli_error):
    (tmp_path / "notes.txt").write_text("not a picture")
    cli_error(["teams", "nsga2", "--chip", str(tmp_path / "notes.txt")],
              f"{tmp_path / 'notes.txt'}: not a readable image, expected a DroneDeploy label PNG")
    cli_error(["teams", "nsga2", "--chip", str(tmp_path / "none.png")], "argument --chip", "none.png: no such file")
