"""Report section: does the terrain decide the design? The gate of issue 46 (item 3) on the block world and on each
probed terrain family (reports/metrics/modular_gate.json, stage `modular_gate`; `robocompose.modular.gate`).

Leads with the verdict (which worlds pass, or that none does; `verdicts.verdict`), then one table: per world and
best-of-k the greedy portfolio's mean best distance on held-out terrains, the two "predict the table, take the top
k" answers (k-NN, ridge), the ceiling's gain over the portfolio in metres and as a share of the mean optimum, and
its one-sided paired Wilcoxon p. Every distance is a pybullet rollout read from committed tables
(leave one terrain out).
"""

from __future__ import annotations

from pathlib import Path

from robocompose.io.atomic import read_json
from robocompose.report.tables import markdown_table
from robocompose.report.verdicts import held, verdict

TITLE = "### Does the terrain decide the design? The gate (beyond the thesis)"


def section(reports_dir: Path) -> str:
    path = Path(reports_dir) / "metrics" / "modular_gate.json"
    if not path.exists():
        return f"{TITLE}\n\nNot run yet: missing {path} (stage `modular_gate`).\n"
    metrics = read_json(path)
    worlds, in_progress = metrics["worlds"], metrics["in_progress"]
    passing = [name for name, s in worlds.items() if s["passes"]]
    config = next(iter(worlds.values()))["config"] if worlds else {}
    gated = " and ".join(f"best-of-{k}" for k in config.get("pass_ks", []))
    tried = ", ".join(f"{name} ({s['terrains']} terrains)" for name, s in worlds.items())
    pending = ("; probes in progress, not gated: " + ", ".join(f"{name} ({p['terrains']} of {p['planned']} "
                                                                "terrains)" for name, p in in_progress.items())
               if in_progress else "")
    stated = verdict("A world where the terrain decides the design (passes the gate; thesis: the block world)",
                     held(bool(passing)),
                     f"Passes: {', '.join(passing)}; of {tried}{pending}." if passing else
                     f"Of {tried}: in none does predicting the table from the height map beat a fixed greedy "
                     f"portfolio by the margin a learned generator would need{pending}.")
    lines = [TITLE, "", stated, "",
             f"A world passes if at {gated} the better of k-NN ({config.get('neighbours')} nearest terrains) and "
             f"ridge beats the greedy portfolio by >= {config.get('margin', 0):.0%} of the mean optimum with a "
             f"one-sided paired Wilcoxon p < {config.get('alpha')} over held-out terrains (leave one terrain out; "
             "height-map summaries as features; docs/modular.md). Distances are pybullet rollouts from the "
             "committed tables (the block world: its pool and test tables; a family: its probe's 400 designs); "
             "metres of max distance, mean over held-out terrains.", ""]
    rows = []
    for name, s in worlds.items():
        for k, row in sorted(s["k"].items(), key=lambda item: int(item[0])):
            rows.append((name, f"{s['terrains']} x {s['designs']}", s["mean_optimum"], k, row["portfolio"],
                         row["knn"], row["ridge"], row["gain_m"], row["gain_share"], row["p"],
                         "yes" if row["passes"] else "no"))
    lines += markdown_table(
        ["world", "terrains x designs", "mean optimum", "best of k", "portfolio", "k-NN", "ridge", "ceiling gain (m)",
         "gain / optimum", "p (one-sided)", "margin and p met"], rows,
        [None, None, "{:.3f}", None, "{:.3f}", "{:.3f}", "{:.3f}", "{:+.3f}", "{:+.1%}", "{:.3g}", None], "llrrrrrrrrl")
    return "\n".join(lines) + "\n"
