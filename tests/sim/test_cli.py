import pytest

from robocompose.grammar.references import REFERENCE_DESIGNS


@pytest.mark.parametrize(("command", "out", "fragments"), [
    ("render", "x.jpg", ["argument --out", "x.jpg: expected a .png file name (it is written as PNG)"]),
    ("render", "folder", ["argument --out", "is a directory"]),
    ("export-urdf", "folder", ["argument --out", "is a directory, expected a file name ending in .urdf"]),
    ("export-urdf", "robot.xml", ["argument --out", "expected a .urdf file name"]),
])
def test_outputs_are_checked_before_any_work(tmp_path, cli_error, monkeypatch, command, out, fragments):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    cli_error([command, "--rules", REFERENCE_DESIGNS["robogrammar_ridged"], "--out", out], *fragments)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"] and not any((tmp_path / "folder").iterdir())
