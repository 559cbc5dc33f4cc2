"""The thesis-scale VAE in committed pieces: the compressed schedule, design pieces, a refused foreign checkpoint."""

import dataclasses
import hashlib
import json

import pandas as pd
import pytest
import yaml

from robocompose.cli import main
from robocompose.dataset.enumerate import EnumerateConfig
from robocompose.io import read_table, write_table
from robocompose.io.checkpoint import save_checkpoint
from robocompose.io.errors import InputError
from robocompose.io.provenance import ROOT
from robocompose.latent import thesis_scale
from robocompose.latent.thesis_scale import ThesisScaleConfig
from robocompose.latent.train import TrainConfig, beta_at, load_model, lr_at, train, training_log
from tests.latent.conftest import TINY


def tiny(directory, designs: int = 20, piece: int = 8, steps: int = 4) -> ThesisScaleConfig:
    train = TrainConfig(steps=steps, batch_size=4, holdout=0.25, log_every=2, eval_every=4, eval_designs=4,
                        checkpoint_every=2, threads=1)
    return ThesisScaleConfig(directory=str(directory), designs=designs, piece=piece, model=TINY, train=train)


def test_the_compressed_schedule_ends_where_the_thesis_400k_steps_end():
    thesis, ours = TrainConfig(), thesis_scale.thesis_schedule(100_000)
    assert (ours.lr_decay_every, ours.beta_start, ours.beta_every) == (10_000, 10_000, 500)
    assert beta_at(ours.steps - 1, ours) == pytest.approx(beta_at(thesis.steps - 1, thesis)) == pytest.approx(0.36)
    assert lr_at(ours.steps - 1, ours) == pytest.approx(lr_at(thesis.steps - 1, thesis))
    assert ours.pred_weight == 20.0 and ThesisScaleConfig().model.hidden == 450


def test_pieces_are_enumerated_until_the_distinct_designs_are_there_and_not_again(tmp_path):
    config = tiny(tmp_path / "vae", designs=20, piece=8)
    enumeration = EnumerateConfig(n=1, min_links=11, chunk=16)
    paths = thesis_scale.enumerate_pieces(config, enumeration)
    sizes = [len(read_table(p, "designs")) for p in paths]
    assert sizes == [8, 8, 4] and thesis_scale.distinct_designs(config) == 20  # the last piece: what is missing
    first = paths[0].read_bytes()
    assert thesis_scale.enumerate_pieces(config, enumeration) == paths and paths[0].read_bytes() == first


def test_a_design_in_two_pieces_counts_once(tmp_path, write_designs):
    config = tiny(tmp_path / "vae", designs=12, piece=8)
    one = read_table(write_designs(tmp_path / "a.parquet", 8, seed=1), "designs")
    two = read_table(write_designs(tmp_path / "b.parquet", 8, seed=2), "designs")
    (tmp_path / "vae").mkdir()
    write_table(one, tmp_path / "vae" / "designs-000.parquet", "designs")
    write_table(pd.concat([one.iloc[:4], two.iloc[:4]], ignore_index=True), tmp_path / "vae" / "designs-001.parquet",
                "designs")
    assert thesis_scale.distinct_designs(config) == 12
    assert thesis_scale.load_pieces(config).ids == list(one["design_id"]) + list(two["design_id"][:4])
    with pytest.raises(InputError, match=r"12 distinct designs in its pieces, expected >= 13"):
        thesis_scale.load_pieces(dataclasses.replace(config, designs=13))


def test_training_finishes_into_a_model_and_reports_its_progress(tmp_path, write_designs):
    config = tiny(tmp_path / "vae", designs=12)
    write_designs(tmp_path / "vae" / "designs-000.parquet", 12)
    untrained = {"full": {"step": 0, "finished": False, "sha256": None}}
    assert thesis_scale.progress(config)["trained"] == untrained
    model = thesis_scale.train_thesis_scale(config, "full")
    assert load_model(model).config == TINY and not thesis_scale.checkpoint_path(config, "full").exists()
    done = thesis_scale.progress(config)
    assert (done["trained"]["full"]["step"], done["steps"], done["trained"]["full"]["finished"],
            done["issue_scale"]) == (4, 4, True, False)
    assert done["trained"]["full"]["sha256"] == hashlib.sha256(model.read_bytes()).hexdigest()
    assert json.loads((tmp_path / "vae" / "log" / "full" / "metrics.json").read_text())["step"] == 4


