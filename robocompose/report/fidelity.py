"""Report section for the evaluator fidelity ladder: how each MPPI setting ranks designs against the thesis's.

Built from the `evaluator_fidelity` stage's outputs (reports/fidelity/summary.csv and
reports/metrics/evaluator_fidelity.json) and the profile's `evaluation.mppi`.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from robocompose.control.mppi import MPPIConfig
from robocompose.io.atomic import read_json


def _row(r: pd.Series) -> str:
    spearman = "-" if pd.isna(r["spearman"]) else f"{r['spearman']:.2f}"
    top = "yes" if r["thesis_best_in_top"] else "no"
    measured = f"{r['n_common']} of {r['n_designs']}"
    random = "-" if pd.isna(r["random_min"]) else f"{r['random_min']:.2f}-{r['random_max']:.2f}"
    return (f"| {r['task']} | {r['rung']} | {r['samples']}/{r['first_samples']} | {r['horizon']} | {r['episode']} | "
            f"{r['sim_steps_per_eval'] / 1e3:.0f}k | {r['seconds_per_eval']:.1f} | {measured} | {spearman} | {top} | "
            f"{random} |")


def section(reports_dir: Path, mppi: MPPIConfig) -> str:
    """`mppi`: the `evaluation.mppi` params the pipeline runs with."""
    title = "## Evaluator fidelity: which MPPI setting ranks designs like the thesis's"
    summary_path = Path(reports_dir) / "fidelity" / "summary.csv"
    choice_path = Path(reports_dir) / "metrics" / "evaluator_fidelity.json"
    if not summary_path.exists():
        return f"{title}\n\nNot run yet: missing {summary_path} (stage `evaluator_fidelity`).\n"
    summary = pd.read_csv(summary_path)
    choice = read_json(choice_path) if choice_path.exists() else {}
    lines = [title, "",
             "One fixed set of designs (the two RoboGrammar reference designs, random dataset designs and the best "
             "of a quick random search) scored under a ladder of MPPI settings, controller seed 0. Spearman is the "
             "rank correlation with the thesis setting's scores (64 samples, 512 for the first update, horizon 16, "
             "128 control steps) over the designs measured at both; `top 3` says whether the thesis setting's best "
             "design is among the setting's three best. Seconds are wall time on the shared 2-core machine "
             "(background, nice 10): physics steps are the comparable cost.", "",
             "| task | setting | samples/first | horizon | episode | sim steps | s / eval | designs | Spearman | "
             "top 3 | random designs (min-max) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += [_row(r) for _, r in summary.iterrows()]
    lines += ["", f"Selection rule: {choice.get('reason', 'not computed')}. "
              f"Selected by the rule: **{choice.get('rung') or 'none (the table is not complete)'}**; the default "
              f"profile runs `evaluation.mppi` = "
              f"{mppi.samples}/{mppi.first_samples} samples, horizon {mppi.horizon}, {mppi.episode} control steps "
              f"({mppi.sim_steps() / 1e3:.0f}k sim steps per evaluation on flat); without a selection it is a "
              "trade-off argued in the README's \"Evaluator fidelity\" section."]
    return "\n".join(lines) + "\n"
