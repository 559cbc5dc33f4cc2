"""The reliability suite: faults injected on purpose, each one survived with nothing lost.

Every test declares the faults it injects with `@injects(...)`; FAULTS lists them all, and the README's
reliability line states their count (checked by the last test). A test passes only if its faults were
survived: the stage resumed (or reran) to byte-identical outputs, the map returned every result, the
corruption was detected (a clear error naming the file, or a rebuild of what only saves time), the previous
output stayed intact. So the number of data lost is 0 whenever this module passes.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest

from robocompose.latent.params import VARIANTS
from tests.tiny_project import TINY, dvc_env

ROOT = Path(__file__).resolve().parents[1]

FAULTS = {
    "kill-enumerate": "kill -9 of the enumerate stage mid-run, then `dvc repro`",
    "kill-train-vae": "kill -9 of the train_vae stage after a checkpoint, then `dvc repro`",
    "kill-glso": "kill -9 of the glso stage after its first search run, then `dvc repro`",
    "kill-eggan": "kill -9 of the teams_eggan stage (EG-GAN training) after a checkpoint, then `dvc repro`",
    "kill-dask-worker": "SIGKILL of a Dask worker process during a map",
    "corrupt-parquet": "a flipped byte inside a parquet data page",
    "truncated-parquet": "a parquet table cut in half",
    "corrupt-cache": "a flipped byte in the evaluation cache",
    "truncated-cache": "an evaluation cache cut in half",
    "corrupt-model": "a flipped byte inside a VAE model's tensor data",
    "truncated-model": "a VAE model file cut in half",
    "corrupt-checkpoint": "a flipped byte in a VAE training checkpoint",
    "full-disk-parquet": "the disk full while a parquet table is rewritten",
    "full-disk-json": "the disk full while a JSON metrics file is rewritten",
    "full-disk-mcap": "the disk full while an MCAP log is rewritten",
    "full-disk-checkpoint": "the disk full while a checkpoint is rewritten",
}


def injects(*faults: str):
    unknown = [f for f in faults if f not in FAULTS]
    assert not unknown, f"undeclared faults {unknown}"
    return pytest.mark.faults(*faults)


def flip_byte(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0xFF
    path.write_bytes(bytes(data))


def truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


# --- kill -9 of a stage, then `dvc repro`, on a tiny copy of the project ---



def dvc(project: Path, *args: str) -> str:
    """Run dvc in `project` (its stages import the project's own copy of robocompose); return its output."""
    done = subprocess.run([sys.executable, "-m", "dvc", *args], cwd=project, capture_output=True, text=True,
                          env=dvc_env(project))
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout + done.stderr


def watch_stage(project: Path, args: list[str], stage: str, ready=lambda process: False) -> tuple[bool, float]:
    """Run `dvc repro *args` and poll the stage script's process. If `ready(p)` says the stage is in its middle,
    SIGKILL dvc and the stage (the whole process group, as an OOM kill of the job would); else let it finish.
    Returns (whether it was killed, the stage process's CPU seconds last seen)."""
    import psutil
    log = (project / "watched.log").open("w")
    proc = subprocess.Popen([sys.executable, "-m", "dvc", "repro", *args], cwd=project, stdout=log,
                            stderr=subprocess.STDOUT, env=dvc_env(project), start_new_session=True)
    deadline = time.monotonic() + 300
    script = f"stages/{stage.partition('@')[0]}.py"
    cpu = 0.0

    def stage_process():
        try:  # the interpreter running the script, not a shell that may wrap it
            return next((p for p in psutil.Process(proc.pid).children(recursive=True)
                         if script in " ".join(p.cmdline()) and p.name().startswith("python")), None)
        except psutil.Error:  # a process ended while we looked
            return None

    while proc.poll() is None:
        assert time.monotonic() < deadline, f"{stage} never reached its middle"
        process = stage_process()
        try:
            cpu = max(cpu, sum(process.cpu_times()[:2])) if process is not None else cpu
        except psutil.Error:  # it ended while we looked: the next poll says so
            pass
        if ready(process):
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            log.close()
            return True, cpu
        time.sleep(0.05)
    log.close()
    assert proc.returncode == 0, (project / "watched.log").read_text()
    return False, cpu


def kill_stage(project: Path, stage: str, ready, *flags: str) -> None:
    """`dvc repro *flags stage`, killed once `ready(p)` (p: the stage script's process, once dvc started it) says
    the stage is in its middle."""
    killed, _ = watch_stage(project, [*flags, stage], stage, ready)
    assert killed, f"{stage} ended before it could be killed: {(project / 'watched.log').read_text()}"


def outputs(project: Path, paths: list[str]) -> dict[str, bytes]:
    """The bytes of every file under `paths` (outputs hold no wall times, so a rerun must repeat them exactly)."""
    found: dict[str, bytes] = {}
    for name in paths:
        path = project / name
        for file in sorted(path.rglob("*") if path.is_dir() else [path]):
            if file.is_file():
                found[file.relative_to(project).as_posix()] = file.read_bytes()
    return found


def differing(a: dict[str, bytes], b: dict[str, bytes]) -> list[str]:
    """The files present in one of `a`, `b` only, or with other bytes (a failure names them, not their bytes)."""
    return sorted(name for name in a.keys() | b.keys() if a.get(name) != b.get(name))


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory, copy_project) -> Path:
    """A tiny copy of the project (TINY params), committed: dvclive in the train_vae stage needs a revision."""
    return copy_project(tmp_path_factory.mktemp("reliability") / "project", TINY, commit=True)


