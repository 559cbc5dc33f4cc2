"""Report section: what produced the report (git revision, params and dvc.lock digests, every stage's wall
time) and what changed since the previous committed run (its params, and the metrics that moved, from
`dvc metrics diff`)."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import yaml

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


def _show(rev: str, path: str, root: Path) -> bytes | None:
    """The bytes of `path` at git revision `rev`, or None if it did not exist there."""
    done = subprocess.run(["git", "show", f"{rev}:{path}"], capture_output=True, cwd=root)
    return done.stdout if done.returncode == 0 else None


def previous_run(root: Path = Path(".")) -> str | None:
    """The previous committed run: the latest commit that changed params.yaml or dvc.lock and whose dvc.lock
    differs from the working tree's (so right after committing a run, the run before it). None if there is
    none (or no git)."""
    lock = root / "dvc.lock"
    current = lock.read_bytes() if lock.exists() else None
    for rev in _git("log", "--format=%H", "--", "params.yaml", "dvc.lock", cwd=root).split():
        if rev != "unknown" and _show(rev, "dvc.lock", root) != current:
            return rev
    return None


def _flatten(tree: object, prefix: str = "") -> dict[str, object]:
    if not isinstance(tree, dict):
        return {prefix: tree}
    flat: dict[str, object] = {}
    for key, value in tree.items():
        flat.update(_flatten(value, f"{prefix}.{key}" if prefix else str(key)))
    return flat


def params_changes(rev: str, params_file: Path, root: Path = Path(".")) -> list[tuple[str, object, object]]:
    """(param, value at `rev`, value now) for every params.yaml entry that differs, in key order ("-" where
    an entry is absent)."""
    before = _show(rev, "params.yaml", root)
    old = _flatten(yaml.safe_load(before) or {}) if before is not None else {}
    new = _flatten(yaml.safe_load(params_file.read_text()) or {}) if params_file.exists() else {}
    return [(key, old.get(key, "-"), new.get(key, "-")) for key in sorted(set(old) | set(new))
            if old.get(key, "-") != new.get(key, "-")]


# Metric names holding wall times or rates: they move with the machine's load, not with the results.
_TIMING_WORDS = ("seconds", "per_s", "elapsed", "minutes")


def metrics_changes(rev: str, root: Path = Path(".")) -> list[tuple[str, str, object, object]]:
    """(metrics file, metric, value at `rev`, value now) for every metric that moved, from `dvc metrics diff
    rev` (run offline by this interpreter's dvc); wall times and rates are left out."""
    env = {**os.environ, "DVC_NO_ANALYTICS": "1", "DVC_STUDIO_OFFLINE": "true"}
    done = subprocess.run([sys.executable, "-m", "dvc", "metrics", "diff", rev, "--json"], capture_output=True,
                          text=True, cwd=root, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"dvc metrics diff {rev[:7]} failed: {done.stderr.strip().splitlines()[-1:]}")
    diff = json.loads(done.stdout or "{}")
    return [(path, name, values.get("old"), values.get("new")) for path, metrics in sorted(diff.items())
            for name, values in sorted(metrics.items())
            if not any(word in name for word in _TIMING_WORDS) and values.get("old") != values.get("new")]


def _subject(rev: str, root: Path) -> str:
    return _git("log", "-1", "--format=%h %s", rev, cwd=root)


def changes_section(params_file: Path, root: Path = Path(".")) -> list[str]:
    """The run-metadata line on the previous committed run (the params that differ), then its "Changed since"
    subsection (the metrics that moved)."""
    rev = previous_run(root)
    if rev is None:
        return ["- previous committed run: none (no earlier commit changed params.yaml or dvc.lock)"]
    params = params_changes(rev, params_file, root)
    lines = [f"- previous committed run: `{_subject(rev, root)}`; params changed since: "
             + (", ".join(f"`{key}` {old} -> {new}" for key, old, new in params) if params else "none")]
    lines += ["", f"### Changed since `{rev[:7]}`", ""]
    moved = metrics_changes(rev, root)
    if not moved:
        return [*lines, "No metric moved (`dvc metrics diff`, wall times and rates left out)."]
    lines += [f"Metrics that moved (`dvc metrics diff {rev[:7]}`; wall times and rates left out):", "",
              f"| metrics file | metric | `{rev[:7]}` | now |", "|---|---|---:|---:|"]
    return [*lines, *(f"| `{path}` | {name} | {old} | {new} |" for path, name, old, new in moved)]


def section(reports_dir: Path, params_file: Path = Path("params.yaml"), root: Path = Path(".")) -> str:
    stages, written = pipeline(root)
    revision = _git("rev-parse", "--short", "HEAD", cwd=root)
    changed = uncommitted(written, root)
    digest = hashlib.sha256(params_file.read_bytes()).hexdigest()[:12] if params_file.exists() else "missing"
    changes = changes_section(params_file, root)  # [the previous-run line, its "Changed since" subsection]
    lock = root / "dvc.lock"
    lock_digest = hashlib.sha256(lock.read_bytes()).hexdigest()[:12] if lock.exists() else "missing"
    timings = read_timings(Path(reports_dir) / "timings.json")
    state = f" with uncommitted changes to {', '.join(f'`{p}`' for p in changed)}" if changed else ""
    lines = ["## Run metadata", "",
             f"- git revision: `{revision}`" + state,
             f"- params.yaml sha256: `{digest}`",
             f"- dvc.lock sha256: `{lock_digest}`",
             changes[0], "",
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
    return "\n".join([*lines, *changes[1:]]) + "\n"
