"""Training: schedules, a tiny model that learns, checkpoints, and resuming after a kill."""

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from robocompose.io import read_mcap
from robocompose.latent.curves import LOG_FIELDS, read_curves
from robocompose.latent.train import (
    TrainConfig,
    batch_indices,
    beta_at,
    load_designs,
    load_model,
    log_evaluation,
    lr_at,
    reconstruction_accuracy,
    save_model,
    split,
    train,
    training_log,
    write_logs,
)
from tests.latent.conftest import TINY


def test_schedules_follow_the_reference():
    c = TrainConfig()
    assert beta_at(39_999, c) == 0.0 and beta_at(40_000, c) == pytest.approx(0.002)
    assert beta_at(41_999, c) == pytest.approx(0.002) and beta_at(42_000, c) == pytest.approx(0.004)
    assert beta_at(10**8, c) == 1.0
    assert lr_at(39_999, c) == pytest.approx(1e-3) and lr_at(80_000, c) == pytest.approx(0.81e-3)


def test_split_and_batches_are_deterministic_and_disjoint():
    train_idx, test_idx = split(100, 0.1, seed=3)
    assert len(test_idx) == 10 and not set(train_idx) & set(test_idx)
    np.testing.assert_array_equal(split(100, 0.1, seed=3)[1], test_idx)
    epoch = np.concatenate([batch_indices(s, 90, 30, seed=0) for s in range(3)])
    assert sorted(epoch) == list(range(90))  # one epoch visits every row once


def test_config_rejects_straddling_checkpoints():
    with pytest.raises(ValueError, match="multiple of log_every"):
        TrainConfig(log_every=10, checkpoint_every=15)


def test_tiny_model_learns_its_designs_and_saves(tmp_path, write_designs):
    designs = load_designs(write_designs(tmp_path / "d.parquet", 12), "grammar", TINY.max_nodes)
    config = TrainConfig(steps=300, batch_size=8, lr=1e-2, beta_start=10**6, holdout=0.25, log_every=50,
                         eval_every=300, checkpoint_every=300, threads=1)
    with training_log(tmp_path / "live") as live:
        model, train_set, _ = train(TINY, config, designs, tmp_path / "ck.pt", live, tmp_path / "log.mcap")
        log_evaluation(live, {"reconstruction_accuracy": 0.5, "property_mse": None})
    assert reconstruction_accuracy(model, train_set) >= 0.5  # memorises most of what it saw
    log = read_curves(tmp_path / "live")
    assert list(log["step"]) == [50, 100, 150, 200, 250, 300]
    assert log["loss"].iloc[-1] < log["loss"].iloc[0]
    assert log["heldout_reconstruction"].notna().tolist() == [False] * 5 + [True]  # every eval_every steps
    assert len([m for m in read_mcap(tmp_path / "log.mcap") if m.topic == "/vae/train"]) == 6
    again = load_model(save_model(model, tmp_path / "m.pt"))
    assert reconstruction_accuracy(again, train_set) == reconstruction_accuracy(model, train_set)