ENUMERATE_OUTS = ["data/designs.parquet", "data/designs_nogram.parquet", "reports/metrics/enumerate.json"]
TRAIN_OUTS = [*(f"models/vae_{variant}.{kind}" for variant in VARIANTS for kind in ("pt", "mcap")), "reports/training"]


@pytest.mark.slow
@injects("kill-enumerate")
def test_killed_enumerate_stage_reruns_to_the_same_bytes(project: Path) -> None:
    """Enumeration keeps no checkpoint (a run at the default scale takes a minute): after a kill, `dvc repro`
    reruns it from scratch, and the outputs are byte-identical to an uninterrupted run."""
    import psutil

    # Its progress bar stays off when stderr is a log, so the stage's own CPU time says where it is: the
    # uninterrupted run first, and the kill at 60% of its CPU time (past the imports, ~25%, on any machine).
    _, cpu = watch_stage(project, ["-f", "-s", "enumerate"], "enumerate")
    uninterrupted = outputs(project, ENUMERATE_OUTS)
    assert cpu > 1.0, "the watcher never saw the stage's process"

    def in_the_middle(stage) -> bool:
        try:
            return stage is not None and sum(stage.cpu_times()[:2]) > 0.6 * cpu
        except psutil.Error:  # it ended while we looked: the next poll says so
            return False

    kill_stage(project, "enumerate", in_the_middle, "-f", "-s")
    assert not (project / "data" / "designs.parquet").exists()  # really killed mid-stage
    dvc(project, "repro", "enumerate")
    assert differing(outputs(project, ENUMERATE_OUTS), uninterrupted) == [] and len(uninterrupted) == 3


@pytest.mark.slow
@injects("kill-train-vae")
def test_killed_train_vae_stage_resumes_to_the_same_bytes(project: Path) -> None:
    """Killed once its first variant (`full`; the variants train one after another here, workers 1) wrote a
    checkpoint, `dvc repro` resumes it and trains the others: every variant's model, logs, curves and metrics are
    byte-identical to an uninterrupted run's."""
    dvc(project, "repro", "vae_designs")  # (and enumerate, if the test above did not run)
    checkpoints = project / "models" / "checkpoints"
    kill_stage(project, "train_vae", lambda _: (checkpoints / "vae_full" / "last.pt").exists())
    assert not (project / "models" / "vae_full.pt").exists()
    assert "resuming from" in dvc(project, "repro", "train_vae")
    resumed = outputs(project, TRAIN_OUTS)
    for file in checkpoints.glob("vae_*/*"):  # the uninterrupted run starts without a checkpoint
        file.unlink()
    dvc(project, "repro", "-f", "-s", "train_vae")
    assert differing(outputs(project, TRAIN_OUTS), resumed) == []
    assert {f"models/vae_{variant}.pt" for variant in VARIANTS} <= set(resumed)


GLSO_OUTS = ["data/glso/steps.parquet", "data/glso/runs", "data/glso/rollouts", "reports/metrics/glso.json"]
EGGAN_OUTS = ["models/teams_eggan.pt", "data/teams/eggan_queries.parquet", "data/teams/eggan_fronts.parquet",
              "data/teams/coverage_examples.parquet", "reports/metrics/teams_eggan.json"]


