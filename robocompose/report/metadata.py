"""Report section: what produced the report (git revision, params digest, stage wall times)."""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

from robocompose.report.timings import read_timings


def _git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def section(reports_dir: Path, params_file: Path = Path("params.yaml")) -> str:
    revision = _git("rev-parse", "--short", "HEAD")
    dirty = _git("status", "--porcelain", "--untracked-files=no")
    digest = hashlib.sha256(params_file.read_bytes()).hexdigest()[:12] if params_file.exists() else "missing"
    timings = read_timings(Path(reports_dir) / "timings.json")
    lines = ["## Run metadata", "",
             f"- git revision: `{revision}`" + (" with uncommitted changes" if dirty and dirty != "unknown" else ""),
             f"- params.yaml sha256: `{digest}`", "",
             "| stage | wall time (s) | figures |", "|---|---:|---|"]
    for stage, figures in timings.items():
        extra = ", ".join(f"{k} {v}" for k, v in figures.items() if k != "seconds")
        lines.append(f"| {stage} | {figures.get('seconds', '')} | {extra} |")
    return "\n".join(lines) + "\n"