def test_the_nopred_twin_trains_on_the_same_designs_without_the_predictor(tmp_path, write_designs):
    config = dataclasses.replace(tiny(tmp_path / "vae", designs=12), variants=["full", "nopred"])
    write_designs(tmp_path / "vae" / "designs-000.parquet", 12)
    twin = thesis_scale.train_thesis_scale(config, "nopred")
    assert load_model(twin).config == dataclasses.replace(TINY, predictor=False) and twin.name == "vae_nopred.pt"
    trained = thesis_scale.progress(config)["trained"]
    assert (trained["nopred"]["finished"], trained["full"]["finished"]) == (True, False)
    assert thesis_scale.finished_model(config) is None and thesis_scale.finished_model(config, "nopred") == twin


def test_the_command_trains_every_variant_asked_and_prints_where_each_stands(tmp_path, write_designs, capsys):
    doc = yaml.safe_load((ROOT / "params.yaml").read_text())
    config = tiny(tmp_path / "vae", designs=12)
    doc["vae_thesis"] = {**dataclasses.asdict(config), "variants": ["full", "nopred"]}
    (tmp_path / "params.yaml").write_text(yaml.safe_dump(doc))
    write_designs(tmp_path / "vae" / "designs-000.parquet", 12)  # the pieces are there: no enumeration
    assert main(["glso-campaign", "vae", "--params", str(tmp_path / "params.yaml")]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert {v: (t["step"], t["finished"]) for v, t in printed["trained"].items()} == {
        "full": (4, True), "nopred": (4, True)}
    assert load_model(tmp_path / "vae" / "vae_nopred.pt").config.predictor is False


def test_a_committed_checkpoint_of_another_run_is_refused_not_overwritten(tmp_path, write_designs):
    config = tiny(tmp_path / "vae", designs=12)
    write_designs(tmp_path / "vae" / "designs-000.parquet", 12)
    foreign = save_checkpoint(thesis_scale.checkpoint_path(config, "full"), "0" * 16, {"step": 2})
    committed_log = thesis_scale.log_dir(config, "full") / "metrics.json"
    committed_log.parent.mkdir(parents=True)
    committed_log.write_text('{"step": 2}')
    before = foreign.read_bytes()
    with pytest.raises(InputError, match="checkpoint-full.pt"):
        thesis_scale.train_thesis_scale(config, "full")
    assert foreign.read_bytes() == before and thesis_scale.finished_model(config) is None
    assert committed_log.read_text() == '{"step": 2}'  # refused before the training log was opened


def test_the_check_before_training_accepts_the_checkpoint_train_writes(tmp_path, write_designs):
    # check_resumable derives train()'s key itself: a divergence would refuse every committed checkpoint
    config = tiny(tmp_path / "vae", designs=12, steps=4)
    write_designs(tmp_path / "vae" / "designs-000.parquet", 12)
    designs, checkpoint = thesis_scale.load_pieces(config), thesis_scale.checkpoint_path(config, "full")
    with training_log(tmp_path / "log") as live:
        train(config.variant_model("full"), dataclasses.replace(config.train, steps=2), designs, checkpoint, live,
              tmp_path / "log.mcap")
    assert checkpoint.exists()
    thesis_scale.check_resumable(config, "full", designs)  # no error: the same run, two steps further to go
    with pytest.raises(InputError, match="checkpoint-nopred.pt"):
        checkpoint.rename(thesis_scale.checkpoint_path(config, "nopred"))
        thesis_scale.check_resumable(config, "nopred", designs)


def test_the_config_refuses_a_vae_glso_cannot_search():
    with pytest.raises(InputError, match="model"):
        ThesisScaleConfig(model=dataclasses.replace(TINY, predictor=False))
    with pytest.raises(InputError, match="piece"):
        ThesisScaleConfig(designs=10, piece=11)
    with pytest.raises(InputError, match=r"variants: expected distinct names of \['full', 'nopred'\]"):
        ThesisScaleConfig(variants=["full", "full"])
