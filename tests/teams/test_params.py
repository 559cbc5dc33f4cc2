import pytest

from robocompose.io.errors import InputError
from robocompose.params import load_section
from robocompose.teams.params import TeamsParams


def write(tmp_path, text: str):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    return path


def test_sections_fill_the_config_dataclasses_with_defaults_for_missing_fields(tmp_path):
    params = load_section(TeamsParams, "teams", write(tmp_path, """
teams:
  chips: {n_synthetic: 5}
  decompose: {n_regions: 4}
  coverage: {iterations: 7, learning_rate: 1}
  experiments: {populations: [4, 6], budgets: [3]}
  eggan: {fitness: {}}
"""))
    assert params.chips.n_synthetic == 5 and params.chips.directory == ""
    assert params.decompose.n_regions == 4 and params.decompose.lloyd_iterations == 10
    assert params.coverage.iterations == 7 and params.coverage.learning_rate == 1
    assert params.experiments.populations == [4, 6] and params.threads == 1


SECTIONS = {"chips": "{}", "decompose": "{}", "coverage": "{}", "experiments": "{}", "eggan": "{fitness: {}}"}


def teams_yaml(**changed: str) -> str:
    """A teams section with every sub-section (empty: the defaults), `changed` ones replaced or added."""
    return "teams:\n" + "".join(f"  {name}: {value}\n" for name, value in {**SECTIONS, **changed}.items())


@pytest.mark.parametrize("text, message", [
    ("other: 1\n", r"params.yaml: missing section 'teams'"),
    (teams_yaml(coverage="{iteration: 3}"), r"teams.coverage.iteration: unknown field"),
    (teams_yaml(coverage="{iterations: 2.5}"), r"teams.coverage.iterations: expected int, found 2.5"),
    (teams_yaml(experiments="{populations: 20}"), r"teams.experiments.populations: expected list"),
    (teams_yaml(experiments="{populations: [20, x]}"), r"teams.experiments.populations: expected a list of int"),
    (teams_yaml(threads="0"), r"teams.threads: expected a positive integer"),
    (teams_yaml(chip="{}"), r"teams.chip: unknown field"),
    (teams_yaml(experiments="{seeds: []}"), r"teams.experiments.seeds: expected a non-empty list"),
    (teams_yaml(decompose="{terrain_weight: -1.0}"), r"teams.decompose.terrain_weight: expected a number >= 0"),
    # a sub-section the stages need is never silently replaced by defaults
    ("teams:\n  chips: {}\n  coverage: {}\n  experiments: {}\n", r"teams.decompose: missing section"),
    (teams_yaml(eggan="{}"), r"teams.eggan.fitness: missing section"),  # though it has defaults
    # value ranges name the field that is wrong
    (teams_yaml(decompose="{test_fraction: 1.5}"), r"teams.decompose.test_fraction: expected a share strictly "
                                                   r"between 0 and 1 .*found 1.5"),
    (teams_yaml(decompose="{n_regions: 0}"), r"teams.decompose.n_regions: expected an integer in 1..64, found 0"),
    (teams_yaml(decompose="{n_regions: 100000}"), r"teams.decompose.n_regions: expected an integer in 1..64"),
    (teams_yaml(chips="{n_synthetic: -1}"), r"teams.chips.n_synthetic: expected an integer >= 1, found -1"),
    (teams_yaml(coverage="{learning_rate: .nan}"), r"teams.coverage.learning_rate: expected a number > 0"),
    (teams_yaml(experiments="{mutation_rate: 2}"), r"teams.experiments.mutation_rate: expected a probability"),
    (teams_yaml(eggan="{fitness: {source: surrogate}}"),
     r"teams.eggan.fitness.source: expected one of \['exact', 'model'\], found 'surrogate'"),
    (teams_yaml(eggan="{fitness: {budget: 0}}"), r"teams.eggan.fitness.budget: expected a positive integer"),
    (teams_yaml(eggan="{validate_every: 7, fitness: {}}"),
     r"teams.eggan.validate_every: expected 0 or a multiple of 5"),
])
def test_bad_params_name_file_field_and_expectation(tmp_path, text, message):
    with pytest.raises(InputError, match=message) as error:
        load_section(TeamsParams, "teams", write(tmp_path, text))
    assert "\n" not in str(error.value)
