import json

import pytest

from robocompose.cli import main


def test_enumerate_writes_parquet(tmp_path, capsys):
    out = tmp_path / "d.parquet"
    assert main(["enumerate", "--n", "3", "--seed", "0", "--out", str(out), "--workers", "1"]) == 0
    assert out.exists() and json.loads(capsys.readouterr().out)["kept"] == 3


@pytest.mark.parametrize(("flags", "fragments"), [
    (["--n", "-4"], ["argument --n", "expected an integer >= 1, found -4"]),
    (["--n", "2", "--seed", "-1"], ["argument --seed", "expected an integer >= 0, found -1"]),
    (["--n", "2", "--workers", "-1"], ["argument --workers", "expected an integer >= 0"]),
])
def test_enumerate_bad_numbers_fail_without_output(tmp_path, cli_error, flags, fragments):
    out = tmp_path / "d.parquet"
    cli_error(["enumerate", *flags, "--out", str(out)], *fragments)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("out", "fragments"), [
    ("out.csv", ["argument --out", "out.csv: expected a .parquet file name (it is written as parquet)"]),
    ("folder", ["argument --out", "folder: is a directory, expected a file name ending in .parquet"]),
])
def test_enumerate_output_is_checked_before_any_work(tmp_path, cli_error, monkeypatch, out, fragments):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    cli_error(["enumerate", "--n", "2", "--out", out], *fragments)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"] and not any((tmp_path / "folder").iterdir())


def test_enumerate_on_a_dask_cluster_writes_the_same_bytes(tmp_path, capsys, dask_address):
    local, remote = tmp_path / "local.parquet", tmp_path / "dask.parquet"
    assert main(["enumerate", "--n", "3", "--seed", "2", "--out", str(local), "--workers", "2"]) == 0
    assert main(["enumerate", "--n", "3", "--seed", "2", "--out", str(remote), "--address", dask_address]) == 0
    assert local.read_bytes() == remote.read_bytes()