@pytest.mark.slow
@injects("kill-glso")
def test_killed_glso_stage_resumes_to_the_same_results(project: Path) -> None:
    """The stage runs its searches one after another here (workers 1); killed after the first, `dvc repro`
    keeps the finished run, resumes the others from their per-step checkpoints, and gives the same step
    tables, rollouts and metrics, byte for byte, as an uninterrupted run."""
    runs = project / "data" / "glso" / "runs"
    # a finished run's table, not the hidden temporary file it is written through
    kill_stage(project, "glso", lambda _: runs.is_dir() and any(not p.name.startswith(".") for p in runs.iterdir()))
    assert not (project / "data" / "glso" / "steps.parquet").exists()
    dvc(project, "repro", "glso")
    resumed = outputs(project, GLSO_OUTS)
    for folder in (runs, project / "data" / "glso" / "checkpoints"):  # the uninterrupted run starts afresh
        for file in folder.iterdir():
            file.unlink()
    dvc(project, "repro", "-f", "-s", "glso")
    assert differing(outputs(project, GLSO_OUTS), resumed) == [] and "data/glso/steps.parquet" in resumed


@pytest.mark.slow
@injects("kill-eggan")
def test_killed_eggan_training_resumes_to_the_same_bytes(project: Path) -> None:
    checkpoint = project / "models" / "checkpoints" / "teams_eggan.pt"
    dvc(project, "repro", "decompose")
    kill_stage(project, "teams_eggan", lambda _: checkpoint.exists())
    assert not (project / "models" / "teams_eggan.pt").exists()
    dvc(project, "repro", "teams_eggan")
    resumed = outputs(project, EGGAN_OUTS)
    checkpoint.unlink()
    dvc(project, "repro", "-f", "-s", "teams_eggan")
    assert differing(outputs(project, EGGAN_OUTS), resumed) == [] and "models/teams_eggan.pt" in resumed


# --- a Dask worker killed during a map ---


def _slow_square(x: int) -> tuple[int, int]:
    time.sleep(0.2)
    return x * x, os.getpid()


@injects("kill-dask-worker")
def test_a_dask_worker_killed_during_a_map_loses_no_result() -> None:
    """dask reschedules the killed worker's tasks on the other worker (its nanny starts a new one): every
    result arrives, once per item, identical to what the items give."""
    from dask.distributed import Client, LocalCluster

    from robocompose.fanout.executor import Executor

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0", silence_logs=50) as cluster, \
            Client(cluster.scheduler_address) as client:
        worker_pids = set(client.run(os.getpid).values())
        items = list(range(24))
        with Executor(address=cluster.scheduler_address) as executor:
            arrived, killed = [], None  # (item index, result) in the order they finish
            for index, result in executor.as_completed(_slow_square, items):
                arrived.append((index, result))
                if len(arrived) == 3:  # mid-map: kill the worker that computed the last result
                    killed = result[1]
                    os.kill(killed, signal.SIGKILL)
    assert killed in worker_pids
    assert [value for _, (value, _) in sorted(arrived)] == [x * x for x in items]
    # The rest came from the surviving (or a new) worker; the 4th may have finished on the killed one just before.
    assert killed not in {pid for _, (_, pid) in arrived[4:]}


# --- corrupted or truncated files: detected, never read as data ---


def _parquet_table(path: Path) -> Path:
    from robocompose.io import write_table

    rows = [{"design_id": f"d{i}", "task": "flat", "settings_hash": "h", "seed": 0, "reward": 4.0 + i / 100,
             "status": "ok", "sim_steps": 100 + i, "seconds": 1.0} for i in range(200)]
    return write_table(pd.DataFrame(rows), path, "eval_cache")


def _data_page_offset(path: Path) -> int:
    """A byte inside the first data page of the reward column (past its page header)."""
    import pyarrow.parquet as pq

    metadata = pq.ParquetFile(path).metadata
    names = [metadata.schema.column(i).name for i in range(metadata.num_columns)]
    column = metadata.row_group(0).column(names.index("reward"))
    return column.data_page_offset + column.total_compressed_size // 2