def test_training_log_is_dvclive_offline_for_dvc_plots_and_exp_show(tmp_path, write_designs):
    """dvclive writes one TSV per curve (step, value; no timestamp) and a summary with the final metrics, and
    nothing else: no dvc.yaml of its own, no report, no experiment."""
    designs = load_designs(write_designs(tmp_path / "d.parquet", 12, seed=5), "grammar", TINY.max_nodes)
    config = TrainConfig(steps=20, batch_size=8, holdout=0.25, log_every=10, eval_every=20, checkpoint_every=20,
                         threads=1)
    dvc_yaml = (Path.cwd() / "dvc.yaml").read_bytes()
    with training_log(tmp_path / "live") as live:
        train(TINY, config, designs, tmp_path / "ck.pt", live, tmp_path / "log.mcap")
        log_evaluation(live, {"reconstruction_accuracy": 0.25, "property_mse": None})
    files = {p.relative_to(tmp_path / "live").as_posix() for p in (tmp_path / "live").rglob("*") if p.is_file()}
    assert files == {"metrics.json", "plots/metrics/heldout/reconstruction.tsv",
                     *(f"plots/metrics/train/{k}.tsv" for k in ("loss", "label_loss", "stop_loss", "kl", "pred_loss",
                                                                "label_acc", "stop_acc", "beta", "lr"))}
    assert (tmp_path / "live/plots/metrics/train/loss.tsv").read_text().splitlines()[0] == "step\tloss"
    summary = json.loads((tmp_path / "live" / "metrics.json").read_text())
    assert summary["step"] == 20 and summary["evaluation"] == {"reconstruction_accuracy": 0.25}
    assert 0 <= summary["heldout"]["reconstruction"] <= 1
    assert (Path.cwd() / "dvc.yaml").read_bytes() == dvc_yaml


RUN = """
import json, sys
from pathlib import Path
from robocompose.latent.train import TrainConfig, load_designs, train, reconstruction_accuracy
from robocompose.latent.model import VAEConfig
out = Path(sys.argv[1])
model_config = VAEConfig(hidden=16, latent=4, predictor_hidden=8, max_nodes=30)
designs = load_designs(sys.argv[2], "grammar", 30)
config = TrainConfig(steps=200, batch_size=8, beta_start=50, beta_every=20, lr_decay_every=50, holdout=0.25,
                     log_every=20, eval_every=100, checkpoint_every=40, threads=1)
from robocompose.latent.train import training_log
with training_log(out / "live") as live:
    model, tr, te = train(model_config, config, designs, out / "ck.pt", live, out / "log.mcap")
state = {k: v.sum().item() for k, v in model.state_dict().items()}
(out / "result.json").write_text(json.dumps({"train": reconstruction_accuracy(model, tr), "state": state}))
"""


