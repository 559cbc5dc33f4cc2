import json

from robocompose.cli import main


def test_enumerate_writes_parquet(tmp_path, capsys):
    out = tmp_path / "d.parquet"
    assert main(["enumerate", "--n", "3", "--seed", "0", "--out", str(out), "--workers", "1"]) == 0
    assert out.exists() and json.loads(capsys.readouterr().out)["kept"] == 3


def test_enumerate_negative_count_fails_without_output(tmp_path, capsys):
    out = tmp_path / "d.parquet"
    assert main(["enumerate", "--n", "-4", "--out", str(out)]) == 2
    assert "n must be a positive integer" in capsys.readouterr().err and not out.exists()


def test_enumerate_on_a_dask_cluster_writes_the_same_bytes(tmp_path, capsys, dask_address):
    local, remote = tmp_path / "local.parquet", tmp_path / "dask.parquet"
    assert main(["enumerate", "--n", "3", "--seed", "2", "--out", str(local), "--workers", "2"]) == 0
    assert main(["enumerate", "--n", "3", "--seed", "2", "--out", str(remote), "--address", dask_address]) == 0
    assert local.read_bytes() == remote.read_bytes()
