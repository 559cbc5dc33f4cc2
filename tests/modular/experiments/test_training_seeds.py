"""Further training seeds: a folder of models trained by `train_seed` with the params' settings is accepted; one
trained under other settings, missing a learner, repeating a learner's own seed or of another name is refused with
one line naming the file (or folder) and the field, never mixed in silently.

Tiny learners on a fake pool of exact tables (as in test_generative.py): a few iterations each, no rollout.
"""

from __future__ import annotations

import dataclasses
import shutil

import pytest

from robocompose.eggan.learners import baselines, variants
from robocompose.io.errors import ArtifactError
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.evaluate import EvalSettings
from robocompose.modular.experiments.generative import configured_seed, train_seed
from robocompose.modular.experiments.training_seeds import further_seeds
from robocompose.params import build_config
from tests.modular.experiments.test_generative import MODULAR, SECTION
from tests.modular.plugins.test_eggan_problem import fake_pool

LEARNED = (*variants("modular"), *baselines("modular"))  # the order the check goes through them


def tiny_section(pool) -> dict:
    """A table-source eggan_modular section small enough to train every learner in seconds."""
    return {**SECTION, "fitness": {"source": "table", "train_terrains": 2, "validation_seed_base": 20_002,
                                   "validation_terrains": 1, "pool": str(pool), "lookups": 400},
            "train": {"iterations": 4, "batch": 8, "tasks": 2, "samples": 4, "log_every": 2, "validate_every": 2,
                      "checkpoint_every": 2},
            "protocol": {"test_terrains": [1007], "queries": 2, "candidates": 3, "samples": 8, "ec_draws": 2}}


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """(the seeds' root, the section) with seed-1 holding every learner trained at seed 1 by `train_seed`."""
    base = tmp_path_factory.mktemp("seeds")
    section = tiny_section(fake_pool(base, [20_000, 20_001, 20_002]))
    params = build_config(EgganModularParams, section, "eggan_modular")
    root = base / "measured" / "modular" / "seeds"
    for method in LEARNED:
        train_seed(method, 1, MODULAR, params, root / "seed-1")
    (root / "README.md").write_text("further training seeds\n")
    return root, section


def params_of(section: dict, **changes: dict) -> EgganModularParams:
    """The section's params with `changes` (subsection -> its fields) laid over it."""
    return build_config(EgganModularParams, {**section, **{key: {**section.get(key, {}), **fields}
                                                          for key, fields in changes.items()}}, "eggan_modular")


def test_a_folder_trained_with_the_params_settings_is_taken(trained):
    root, section = trained
    params = params_of(section)
    assert all(configured_seed(m, params) == 0 for m in (*LEARNED, "crowding_diverse"))
    assert further_seeds(root, MODULAR, params) == {1: root / "seed-1"}  # the README beside it is left alone
    assert further_seeds(root / "nowhere", MODULAR, params) == {}


@pytest.mark.parametrize(("changes", "file", "field", "expected", "found"), [
    ({"train": {"lr_generator": 3e-4}}, "ga", "train.lr_generator", "0.0003", "0.0001"),
    ({"evolution_steps": {"crowding": 2, "ga": 1}}, "crowding", "train.evolution_steps", "2", "1"),
    ({"baselines": {"molgan": {**SECTION["baselines"]["molgan"], "lam": 1.0}}}, "molgan", "train.lam", "1.0", "0.5"),
    ({"network": {"hidden": 32}}, "ga", "network.hidden", "32", "16"),
    ({"encoders": {"molgan": "features"}}, "molgan", "network.encoder", "'features'", "'conv'"),  # per learner
    ({"fitness": {"lookups": 300}}, "ga", "metrics.evaluation_budget", "300", "400"),
])
def test_a_folder_trained_under_other_settings_is_refused_naming_file_field_and_values(trained, changes, file, field,
                                                                                      expected, found):
    root, section = trained
    with pytest.raises(ArtifactError) as error:
        further_seeds(root, MODULAR, params_of(section, **changes))
    message = str(error.value)
    assert message.startswith(f"{root / 'seed-1' / f'eggan_modular_{file}.pt'}: {field}: expected {expected} ")
    assert f"found {found}: trained under other settings" in message and "\n" not in message
    assert f"train-seed --method {file} --seed 1 --out-dir {root / 'seed-1'}" in message


def test_a_folder_of_other_evaluator_settings_is_refused(trained):
    root, section = trained
    other = dataclasses.replace(MODULAR, eval=EvalSettings(control_steps=11))
    with pytest.raises(ArtifactError, match=r"seed-1/eggan_modular_ga\.pt: settings_hash: expected '[0-9a-f]{16}'"):
        further_seeds(root, other, params_of(section))


def test_a_missing_model_a_repeated_seed_a_mislabelled_folder_or_another_name_is_refused(trained, tmp_path):
    source, section = trained
    params = params_of(section)
    root = tmp_path / "seeds"
    (root / "seed-3").mkdir(parents=True)  # training started, no model yet
    with pytest.raises(ArtifactError, match=r"seed-3/eggan_modular_ga\.pt: no such file \(expected EG-GAN's model at "
                                            r"training seed 3: robocompose modular train-seed --method ga --seed 3"):
        further_seeds(root, MODULAR, params)
    shutil.rmtree(root / "seed-3")
    shutil.copytree(source / "seed-1", root / "seed-2")  # seed 1's models in a folder named seed 2
    for model in (root / "seed-2").glob("*.pt"):
        if model.name == "eggan_modular_crowding.pt":
            model.unlink()
    with pytest.raises(ArtifactError, match=r"seed-2/eggan_modular_ga\.pt: train\.seed: expected 2 .* found 1"):
        further_seeds(root, MODULAR, params)
    (root / "seed-2").rename(root / "seed-0")  # the stage's own seed
    with pytest.raises(ArtifactError, match=r"seed-0: training seed 0: expected a seed other than EG-GAN's own \(0"):
        further_seeds(root, MODULAR, params)
    for name in ("seed-01", "notes"):
        shutil.rmtree(root)
        (root / name).mkdir(parents=True)
        with pytest.raises(ArtifactError, match=rf"{name}: expected a folder named seed-S .* found '{name}'"):
            further_seeds(root, MODULAR, params)
    shutil.rmtree(root)
    shutil.copytree(source / "seed-1", root / "seed-1")
    (root / "seed-1" / "eggan_modular_dqn.pt").unlink()
    with pytest.raises(ArtifactError, match=r"seed-1/eggan_modular_dqn\.pt: no such file"):
        further_seeds(root, MODULAR, params)