def _run(out: Path, data: Path, kill_after_checkpoint: bool) -> dict:
    out.mkdir()
    env = {**os.environ, "PYTHONPATH": str(Path.cwd())}
    proc = subprocess.Popen([sys.executable, "-c", RUN, str(out), str(data)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    if kill_after_checkpoint:
        while not (out / "ck.pt").exists():
            assert proc.poll() is None, proc.stdout.read().decode()
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        assert not (out / "result.json").exists()
        return _resume(out, data, env)
    assert proc.wait() == 0, proc.stdout.read().decode()
    return json.loads((out / "result.json").read_text())


def _resume(out: Path, data: Path, env: dict) -> dict:
    done = subprocess.run([sys.executable, "-c", RUN, str(out), str(data)], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "resuming from" in done.stdout
    return json.loads((out / "result.json").read_text())


def test_killed_run_resumes_to_the_same_model(tmp_path, write_designs):
    data = write_designs(tmp_path / "d.parquet", 16, seed=1)
    whole = _run(tmp_path / "whole", data, kill_after_checkpoint=False)
    resumed = _run(tmp_path / "killed", data, kill_after_checkpoint=True)
    assert resumed == whole  # same weights to the last bit, same accuracy
    curves = sorted(p.relative_to(tmp_path / "whole") for p in (tmp_path / "whole" / "live").rglob("*.*"))
    assert curves == sorted(p.relative_to(tmp_path / "killed") for p in (tmp_path / "killed" / "live").rglob("*.*"))
    for name in ("metrics.json", "plots/metrics/train/loss.tsv"):  # a resumed run's summary keys in the same order
        assert (tmp_path / "whole" / "live" / name).read_bytes() == (tmp_path / "killed" / "live" / name).read_bytes()
    for path in curves:  # the dvclive files of the resumed run are those of the uninterrupted one, byte for byte
        assert (tmp_path / "killed" / path).read_bytes() == (tmp_path / "whole" / path).read_bytes(), path


def test_extra_designs_train_without_contacts_and_never_leak_held_out(tmp_path, write_designs):
    designs = load_designs(write_designs(tmp_path / "d.parquet", 12, seed=2), "grammar", TINY.max_nodes)
    extra = designs.subset(np.arange(12))  # all of them again, contacts unknown
    extra = type(extra)(extra.ids, extra.trees, extra.replays, np.full_like(extra.contacts, np.nan))
    config = TrainConfig(steps=20, batch_size=8, holdout=0.25, log_every=10, eval_every=20, checkpoint_every=20,
                         threads=1)
    with training_log(tmp_path / "live") as live:
        _, train_set, test_set = train(TINY, config, designs, tmp_path / "ck.pt", live, tmp_path / "log.mcap",
                                       extra=extra)
    assert not set(test_set.ids) & set(train_set.ids)
    assert len(train_set.ids) == 2 * 9  # 9 training designs, and their 9 copies without contacts
    assert np.isfinite(read_curves(tmp_path / "live")["pred_loss"]).all()


def test_raising_steps_extends_a_finished_run(tmp_path, write_designs):
    designs = load_designs(write_designs(tmp_path / "d.parquet", 12, seed=3), "grammar", TINY.max_nodes)
    short = TrainConfig(steps=30, batch_size=8, beta_start=10, beta_every=5, holdout=0.25, log_every=10,
                        eval_every=30, checkpoint_every=10, threads=1)
    long = TrainConfig(**{**short.__dict__, "steps": 60, "eval_every": 20})  # bookkeeping may change too

    def run(folder: str, config: TrainConfig):
        with training_log(tmp_path / folder / "live") as live:
            model, _, _ = train(TINY, config, designs, tmp_path / folder / "ck.pt", live,
                                tmp_path / folder / "log.mcap")
        return {k: v.clone() for k, v in model.state_dict().items()}

    run("extended", short)
    extended, straight = run("extended", long), run("straight", long)
    assert all(torch.equal(extended[k], straight[k]) for k in straight)
    changed = TrainConfig(**{**long.__dict__, "lr": 0.002})  # a real change starts afresh
    assert not all(torch.equal(run("extended", changed)[k], straight[k]) for k in straight)


def test_same_ids_with_changed_contacts_or_changed_code_retrain(tmp_path, write_designs, monkeypatch):
    import robocompose.latent.train as train_module

    designs = load_designs(write_designs(tmp_path / "d.parquet", 12, seed=4), "grammar", TINY.max_nodes)
    config = TrainConfig(steps=20, batch_size=8, holdout=0.25, log_every=10, eval_every=20, checkpoint_every=20,
                         threads=1)

    def run(data):
        with training_log(tmp_path / "live") as live:
            model, _, _ = train(TINY, config, data, tmp_path / "ck.pt", live, tmp_path / "log.mcap")
        return {k: v.clone() for k, v in model.state_dict().items()}

    first = run(designs)
    assert all(torch.equal(run(designs)[k], first[k]) for k in first)  # an unchanged setup resumes: same weights
    moved = type(designs)(designs.ids, designs.trees, designs.replays, designs.contacts + 0.5)  # same ids
    assert not all(torch.equal(run(moved)[k], first[k]) for k in first)
    run(designs)  # back to the first checkpoint's data
    key = train_module.run_key(TINY, config, designs, designs)
    monkeypatch.setattr(train_module, "code_digest", lambda *modules, **exclude: "changed-source")
    assert train_module.run_key(TINY, config, designs, designs) != key


def test_training_log_validates_against_its_schema(tmp_path, valid_foxglove_log):
    rows = [{field: 0.5 for field in LOG_FIELDS} | {"step": step, "heldout_reconstruction": math.nan}
            for step in (50, 100)]
    with training_log(tmp_path / "live") as live:
        write_logs(rows, live, tmp_path / "log.mcap")
    assert valid_foxglove_log(tmp_path / "log.mcap") == 2