@injects("corrupt-parquet", "truncated-parquet")
def test_a_corrupted_or_truncated_parquet_table_is_an_error_naming_the_file(tmp_path: Path) -> None:
    from robocompose.io import ArtifactError, read_table

    for fault in (lambda p: flip_byte(p, _data_page_offset(p)), truncate):
        path = _parquet_table(tmp_path / "table.parquet")
        fault(path)
        with pytest.raises(ArtifactError, match=re.escape(str(path))):
            read_table(path, "eval_cache")


@injects("corrupt-cache", "truncated-cache")
def test_a_corrupt_evaluation_cache_is_moved_aside_and_rebuilt(tmp_path: Path) -> None:
    """The cache only saves time: a corrupt file is kept (renamed), a warning names it, the evaluation runs
    again and gives the right values."""
    from robocompose.fanout.cache import EvaluationCache
    from robocompose.fanout.executor import evaluate_many

    def evaluate(item: int) -> dict:
        return {"reward": 4.0 + item / 100, "status": "ok", "sim_steps": 100 + item, "seconds": 1.0}

    def key(item: int) -> tuple:
        return (f"d{item}", "flat", "h", 0)

    for n, fault in enumerate((lambda p: flip_byte(p, _data_page_offset(p)), truncate)):
        path = _parquet_table(tmp_path / f"cache{n}.parquet")
        fault(path)
        corrupt = path.read_bytes()
        with pytest.warns(UserWarning, match=re.escape(str(path))):
            cache = EvaluationCache(path)
        assert len(cache) == 0
        assert (tmp_path / f"cache{n}.parquet.corrupt").read_bytes() == corrupt  # kept for inspection
        rows = evaluate_many(evaluate, range(200), key, cache=cache)
        assert rows == [evaluate(i) for i in range(200)]
        rebuilt = EvaluationCache(path)  # saved again, readable, the right values
        assert [rebuilt.get(key(i)) for i in range(200)] == [evaluate(i) for i in range(200)]


def _tiny_vae_run(tmp_path: Path, name: str):
    """A tiny VAE trained to the end in `tmp_path/name` (checkpoint kept); returns (model, checkpoint)."""
    import numpy as np

    from robocompose.grammar.derivation import random_derivation
    from robocompose.io import write_table
    from robocompose.latent.model import VAEConfig
    from robocompose.latent.train import TrainConfig, load_designs, train, training_log

    data = tmp_path / "designs.parquet"
    if not data.exists():
        rng, trees = np.random.default_rng(0), []
        while len(trees) < 12:
            derivation = random_derivation(rng)
            if derivation is not None and derivation.tree.n_links >= 3:
                trees.append(derivation.tree)
        write_table(pd.DataFrame([{"design_id": t.design_id, "rules": [], "parents": list(t.parents),
                                   "tokens": list(t.tokens), "n_links": t.n_links, "n_joints": t.n_joints,
                                   "contacts": [float(t.n_links)] * 16} for t in trees]), data, "designs")
    config = TrainConfig(steps=20, batch_size=4, holdout=0.25, log_every=10, eval_every=20, checkpoint_every=10,
                         threads=1)
    out = tmp_path / name
    with training_log(out / "live") as live:
        model, _, _ = train(VAEConfig(hidden=16, latent=4, predictor_hidden=8, max_nodes=30), config,
                            load_designs(data, "grammar", 30), out / "ck.pt", live, out / "log.mcap")
    return model, out / "ck.pt"


def _tensor_byte(path: Path) -> int:
    """An offset inside the tensor data of a saved torch file (past the header, pickle and record names)."""
    return path.stat().st_size * 3 // 4


@injects("corrupt-model", "truncated-model")
def test_a_corrupted_or_truncated_model_is_an_error_naming_the_file(tmp_path: Path) -> None:
    """torch.load alone reads a flipped tensor byte without complaint; the checksum header catches it."""
    from robocompose.io import InputError
    from robocompose.latent.train import load_model, save_model

    model, _ = _tiny_vae_run(tmp_path, "run")
    for fault in (lambda p: flip_byte(p, _tensor_byte(p)), truncate):
        path = save_model(model, tmp_path / "vae.pt")
        fault(path)
        with pytest.raises(InputError, match=re.escape(f"{path}: checksum mismatch")):
            load_model(path)


