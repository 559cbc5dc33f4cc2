import pytest

from robocompose.modular.evaluate import EvalSettings, rollout
from robocompose.modular.params import FASTEST_SPEED, FRONT_REACH, ModularParams, course_reach
from robocompose.modular.terrain import TerrainConfig, generate_terrain
from robocompose.params import load_section, write_profile


def test_both_profiles_load_and_differ_where_the_thesis_does(tmp_path):
    root = __import__("pathlib").Path(__file__).resolve().parents[2]
    (tmp_path / "profiles").mkdir()
    for name in ("default", "paper"):
        (tmp_path / "profiles" / f"{name}.yaml").write_text((root / "profiles" / f"{name}.yaml").read_text())
    default = load_section(ModularParams, "modular", write_profile("default", tmp_path))
    paper = load_section(ModularParams, "modular", write_profile("paper", tmp_path))
    assert default.eval.control_steps == 50 and paper.eval.control_steps == 250
    assert len(paper.experiments.test_terrains) == 10 and len(paper.experiments.ga_seeds) == 20
    assert default.experiments.test_terrains == paper.experiments.test_terrains == list(range(1000, 1010))
    assert len(paper.experiments.truth_terrains) >= 8  # thesis: 10 test terrains x 20 runs
    assert default.eval.terrain.max_height_range == paper.eval.terrain.max_height_range
    assert default.eval.time_step == pytest.approx(1 / 240)
    # Both courses are as long as their episodes: the fastest design stays on the blocks to the end.
    for params in (default, paper):
        assert course_reach(params.eval) <= params.eval.terrain.x_range[1] < course_reach(params.eval) + 2.0


def test_the_fastest_design_does_not_outrun_the_course_reach():
    # Six wheels on flat ground, the default episode: at most the rim speed of the drives, and close to it.
    settings = EvalSettings(control_steps=50, terrain=TerrainConfig(x_range=(-1.0, 5.0), max_height_range=(0, 0)))
    distance = rollout("wwwwww", generate_terrain(0, settings.terrain), settings).distance
    duration = 50 * 20 / 240
    assert 0.9 * FASTEST_SPEED * duration < distance <= FASTEST_SPEED * duration
    assert distance + FRONT_REACH <= course_reach(settings)


def test_a_course_shorter_than_the_episode_is_rejected(tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text("modular: {eval: {control_steps: 250, terrain: {x_range: [-1.0, 9.0]}}, fitness: {},\n"
                    "          experiments: {}}")
    with pytest.raises(ValueError, match=r"modular\.eval\.terrain\.x_range: the course ends at x = 9"):
        load_section(ModularParams, "modular", path)


@pytest.mark.parametrize("experiments,message", [
    ("{test_terrains: [1000, 1001], truth_terrains: [1000]}", "missing \\[1001\\]"),
    ("{test_terrains: [7], truth_terrains: [7]}", "1000, 2000"),
])
def test_test_terrains_are_held_out_and_have_exhaustive_tables(tmp_path, experiments, message):
    path = tmp_path / "params.yaml"
    path.write_text(f"modular: {{experiments: {experiments}}}")
    with pytest.raises(ValueError, match=message):
        load_section(ModularParams, "modular", path)


@pytest.mark.parametrize("text,field", [
    ("modular: {eval: {control_steps: many}}", "modular.eval.control_steps"),
    ("modular: {eval: {terrain: {spacing: 1}}}", "modular.eval.terrain.spacing"),
    ("modular: {experiments: {seeds: [1]}}", "modular.experiments.seeds"),
    ("modular: {fitness: {invalid: drop}}", "modular.fitness"),
    ("modular: {workers: -1}", "modular.workers: unknown field"),  # fan-out is the compute: section's
    ("other: {}", "modular"),
])
def test_bad_params_name_the_file_and_field(tmp_path, text, field):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=field.replace(".", r"\.")) as error:
        load_section(ModularParams, "modular", path)
    assert str(path) in str(error.value)
