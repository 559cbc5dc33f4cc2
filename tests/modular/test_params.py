import pytest

from robocompose.modular.params import load_modular_params
from robocompose.params import write_profile


def test_both_profiles_load_and_differ_where_the_thesis_does(tmp_path):
    root = __import__("pathlib").Path(__file__).resolve().parents[2]
    (tmp_path / "profiles").mkdir()
    for name in ("default", "paper"):
        (tmp_path / "profiles" / f"{name}.yaml").write_text((root / "profiles" / f"{name}.yaml").read_text())
    default = load_modular_params(write_profile("default", tmp_path))
    paper = load_modular_params(write_profile("paper", tmp_path))
    assert default.eval.control_steps == 100 and paper.eval.control_steps == 250
    assert len(paper.experiments.test_terrains) == 10 and len(paper.experiments.ga_seeds) == 20
    assert default.eval.terrain == paper.eval.terrain and default.eval.time_step == pytest.approx(1 / 240)


@pytest.mark.parametrize("text,field", [
    ("modular: {eval: {control_steps: many}}", "modular.eval.control_steps"),
    ("modular: {eval: {terrain: {spacing: 1}}}", "modular.eval.terrain.spacing"),
    ("modular: {experiments: {seeds: [1]}}", "modular.experiments.seeds"),
    ("modular: {fitness: {invalid: drop}}", "modular.fitness"),
    ("modular: {workers: -1}", "modular.workers"),
    ("other: {}", "modular"),
])
def test_bad_params_name_the_file_and_field(tmp_path, text, field):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=field.replace(".", r"\.")) as error:
        load_modular_params(path)
    assert str(path) in str(error.value)
