"""The eggan_modular: params section: the profiles parse; bad fields are named."""

import pytest
import yaml

from robocompose.io.errors import InputError
from robocompose.modular.eggan_params import EgganModularParams, network_of
from robocompose.modular.experiments.held_out import PARTIAL_DIR
from robocompose.modular.params import ModularParams
from robocompose.params import build_config, load_section


def test_default_profile_parses():
    params = load_section(EgganModularParams, "eggan_modular", "profiles/default.yaml")
    assert params.train.batch // params.train.tasks >= 32 and params.protocol.candidates == 10  # EA population 32+
    assert params.fitness.source == "table" and params.train.iterations >= 2000 and params.network.norm != "batch"
    # issue 46's measured training: a small encoder, an elite archive, the best-validated generator kept
    assert params.network.encoder == "pooled" and params.train.archive > 0
    # each learner's encoder as measured on the validation terrains (measured/modular/encoders/)
    assert {m: network_of(m, params).encoder for m in ("crowding", "ga", "fit2form", "dqn", "molgan")} == {
        "crowding": "conv", "ga": "conv", "fit2form": "pooled", "dqn": "pooled", "molgan": "features"}
    assert network_of("dqn", params) is params.network and network_of("molgan", params).hidden == params.network.hidden
    assert params.train.best_by == "val_max_distance" and params.train.validate_every > 0
    # issue 46: >= 30 test terrains; the thesis's 10 with exhaustive tables, the others with committed partial ones
    assert params.protocol.test_terrains == list(range(1000, 1030)) and params.protocol.queries == 20
    truth = load_section(ModularParams, "modular", "profiles/default.yaml").experiments.truth_terrains
    assert set(truth) == set(range(1000, 1010)) <= set(params.protocol.test_terrains)
    assert all((PARTIAL_DIR / f"blocks-{seed}.parquet").is_file()
               for seed in set(params.protocol.test_terrains) - set(truth))
    seeds = params.fitness.train_seeds + params.fitness.validation_seeds
    assert not set(params.protocol.test_terrains) & set(seeds)  # test terrains are never trained on


@pytest.mark.parametrize("section, message", [
    ({"evolution_steps": {"crowding": 0, "ga": 1}}, "evolution_steps"),
    ({"train": {"batch": 30, "tasks": 8}}, "even number of noise vectors"),
    ({"protocol": {"test_terrains": []}}, "test_terrains"),
    ({"fitness": {"surrogate": {"steps": 0}}}, "surrogate.steps"),
    ({"colour": 1}, "colour"),
    ({"network": {"encoder": "mlp"}}, r"network\.encoder: expected one of \['conv', 'pooled', 'features'\]"),
    ({"encoders": {"sgd": "conv"}}, r"encoders: expected a mapping of learners among \['ga', 'crowding', "),
    ({"encoders": {"dqn": "mlp"}}, r"encoders: expected .* to an encoder among \['conv', 'pooled', 'features'\], "
                                   r"found \{'dqn': 'mlp'\}"),
    ({"train": {"archive": 3}}, "archive: expected 0 or a positive even number"),
    ({"train": {"validate_every": 0, "best_by": "val_max_distance"}}, "best_by: expected"),
])
def test_bad_fields_are_named(section, message):
    base = yaml.safe_load(open("profiles/default.yaml"))["eggan_modular"]
    with pytest.raises(InputError, match=message):
        build_config(EgganModularParams, {**base, **section}, "params.yaml: eggan_modular")


@pytest.mark.parametrize("baselines, message", [
    ({"dqn": {"lr": 0.0}}, r"^params\.yaml: eggan_modular\.baselines\.dqn\.lr: expected a positive number"),
    ({"molgan": {"colour": 1}}, r"^params\.yaml: eggan_modular\.baselines\.molgan\.colour: unknown field"),
    ({"sgd": {}}, r"^params\.yaml: eggan_modular\.baselines: expected a settings mapping for each of "
                  r"\['fit2form', 'dqn', 'molgan'\]"),
])
def test_a_bad_learner_setting_is_refused_in_one_line_when_the_section_is_built(baselines, message):
    """Each learned baseline's settings are its registry entry's dataclass, checked with the section (so by
    `robocompose profile`), not first when its trainer starts."""
    base = yaml.safe_load(open("profiles/default.yaml"))["eggan_modular"]
    merged = {name: {**values, **baselines.get(name, {})} for name, values in base["baselines"].items()}
    merged.update({name: values for name, values in baselines.items() if name not in merged})
    with pytest.raises(InputError, match=message) as err:
        build_config(EgganModularParams, {**base, "baselines": merged}, "params.yaml: eggan_modular")
    assert "\n" not in str(err.value)


def test_every_learned_baseline_needs_its_settings():
    base = yaml.safe_load(open("profiles/default.yaml"))["eggan_modular"]
    del base["baselines"]["fit2form"]
    with pytest.raises(InputError, match=r"eggan_modular\.baselines: expected a settings mapping for each of"):
        build_config(EgganModularParams, base, "params.yaml: eggan_modular")