@injects("corrupt-checkpoint")
def test_a_corrupt_checkpoint_is_moved_aside_and_training_restarts_to_the_same_model(tmp_path: Path) -> None:
    import torch

    model, checkpoint = _tiny_vae_run(tmp_path, "run")
    flip_byte(checkpoint, _tensor_byte(checkpoint))
    with pytest.warns(UserWarning, match="checksum mismatch"):
        again, _ = _tiny_vae_run(tmp_path, "run")
    assert (checkpoint.parent / "ck.pt.corrupt").exists()
    for name, tensor in model.state_dict().items():
        assert torch.equal(tensor, again.state_dict()[name]), name


# --- a full disk during a write: the previous output stays intact ---

# Each writer first writes a small file; then, with the file size limit (RLIMIT_FSIZE) just above that file's
# size, it rewrites the file with 1 MB of data: the kernel fails the write (EFBIG, as it fails one with
# ENOSPC on a full disk) in the middle of the new file. One process tries every writer kind.
FULL_DISK = textwrap.dedent("""
    import hashlib, json, resource, signal, sys
    from pathlib import Path
    import numpy as np, pandas as pd, torch
    from robocompose.io import McapWriter, atomic_write_json, write_table
    from robocompose.io.torch_file import save_torch

    folder = Path(sys.argv[1])
    noise = np.random.default_rng(0).random(131_072)  # 1 MB of incompressible float64

    def write(kind, out, values):
        if kind == "parquet":
            write_table(pd.DataFrame({"design_id": [f"d{i}" for i in range(len(values))], "task": "flat",
                                      "settings_hash": "h", "seed": 0, "reward": values, "status": "ok",
                                      "sim_steps": 1, "seconds": values}), out, "eval_cache")
        elif kind == "json":
            atomic_write_json(out, {"values": values.tolist()})
        elif kind == "mcap":
            with McapWriter(out) as log:
                for i, value in enumerate(values[:20_000]):
                    log.scalars("/x", float(i), {"value": float(value), "twice": float(value) * 2})
        else:
            save_torch({"step": 1, "model": {"w": torch.from_numpy(values)}}, out)

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails instead of killing us
    results = {}
    for kind, name in (("parquet", "t.parquet"), ("json", "m.json"), ("mcap", "l.mcap"), ("checkpoint", "ck.pt")):
        out = folder / kind / name
        out.parent.mkdir()
        write(kind, out, noise[:4])
        before = hashlib.sha256(out.read_bytes()).hexdigest()
        resource.setrlimit(resource.RLIMIT_FSIZE, (out.stat().st_size + 4096, resource.RLIM_INFINITY))
        try:
            write(kind, out, noise)
            errno = None
        except OSError as err:
            errno = err.errno
        resource.setrlimit(resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
        results[kind] = {"errno": errno, "intact": hashlib.sha256(out.read_bytes()).hexdigest() == before,
                         "files": sorted(p.name for p in out.parent.iterdir())}
    print(json.dumps(results))
""")


@injects("full-disk-parquet", "full-disk-json", "full-disk-mcap", "full-disk-checkpoint")
def test_a_full_disk_during_a_write_leaves_the_previous_output_intact(tmp_path: Path) -> None:
    import errno

    done = subprocess.run([sys.executable, "-c", FULL_DISK, str(tmp_path)], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    results = json.loads(done.stdout.splitlines()[-1])
    names = {"parquet": "t.parquet", "json": "m.json", "mcap": "l.mcap", "checkpoint": "ck.pt"}
    for kind, result in results.items():
        assert result["errno"] == errno.EFBIG, kind  # the rewrite did fail
        assert result["intact"], f"{kind}: the previous output changed"
        assert result["files"] == [names[kind]], f"{kind}: a partial temporary file was left behind"
    assert sorted(results) == sorted(names)


# --- the count ---


def test_every_fault_is_injected_and_the_readme_states_the_count() -> None:
    injected = [fault for value in globals().values() for mark in getattr(value, "pytestmark", [])
                if mark.name == "faults" for fault in mark.args]
    assert sorted(injected) == sorted(FAULTS)  # each declared fault injected by exactly one test
    line = next(line for line in (ROOT / "README.md").read_text().splitlines() if "**Reliability**" in line)
    n = len(FAULTS)
    assert f"{n} faults injected, {n} survived, 0 data lost" in line, line
