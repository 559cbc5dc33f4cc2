"""The `train_vae` stage's variants, trained side by side on worker processes, are the bytes of a run in this
process: models, MCAP logs, dvclive logs and checkpoints."""

from pathlib import Path

import torch

from robocompose.fanout.executor import Executor
from robocompose.latent.params import MetricsConfig, TrainVaeParams, Variant
from robocompose.latent.train import TrainConfig, load_model
from robocompose.latent.variants import train_variants
from tests.latent.conftest import TINY, write_designs_table

TRAIN = TrainConfig(steps=40, batch_size=8, beta_start=10, beta_every=5, lr_decay_every=20, holdout=0.25,
                    log_every=10, eval_every=20, eval_designs=4, checkpoint_every=20, threads=1)
PARAMS = TrainVaeParams(model=TINY, train=TRAIN, metrics=MetricsConfig(prior_samples=4), variants={
    "full": Variant("data/designs.parquet", "data/extra.parquet", predictor=True, constraints="grammar"),
    "nogram": Variant("data/nogram.parquet", "", predictor=False, constraints="tree")})


def files(root: Path) -> dict[str, bytes]:
    """The bytes of every file the variants wrote under `root`."""
    return {path.relative_to(root).as_posix(): path.read_bytes()
            for folder in ("models", "reports") for path in sorted((root / folder).rglob("*")) if path.is_file()}


def test_variants_trained_on_worker_processes_are_the_bytes_of_a_run_in_this_process(tmp_path, make_trees,
                                                                                      nogram_trees):
    figures, written = {}, {}
    for folder, workers in (("inline", 1), ("processes", 2)):
        root = tmp_path / folder
        write_designs_table(root / "data/designs.parquet", make_trees(16, 1, min_links=3))
        write_designs_table(root / "data/extra.parquet", make_trees(8, 2, min_links=3))
        write_designs_table(root / "data/nogram.parquet", nogram_trees)
        with Executor(workers=workers) as executor:
            assert executor.backend == folder
            figures[folder] = dict(train_variants(PARAMS, root, executor))
        written[folder] = files(root)
    assert written["processes"] == written["inline"]
    assert {"models/vae_full.pt", "models/vae_nogram.mcap", "models/checkpoints/vae_full/last.pt",
            "reports/training/vae_nogram/metrics.json"} <= set(written["inline"])
    for name in PARAMS.variants:  # the same weights, loaded back
        inline, processes = (load_model(tmp_path / folder / f"models/vae_{name}.pt").state_dict()
                             for folder in ("inline", "processes"))
        assert inline.keys() == processes.keys() and all(torch.equal(inline[k], processes[k]) for k in inline)
    for run in figures.values():  # each worker trained at `threads`, not at the cores it was started with
        assert set(run) == {"full", "nogram"} and all(f["threads"] == TRAIN.threads for f in run.values())
        assert all(f["seconds"] > 0 and f["steps_per_s"] > 0 for f in run.values())
