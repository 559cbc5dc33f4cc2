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
