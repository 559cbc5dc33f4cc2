"""Report section: what produced the report (git revision, params and dvc.lock digests, every stage's wall
time) and what changed since the previous committed run (its params, and the metrics that moved, from
`dvc metrics diff`)."""

from __future__ import annotations

import hashlib
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from robocompose.io.timings import TIMINGS_FILE, read_timings
from robocompose.params import load_yaml


def _git(*args: str, cwd: Path = Path(".")) -> str:
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=True, cwd=cwd).stdout.rstrip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def pipeline(root: Path = Path(".")) -> tuple[list[str], list[str]]:
    """The DVC stages in dvc.yaml order (a matrix stage expanded, NAME@ITEM) and the paths DVC writes
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


ABSENT = "-"  # a params entry or metric that one side does not have


def _diff(old: object, new: object, prefix: str = "") -> list[tuple[str, object, object]]:
    """(dotted key, old, new) where two params trees differ; a section only one side has is one entry."""
    if isinstance(old, dict) and isinstance(new, dict):
        return [row for key in sorted(set(old) | set(new), key=str)
                for row in _diff(old.get(key, ABSENT), new.get(key, ABSENT), f"{prefix}.{key}" if prefix else str(key))]
    if old == new:
        return []
    return [(prefix, "(section)" if isinstance(old, dict) else old, "(section)" if isinstance(new, dict) else new)]


def params_changes(rev: str, params_file: Path, root: Path = Path(".")) -> list[tuple[str, object, object]]:
    """(param, value at `rev`, value now) for every params.yaml entry that differs, in key order (ABSENT where
    one side lacks it; a whole section added or removed is one entry)."""
    before = _show(rev, "params.yaml", root)
    old = (load_yaml(before, f"params.yaml at {rev[:7]}") or {}) if before is not None else {}
    new = (load_yaml(params_file.read_text(), params_file) or {}) if params_file.exists() else {}
    return _diff(old, new)


# Metric names holding wall times or rates: they move with the machine's load, not with the results.
_TIMING_WORDS = ("seconds", "per_s", "elapsed", "minutes", "_ms")


def metrics_changes(rev: str, root: Path = Path(".")) -> list[tuple[str, str, object, object]]:
    """(metrics file, metric, value at `rev`, value now) for every metric that differs, from `dvc metrics diff
    rev` (run offline by this interpreter's dvc); wall times and rates are left out; ABSENT where a side has
    no such metric."""
    env = {**os.environ, "DVC_NO_ANALYTICS": "1", "DVC_STUDIO_OFFLINE": "true"}
    done = subprocess.run([sys.executable, "-m", "dvc", "metrics", "diff", rev, "--json"], capture_output=True,
                          text=True, cwd=root, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"dvc metrics diff {rev[:7]} failed: {done.stderr.strip().splitlines()[-1:]}")
    diff = json.loads(done.stdout or "{}")
    rows = []
    for path, metrics in sorted(diff.items()):
        for name, values in sorted(metrics.items()):
            old, new = values.get("old"), values.get("new")
            if old != new and not any(word in name for word in _TIMING_WORDS):
                rows.append((path, name, ABSENT if old is None else old, ABSENT if new is None else new))
    return rows


def _subject(rev: str, root: Path, width: int = 72) -> str:
    """`<short hash> <subject>`, the subject cut to `width` characters."""
    line = _git("log", "-1", "--format=%h %s", rev, cwd=root)
    return line if len(line) <= width else line[: width - 3] + "..."


MAX_ROWS = 40  # rows of each "Changed since" table; the rest is counted, `dvc metrics diff` shows all


def _table(header: list[str], rows: list[tuple], what: str, rev: str) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(f"`{c}`" if i == 0 else str(c) for i, c in enumerate(row)) + " |"
              for row in rows[:MAX_ROWS]]
    if len(rows) > MAX_ROWS:
        lines += ["", f"... and {len(rows) - MAX_ROWS} more {what} (`.venv/bin/dvc metrics diff {rev[:7]}`, "
                  f"`git diff {rev[:7]} -- params.yaml`)."]
    return lines


def changes_section(params_file: Path, root: Path = Path(".")) -> list[str]:
    """The run-metadata line on the previous committed run, then its "Changed since" subsection: the params
    that differ, the headline metrics that moved (in both runs, value changed) and the metrics files that
    appeared or went."""
    rev = previous_run(root)
    if rev is None:
        return ["- previous committed run: none (no earlier commit changed params.yaml or dvc.lock)"]
    short = rev[:7]
    params = params_changes(rev, params_file, root)
    changes = metrics_changes(rev, root)
    moved = [(f"{path}: {name}", old, new) for path, name, old, new in changes if ABSENT not in (old, new)]
    files = sorted({(path, "new" if old == ABSENT else "no longer written") for path, _, old, new in changes
                    if ABSENT in (old, new)})
    lines = [f"- previous committed run: `{_subject(rev, root)}` ({len(params)} params differ, "
             f"{len(moved)} metrics moved; see \"Changed since `{short}`\")"]
    lines += ["", f"### Changed since `{short}`", "",
              "Params that differ from that run's params.yaml (`-`: absent):", ""]
    lines += _table(["param", f"`{short}`", "now"], params, "params", rev) if params else ["none"]
    lines += ["", f"Headline metrics that moved (`dvc metrics diff {short}`, run offline; wall times and rates left "
              "out):", ""]
    lines += _table(["metric", f"`{short}`", "now"], moved, "metrics", rev) if moved else ["none"]
    if files:
        lines += ["", "Metrics that only one run has: " + "; ".join(f"`{path}` ({state})" for path, state in files)]
    return lines


def _figure(value: object) -> str:
    """A timings figure for a table cell: a list of per-run records becomes its count and median times."""
    if not (isinstance(value, list) and value and all(isinstance(item, dict) for item in value)):
        return str(value)
    times = [key for key in ("seconds", "milliseconds")
             if all(isinstance(item.get(key), int | float) for item in value)]
    medians = ", ".join(f"{key} {round(statistics.median(item[key] for item in value), 3)}" for key in times)
    return f"{len(value)} runs" + (f" (median {medians})" if medians else "")


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
        extra = ", ".join(f"{k} {_figure(v)}" for k, v in figures.items() if k != "seconds")
        lines.append(f"| {stage} | {figures.get('seconds', '')} | {extra} |")
    return "\n".join([*lines, *changes[1:]]) + "\n"
