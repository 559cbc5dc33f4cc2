import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from robocompose.dataset.enumerate import EnumerateConfig
from robocompose.io.errors import InputError
from robocompose.params import (
    build_config,
    check_params,
    load_section,
    merge,
    profile_names,
    read_params,
    write_profile,
)

ROOT = Path(__file__).resolve().parents[1]


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


def _profiles(tmp_path, **overrides: dict):
    """tmp_path/profiles: the repository's default.yaml and one file per override."""
    (tmp_path / "profiles").mkdir()
    shutil.copy(ROOT / "profiles" / "default.yaml", tmp_path / "profiles" / "default.yaml")
    for name, document in overrides.items():
        _write(tmp_path / "profiles" / f"{name}.yaml", document)
    return tmp_path


def test_profile_merges_overrides_onto_default(tmp_path):
    root = _profiles(tmp_path, paper={"enumerate": {"n": 500000}})
    written = read_params(write_profile("paper", root))
    assert written["enumerate"]["n"] == 500000 and written["enumerate"]["seed"] == 0
    assert written["gallery"] == read_params(root / "profiles" / "default.yaml")["gallery"]
    assert written["profile"] == "paper"


@pytest.mark.parametrize("name", ["huge", "../dvc", "default.yaml", "", "/etc/passwd"])
def test_only_the_files_in_profiles_are_profiles(tmp_path, name):
    root = _profiles(tmp_path, paper={})
    (tmp_path / "dvc.yaml").write_text("stages: {}\n")
    with pytest.raises(InputError, match=r"no such profile; expected one of \['default', 'paper'\]") as error:
        write_profile(name, root)
    assert "\n" not in str(error.value) and not (root / "params.yaml").exists()


@pytest.mark.parametrize("override, message", [
    ({"enumerate": {"sedd": 1}}, r"enumerate.sedd: unknown field"),
    ({"glso": {"bo": {"init": "six"}}}, r"glso.bo.init: expected int, found 'six'"),
    ({"compute": {"address": "localhost"}}, r"compute.address: expected a Dask scheduler address like tcp://host"),
    ({"modular": {"eval": {"control_steps": 250}}}, r"modular.eval.terrain.x_range: the course ends"),
    ({"eggan_modular": {"protocol": {"queries": 0}}}, r"eggan_modular.protocol.queries: expected a positive"),
    ({"train_vae": {"variants": {"full": {"predictor": "yes"}}}}, r"train_vae.variants.full.predictor: expected bool"),
    ({"train_vae": {"landscape": {"evaluated": 0}}}, r"train_vae.landscape: need 0 < evaluated"),
    ({"colour": {}}, r"unknown section 'colour'"),
])
def test_a_profile_is_checked_before_params_yaml_is_written(tmp_path, override, message):
    root = _profiles(tmp_path, bad=override)
    with pytest.raises(InputError, match=message) as error:
        write_profile("bad", root)
    assert "\n" not in str(error.value) and "bad.yaml" in str(error.value)
    assert not (root / "params.yaml").exists()


def test_the_repository_profiles_load_every_section(tmp_path):
    for name in profile_names(ROOT):
        check_params(merge(read_params(ROOT / "profiles" / "default.yaml"),
                           read_params(ROOT / "profiles" / f"{name}.yaml")), name)
    assert set(profile_names(ROOT)) >= {"default", "paper", "smoke"}


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


LAUGHS = 'a: &a ["lol", "lol", "lol"]\n' + "".join(f"{n}: &{n} [{', '.join([f'*{p}'] * 9)}]\n"
                                                   for p, n in zip("abcdefgh", "bcdefghi", strict=True))


@pytest.mark.parametrize("text", [LAUGHS, "enumerate: {n: 5, seed: 0}\nnogram: &x {n: 5}\n",
                                  "base: {n: 5}\nenumerate: {<<: *base}\n"])
def test_a_params_file_with_anchors_or_aliases_is_refused_in_one_short_line(tmp_path, text):
    params = tmp_path / "params.yaml"
    params.write_text(text)
    with pytest.raises(InputError, match="YAML anchors and aliases are not allowed") as error:
        load_section(EnumerateConfig, "enumerate", params)
    assert str(params) in str(error.value) and len(str(error.value)) < 300


def test_a_written_profile_has_no_aliases_even_for_shared_values(tmp_path):
    from robocompose.params import dump_yaml, load_yaml

    shared = [1, 2]
    assert load_yaml(dump_yaml({"a": shared, "b": shared}), "x") == {"a": [1, 2], "b": [1, 2]}


def test_a_section_with_defaults_is_still_required_in_a_params_file(tmp_path):
    from robocompose.evaluation.evaluate import EvaluationConfig

    params = tmp_path / "params.yaml"
    _write(params, {"evaluation": {"seed": 0}})
    with pytest.raises(InputError, match=r"params.yaml: evaluation.mppi: missing section"):
        load_section(EvaluationConfig, "evaluation", params)
    assert build_config(EvaluationConfig, {"seed": 0}, "x") == EvaluationConfig()  # code may rely on defaults
    _write(params, {"evaluation": {"seed": -1}})  # a given value's own error comes first
    with pytest.raises(InputError, match=r"evaluation.seed: expected an integer >= 0"):
        load_section(EvaluationConfig, "evaluation", params)


def test_a_huge_value_is_cut_in_the_error_line():
    with pytest.raises(InputError) as error:
        build_config(EnumerateConfig, {"n": list(range(100_000))}, "x")
    assert str(error.value).startswith("x.n: expected int, found [0, 1, 2") and len(str(error.value)) < 200


def test_profile_refuses_a_params_yaml_that_is_a_directory(tmp_path):
    root = _profiles(tmp_path)
    (root / "params.yaml").mkdir()
    with pytest.raises(InputError, match="params.yaml: not a file"):
        write_profile("default", root)
    assert (root / "params.yaml").is_dir()


@pytest.mark.parametrize("value", [float("nan"), float("inf"), [0.0, float("-inf")]])
def test_every_float_field_of_a_params_section_is_finite(value):
    @dataclass
    class C:
        rate: float = 0.5  # no range check of its own
        ranges: list[float] | None = None

    with pytest.raises(InputError, match="expected finite numbers"):
        build_config(C, {"ranges" if isinstance(value, list) else "rate": value}, "x")


def test_a_class_s_own_range_check_is_reported_before_the_general_finite_rule():
    from dataclasses import field

    from robocompose.io.errors import check_number

    @dataclass
    class Inner:
        x: float = 1.0

    @dataclass
    class Outer:
        inner: Inner = field(default_factory=Inner)

        def __post_init__(self) -> None:  # a parent checks its section's field, as ModularParams does
            check_number(self.inner.x, "inner.x", 0.0)

    with pytest.raises(InputError, match=r"^w.inner.x: expected a finite number >= 0, found inf$"):
        build_config(Outer, {"inner": {"x": float("inf")}}, "w", complete=True)
