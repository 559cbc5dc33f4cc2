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


def test_wrong_number_of_allocation_rows_is_explained(tmp_path, capsys):
    with pytest.raises(SystemExit, match="2 rows, expected one per region"):
        run(["teams", "coverage", "--synthetic-seed", "0", "--regions", "3",
             "--allocation", "0.1,0,0;0,0,0"], capsys)


def test_nsga2_on_a_dask_cluster_gives_the_local_front(capsys, dask_address):
    argv = ["teams", "nsga2", "--synthetic-seed", "1", "--regions", "3", "--pop", "6", "--generations", "2"]
    local, remote = run(argv, capsys), run([*argv, "--address", dask_address], capsys)
    assert remote["front"] == local["front"] and remote["hypervolume"] == local["hypervolume"]
