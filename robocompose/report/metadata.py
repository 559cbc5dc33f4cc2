"""Report section: what produced the report (git revision, params digest, every stage's wall time)."""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

from robocompose.report.timings import TIMINGS_FILE, read_timings


def _git(*args: str, cwd: Path = Path(".")) -> str:
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=True, cwd=cwd).stdout.rstrip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def pipeline(root: Path = Path(".")) -> tuple[list[str], list[str]]:
    """The DVC stages in dvc.yaml order (matrix stages expanded, `train_vae@full`) and the paths DVC writes
    while it runs them: dvc.lock and every stage's outputs."""
    from dvc.repo import Repo

    with Repo(str(root)) as repo:
        stages = list(repo.index.stages)
        return [s.name for s in stages], ["dvc.lock", *(Path(o.def_path).as_posix() for s in stages for o in s.outs)]


def uncommitted(written: list[str], root: Path = Path(".")) -> list[str] | None:
    """Tracked files that differ from HEAD, except those a `dvc repro` writes (`written`, and the wall times):
    a report built by `dvc repro` from a clean tree then shows a clean revision. None if git is unavailable."""
    status = _git("status", "--porcelain", "--untracked-files=no", cwd=root)
    if status == "unknown":
        return None
    own = [*written, TIMINGS_FILE.as_posix()]
    changed = [line[3:].split(" -> ")[-1].strip('"') for line in status.splitlines() if line.strip()]
    return [path for path in changed if not any(path == out or path.startswith(out.rstrip("/") + "/") for out in own)]


def section(reports_dir: Path, params_file: Path = Path("params.yaml"), root: Path = Path(".")) -> str:
    stages, written = pipeline(root)
    revision = _git("rev-parse", "--short", "HEAD", cwd=root)
    changed = uncommitted(written, root)
    digest = hashlib.sha256(params_file.read_bytes()).hexdigest()[:12] if params_file.exists() else "missing"
    timings = read_timings(Path(reports_dir) / "timings.json")
    state = f" with uncommitted changes to {', '.join(f'`{p}`' for p in changed)}" if changed else ""
    lines = ["## Run metadata", "",
             f"- git revision: `{revision}`" + state,
             f"- params.yaml sha256: `{digest}`", "",
             "Wall times of each stage's last run (in `reports/timings.json`, kept out of DVC's outputs); "
             "the report's own row is its previous run.", "",
             "| stage | wall time (s) | figures |", "|---|---:|---|"]
    for stage in stages:
        figures = timings.get(stage)
        if figures is None:
            lines.append(f"| {stage} | not recorded | |")
            continue
        extra = ", ".join(f"{k} {v}" for k, v in figures.items() if k != "seconds")
        lines.append(f"| {stage} | {figures.get('seconds', '')} | {extra} |")
    return "\n".join(lines) + "\n"
