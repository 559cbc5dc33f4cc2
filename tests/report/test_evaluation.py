import json

import pandas as pd
from PIL import Image

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.references import best_scores
from robocompose.fanout.cache import EvaluationCache
from robocompose.io import write_table
from robocompose.report.evaluation import section


def _row(name, task, reward, status="ok", steps=1000):
    return {"name": name, "rules": [0, 7], "design_id": name, "task": task, "settings_hash": "h", "seed": 0,
            "reward": reward, "status": status, "sim_steps": steps, "objective": reward if status == "ok" else 3.8}


def test_section_tabulates_rewards_statuses_settings_and_gifs(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    rows = [_row("robogrammar_flat", "flat", 5.25), _row("robogrammar_flat", "wall", 4.5, steps=2000),
            _row("random_0", "flat", None, "self_collision", 0), _row("random_0", "wall", 4.75, steps=2000)]
    write_table(pd.DataFrame(rows), data / "reference_evals.parquet", "reference_evals")
    (data / "rollouts").mkdir()
    Image.new("RGB", (8, 8)).save(data / "rollouts" / "flat.gif")
    cache = EvaluationCache(tmp_path / "cache.parquet")
    for row in rows:
        seconds = {"flat": 6.0, "wall": 12.0}[row["task"]] if row["sim_steps"] else 0.1
        cache.put((row["design_id"], row["task"], "h", 0), reward=row["reward"], status=row["status"],
                  sim_steps=row["sim_steps"], seconds=seconds)
    cache.save()
    (reports / "metrics").mkdir(parents=True)
    (reports / "metrics" / "evaluate_references.json").write_text(json.dumps({
        "best_reward": {"flat": 5.25, "wall": 4.75}, "best_design": {"flat": "robogrammar_flat", "wall": "random_0"},
        "best_score": best_scores(pd.DataFrame(rows))}))
    text = section(reports, data, MPPIConfig(samples=16, horizon=8), cache.path)
    assert "| robogrammar_flat | 5.25 | 4.50 |" in text and "| random_0 | self collision | 4.75 |" in text
    assert "flat 5.25 vs 3.80; wall 4.50 vs 4.75" in text
    assert "| samples | 64 | 16 |" in text and "0.00 M / 0.00 M" in text
    assert "| 6 / 12 s |" in text  # measured seconds of the simulated evaluations, from the cache
    assert "(figures/rollout_flat.gif)" in text and (reports / "figures" / "rollout_flat.gif").exists()
    assert "robogrammar_flat, reward 5.25" in text


def test_section_says_when_the_stage_has_not_run(tmp_path):
    assert "Not run yet" in section(tmp_path, tmp_path, MPPIConfig(), None)
