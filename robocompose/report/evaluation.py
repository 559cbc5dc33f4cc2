"""Report section for the robot evaluator (thesis 7.2): reference and random designs on the four tasks.

Built from the `evaluate_references` stage's outputs (the table, its metrics, the rollout GIFs) and the evaluation
cache's measured seconds; the MPPI settings are the params the stage ran with.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd

from robocompose.control.mppi import MPPIConfig
from robocompose.io import read_table
from robocompose.io.atomic import read_json

# The thesis's settings (RoboGrammar's MPPI) and its reported cost.
THESIS_MPPI = {"samples": 64, "first_samples": 512, "horizon": 16, "episode": 128}
THESIS_SECONDS = "30-60 s per design on an 8-core computer"


def _cell(row: pd.Series) -> str:
    if row["status"] == "ok":
        return f"{row['reward']:.2f}"
    return row["status"].replace("_", " ") + (f" ({row['reward']:.1f})" if pd.notna(row["reward"]) else "")


def _evaluation_seconds(table: pd.DataFrame, cache_path: Path) -> pd.Series | None:
    """Mean wall seconds per evaluation by task, as measured when the evaluations ran (from the cache)."""
    from robocompose.fanout.cache import EVAL_KEY_COLUMNS, EvaluationCache

    if not cache_path.exists():
        return None
    timed = table.merge(EvaluationCache(cache_path).frame(), on=list(EVAL_KEY_COLUMNS), suffixes=("", "_cache"))
    timed = timed[timed["sim_steps"] > 0]
    return timed.groupby("task")["seconds"].mean() if len(timed) else None


def section(reports_dir: Path, data_dir: Path, mppi: MPPIConfig, cache: Path | None) -> str:
    """`mppi`: the `evaluation.mppi` params; `cache`: the evaluation cache (None: none kept)."""
    title = "## Robot evaluator: MPPI in pybullet (thesis 7.2)"
    table_path, rollouts = Path(data_dir) / "reference_evals.parquet", Path(data_dir) / "rollouts"
    metrics_path = Path(reports_dir) / "metrics" / "evaluate_references.json"
    if not table_path.exists() or not metrics_path.exists():
        return f"{title}\n\nNot run yet: missing {table_path} or {metrics_path} (stage `evaluate_references`).\n"
    table = read_table(table_path, "reference_evals")
    metrics = read_json(metrics_path)
    tasks = list(dict.fromkeys(table["task"]))
    names = list(dict.fromkeys(table["name"]))
    grid = table.assign(cell=table.apply(_cell, axis=1)).pivot(index="name", columns="task", values="cell")
    lines = [title, "",
             "Each design is scored by one MPPI episode (RoboGrammar's controller and reward: ~4 standing still "
             "upright and facing forward, +2 per m/s forward); mean reward per sim step. Non-ok results are shown "
             "with their status; optimisers score them 3.8 (self-collision) or 4.0 (blow-up), as GLSO does.", "",
             "| design | " + " | ".join(tasks) + " |", "|---|" + "---|" * len(tasks)]
    lines += [f"| {name} | " + " | ".join(grid.loc[name, task] for task in tasks) + " |" for name in names]
    reference, random_best = metrics["best_score"]["reference"], metrics["best_score"]["random"]
    lines += ["", "Best reference design vs best random design per task: "
              + "; ".join(f"{t} {reference[t]:.2f} vs {random_best[t]:.2f}" for t in tasks if t in random_best) + "."]

    steps = table.groupby("task")["sim_steps"].max()
    lines += ["", "| MPPI setting | thesis | this run |", "|---|---|---|"]
    lines += [f"| {k.replace('_', ' ')} | {v} | {getattr(mppi, k)} |" for k, v in THESIS_MPPI.items()]
    lines += [f"| sim steps per evaluation (flat / wall) | ~2.4 M / ~4.6 M | {steps.get('flat', 0) / 1e6:.2f} M / "
              f"{steps.get('wall', 0) / 1e6:.2f} M |"]
    seconds = _evaluation_seconds(table, Path(cache)) if cache else None
    if seconds is not None:
        flat, wall = (seconds.get(task, float("nan")) for task in ("flat", "wall"))
        lines += [f"| wall seconds per evaluation as run (one process, shared machine; flat / wall) | "
                  f"{THESIS_SECONDS} | {flat:.0f} / {wall:.0f} s |"]
    bench = Path(reports_dir) / "benchmarks.json"
    figures = read_json(bench) if bench.exists() else {}
    if "mppi.overhead_ratio" in figures:
        lines += ["", f"MPPI wall time is {figures['mppi.overhead_ratio']:.2f}x the time of the raw physics steps it "
                  f"takes (target <= 1.2; `benchmarks/bench_evaluate.py`)."]
    gifs = sorted(rollouts.glob("*.gif")) if rollouts.exists() else []
    if gifs:
        out = Path(reports_dir) / "figures"
        out.mkdir(parents=True, exist_ok=True)
        lines += ["", "Best design of each task (MCAP logs for Foxglove beside the GIFs in `data/rollouts/`):", ""]
        for gif in gifs:
            shutil.copyfile(gif, out / f"rollout_{gif.name}")
            task = gif.stem
            lines.append(f"![{task}: {metrics['best_design'][task]}, reward {metrics['best_reward'][task]:.2f}]"
                         f"(figures/rollout_{gif.name})")
    return "\n".join(lines) + "\n"
