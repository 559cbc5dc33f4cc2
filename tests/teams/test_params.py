import pytest

from robocompose.teams.params import load_teams_params


def write(tmp_path, text: str):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    return path


def test_sections_fill_the_config_dataclasses_with_defaults_for_missing_fields(tmp_path):
    params = load_teams_params(write(tmp_path, """
teams:
  chips: {n_synthetic: 5}
  decompose: {n_regions: 4}
  coverage: {iterations: 7, learning_rate: 1}
  experiments: {populations: [4, 6], budgets: [3]}
"""))
    assert params.chips.n_synthetic == 5 and params.chips.directory == ""
    assert params.decompose.n_regions == 4 and params.decompose.lloyd_iterations == 10
    assert params.coverage.iterations == 7 and params.coverage.learning_rate == 1
    assert params.experiments.populations == [4, 6] and params.threads == 1


@pytest.mark.parametrize("text, message", [
    ("other: 1\n", r"params.yaml: teams: missing section"),
    ("teams:\n  coverage: {iteration: 3}\n", r"teams.coverage.iteration: unknown field"),
    ("teams:\n  coverage: {iterations: 2.5}\n", r"teams.coverage.iterations: expected int, found 2.5"),
    ("teams:\n  experiments: {populations: 20}\n", r"teams.experiments.populations: expected list"),
    ("teams:\n  threads: 0\n", r"teams.threads: expected a positive integer"),
    ("teams:\n  chip: {}\n", r"teams.chip: unknown field"),
    ("teams:\n  experiments: {seeds: []}\n", r"teams.experiments.*non-empty seed list"),
    ("teams:\n  decompose: {terrain_weight: -1.0}\n", r"teams.decompose.*terrain_weight: expected >= 0"),
])
def test_bad_params_name_file_field_and_expectation(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        load_teams_params(write(tmp_path, text))
