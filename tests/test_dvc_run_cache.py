"""DVC's run cache restores every stage, and `dvc exp run -S key=value` runs a one-parameter experiment.

On a tiny copy of the project: a clone that shares the DVC cache (`dvc cache dir`) gets every stage's outputs
from the run cache, byte for byte, without running any (train_vae and teams_eggan included: their checkpoints
are no DVC outs, so DVC keeps a run cache for them); and `dvc exp run -S` changes one param, reruns what it
shapes and records the experiment.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.tiny_project import TINY, dvc_env

TARGETS = ["train_vae", "teams_eggan"]  # and what they need: enumerate, vae_designs, decompose
STAGES = {"enumerate", "vae_designs", "train_vae", "decompose", "teams_eggan"}
OUTPUTS = ["data/designs.parquet", "data/vae_extra_designs.parquet", "models/vae_full.pt", "models/vae_full.mcap",
           "models/vae_nogram.pt", "reports/training", "data/regions.parquet", "data/teams/chips",
           "models/teams_eggan.pt", "data/teams/eggan_fronts.parquet", "reports/metrics/teams_eggan.json"]


def env(project: Path, tmp_path: Path) -> dict:
    return dvc_env(project, DVC_SITE_CACHE_DIR=str(tmp_path / "dvc-site"), GIT_AUTHOR_NAME="t",
                   GIT_AUTHOR_EMAIL="t@t", GIT_COMMITTER_NAME="t", GIT_COMMITTER_EMAIL="t@t")


def run(project: Path, tmp_path: Path, *command: str) -> str:
    done = subprocess.run(command, cwd=project, capture_output=True, text=True, env=env(project, tmp_path))
    assert done.returncode == 0, f"{' '.join(command)}: {done.stdout}\n{done.stderr}"
    return done.stdout + done.stderr


def dvc(project: Path, tmp_path: Path, *args: str) -> str:
    return run(project, tmp_path, sys.executable, "-m", "dvc", *args)


def outputs(project: Path) -> dict[str, bytes]:
    found: dict[str, bytes] = {}
    for name in OUTPUTS:
        path = project / name
        for file in sorted(path.rglob("*") if path.is_dir() else [path]):
            if file.is_file():
                found[file.relative_to(project).as_posix()] = file.read_bytes()
    return found


def stages_said(output: str, pattern: str) -> set[str]:
    return set(re.findall(pattern, output))


@pytest.mark.slow
def test_a_clone_sharing_the_cache_restores_every_stage_from_the_run_cache(tmp_path: Path, copy_project) -> None:
    cache = tmp_path / "cache"
    origin = copy_project(tmp_path / "origin", TINY, commit=True)
    dvc(origin, tmp_path, "cache", "dir", "--local", str(cache))
    ran = dvc(origin, tmp_path, "repro", *TARGETS)
    assert stages_said(ran, r"Running stage '([^']+)'") == STAGES, ran
    assert (origin / "models" / "checkpoints" / "vae_full").is_dir()  # checkpoints are still written
    run(origin, tmp_path, "git", "add", "-A")
    run(origin, tmp_path, "git", "commit", "-qm", "tiny run")  # dvc.lock and the metrics, as the project commits them

    clone = tmp_path / "clone"
    run(tmp_path, tmp_path, "git", "clone", "-q", str(origin), str(clone))
    assert not (clone / "models" / "vae_full.pt").exists()
    dvc(clone, tmp_path, "cache", "dir", "--local", str(cache))
    restored = dvc(clone, tmp_path, "repro", *TARGETS)
    assert "Running stage" not in restored, restored
    assert stages_said(restored, r"Stage '([^']+)' is cached - skipping run") == STAGES, restored
    assert not (clone / "models" / "checkpoints").exists()  # nothing ran: no checkpoint was written
    produced = outputs(origin)
    assert outputs(clone) == produced and "models/vae_full.pt" in produced and "models/teams_eggan.pt" in produced
    assert run(clone, tmp_path, "git", "status", "--porcelain") == ""  # dvc.lock and the metrics unchanged
    assert "up to date" in dvc(clone, tmp_path, "status", *TARGETS)


@pytest.mark.slow
def test_dvc_exp_run_sets_one_param_reruns_its_stage_and_records_the_experiment(tmp_path: Path, copy_project) -> None:
    project = copy_project(tmp_path / "project", TINY, commit=True)
    dvc(project, tmp_path, "repro", "decompose")
    run(project, tmp_path, "git", "add", "-A")
    run(project, tmp_path, "git", "commit", "-qm", "baseline")
    metrics = project / "reports" / "metrics" / "decompose.json"
    assert json.loads(metrics.read_text())["chips"] == 4

    ran = dvc(project, tmp_path, "exp", "run", "-S", "teams.chips.n_synthetic=3", "decompose")
    assert "Running stage 'decompose'" in ran, ran
    assert yaml.safe_load((project / "params.yaml").read_text())["teams"]["chips"]["n_synthetic"] == 3
    assert json.loads(metrics.read_text())["chips"] == 3  # the result follows the param
    diff = json.loads(dvc(project, tmp_path, "params", "diff", "--json"))
    assert diff == {"params.yaml": {"teams.chips.n_synthetic": {"old": 4, "new": 3, "diff": -1}}}
    shown = dvc(project, tmp_path, "exp", "show", "--md", "--no-pager", "--drop", ".*", "--keep",
                "Experiment|teams.chips.n_synthetic")
    rows = [[cell.strip() for cell in line.strip("|").split("|")] for line in shown.splitlines()[2:] if line]
    # the workspace, the baseline commit, and the experiment off it
    assert [row[1] for row in rows] == ["3", "4", "3"] and rows[2][0].startswith("└── "), shown
