from dataclasses import dataclass

import pytest
import yaml

from robocompose.dataset.enumerate import EnumerateConfig
from robocompose.io.errors import InputError
from robocompose.params import build_config, load_section, merge, read_params, write_profile


def _write(path, document) -> None:
    path.write_text(yaml.safe_dump(document))


def test_section_is_built_and_checked(tmp_path):
    params = tmp_path / "params.yaml"
    _write(params, {"enumerate": {"n": 5, "seed": 2}})
    assert load_section(EnumerateConfig, "enumerate", params) == EnumerateConfig(n=5, seed=2)


@pytest.mark.parametrize(("section", "message"), [
    ({"n": -3}, "enumerate: n must be a positive integer, got -3"),
    ({"n": "many"}, "enumerate.n: expected int, found 'many'"),
    ({"n": 3, "sedd": 1}, "enumerate.sedd: unknown field"),
    ({"n": True}, "enumerate.n: expected int"),
])
def test_bad_params_name_file_and_field(tmp_path, section, message):
    params = tmp_path / "params.yaml"
    _write(params, {"enumerate": section})
    with pytest.raises(ValueError, match=message) as err:
        load_section(EnumerateConfig, "enumerate", params)
    assert str(params) in str(err.value)


def test_missing_file_and_section(tmp_path):
    with pytest.raises(InputError, match="nope.yaml: params file not found"):
        read_params(tmp_path / "nope.yaml")
    _write(tmp_path / "p.yaml", {"other": {}})
    with pytest.raises(ValueError, match="missing section 'enumerate'"):
        load_section(EnumerateConfig, "enumerate", tmp_path / "p.yaml")


def test_float_fields_accept_integers():
    @dataclass
    class C:
        rate: float = 0.5

    assert build_config(C, {"rate": 1}, "x").rate == 1


def test_profile_merges_overrides_onto_default(tmp_path):
    (tmp_path / "profiles").mkdir()
    _write(tmp_path / "profiles" / "default.yaml", {"enumerate": {"n": 10, "seed": 0}, "report": {"gallery": 3}})
    _write(tmp_path / "profiles" / "paper.yaml", {"enumerate": {"n": 500000}})
    written = read_params(write_profile("paper", tmp_path))
    assert written["enumerate"] == {"n": 500000, "seed": 0} and written["report"] == {"gallery": 3}
    assert written["profile"] == "paper"
    with pytest.raises(InputError, match="known profiles: \\['default', 'paper'\\]"):
        write_profile("huge", tmp_path)


def test_merge_is_deep_and_leaves_inputs_alone():
    base = {"a": {"b": 1, "c": 2}}
    assert merge(base, {"a": {"b": 5}}) == {"a": {"b": 5, "c": 2}} and base == {"a": {"b": 1, "c": 2}}


def test_repository_profiles_are_consistent():
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    default = read_params(root / "profiles" / "default.yaml")
    paper = read_params(root / "profiles" / "paper.yaml")

    def keys(d, prefix=""):
        return {prefix + k for k in d} | {x for k, v in d.items() if isinstance(v, dict) for x in keys(v, f"{k}.")}

    assert keys(paper) <= keys(default)  # a profile only overrides knobs the default profile has


def test_profile_outside_the_repository_says_where_to_run_it(tmp_path):
    with pytest.raises(InputError, match="run `robocompose profile` in the repository's root folder") as error:
        write_profile("default", tmp_path)
    assert "profiles" in str(error.value) and not (tmp_path / "params.yaml").exists()


@pytest.mark.parametrize("values, message", [
    ({"n": [1]}, "x.n: expected int, found [1]"),
    ({"n": True}, "x.n: expected int, found True"),
    ({"n": 0}, "x: n must be a positive integer, got 0"),  # the dataclass's own range check, field named
    ({"n": 5, "seed": "a"}, "x.seed: expected int"),
])
def test_values_are_checked_by_type_and_by_the_dataclass(values, message):
    with pytest.raises(InputError) as error:
        build_config(EnumerateConfig, values, "x")
    assert message in str(error.value)
