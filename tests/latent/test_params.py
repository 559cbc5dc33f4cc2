import pytest

from robocompose.latent.params import VARIANTS, TrainVaeParams
from robocompose.params import load_section, write_profile


@pytest.mark.parametrize("profile", ["default", "paper"])
def test_every_variant_loads_from_both_profiles(tmp_path, profile):
    import shutil
    from pathlib import Path

    shutil.copytree(Path(__file__).parents[2] / "profiles", tmp_path / "profiles")
    params = write_profile(profile, tmp_path)
    for name in VARIANTS:
        variant, model, train, metrics = load_section(TrainVaeParams, "train_vae", params).variant(name)
        assert model.predictor == (name == "full")  # nogram: no contacts, no predictor (as GLSO trains it)
        assert model.constraints == ("tree" if name == "nogram" else "grammar")
    if profile == "paper":
        assert (model.hidden, model.latent, train.steps, train.batch_size) == (450, 28, 400_000, 32)
        assert (train.beta_start, train.beta_every, train.beta_increment, train.lr_decay_every) == (
            40_000, 2_000, 0.002, 40_000)


def test_bad_variant_and_fields_are_named(tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text("train_vae:\n  model: {hidden: 8}\n  train: {steps: 10}\n  variants:\n"
                      "    full: {data: d.parquet, extra: '', predictor: yes, constraints: grammar, size: 3}\n")
    with pytest.raises(ValueError, match=r"train_vae.variants.full.size: unknown field"):
        load_section(TrainVaeParams, "train_vae", params)
    params.write_text(params.read_text().replace(", size: 3", ""))
    with pytest.raises(ValueError, match=r"params.yaml: train_vae.metrics: missing section"):  # never the defaults
        load_section(TrainVaeParams, "train_vae", params)
    params.write_text(params.read_text() + "  metrics: {}\n  extra: {}\n")
    with pytest.raises(ValueError, match="no variant 'nogram'"):
        load_section(TrainVaeParams, "train_vae", params).variant("nogram")
