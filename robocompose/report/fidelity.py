"""Report section for the evaluator fidelity ladder: how each MPPI setting ranks designs against the thesis's.

Built from the `evaluator_fidelity` stage's outputs (reports/fidelity/summary.csv and
reports/metrics/evaluator_fidelity.json) and the profile's `evaluation.mppi`.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from robocompose.control.mppi import MPPIConfig
from robocompose.io.atomic import read_json


def _number(value: float) -> str:
    return "-" if pd.isna(value) else f"{value:.2f}"


def _row(r: pd.Series) -> str:
    top = "yes" if r["thesis_best_in_top"] else "no"
    measured = f"{r['n_common']} of {r['n_designs']}"
    random = "-" if pd.isna(r["random_min"]) else f"{r['random_min']:.2f}-{r['random_max']:.2f}"
    found = f"{r.get('n_search_common', 0)} of {r.get('n_search', 0)}"
    return (f"| {r['task']} | {r['rung']} | {r['samples']}/{r['first_samples']} | {r['horizon']} | {r['episode']} | "
            f"{r['sim_steps_per_eval'] / 1e3:.0f}k | {r['seconds_per_eval']:.1f} | {measured} | "
            f"{_number(r['spearman'])} | {top} | {random} | {found} | {_number(r.get('spearman_search'))} | "
            f"{_number(r.get('noise_ceiling'))} |")


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
             "One fixed set of designs scored under a ladder of MPPI settings, controller seed 0. The base set: the "
             "two RoboGrammar reference designs, random dataset designs and the best of a quick random search. The "
             "search-found designs: the best designs of GLSO, random search, MCTS and GHS runs at two cheap rungs "
             "(`robocompose fidelity-search`), what a search hands the evaluator to rank. Spearman is the "
             "rank correlation with the thesis setting's scores (64 samples, 512 for the first update, horizon 16, "
             "128 control steps) over the designs measured at both; `top 3` says whether the thesis setting's best "
             "base design is among the setting's three best; the noise ceiling is the thesis setting against itself "
             "with controller seed 1 (rung `thesis_seed1`) over the search-found designs. Seconds are wall time on "
             "the shared 2-core machine (background, niced): physics steps are the comparable cost.", "",
             "| task | setting | samples/first | horizon | episode | sim steps | s / eval | base designs | Spearman | "
             "top 3 | random designs (min-max) | search-found designs | Spearman (search) | noise ceiling |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += [_row(r) for _, r in summary.iterrows()]
    rule = choice.get("rule", "")
    label = " (provisional)" if rule == "provisional" else ""
    lines += ["", f"Selection rule: {choice.get('reason', 'not computed')}. "
              f"Selected{label}: **{choice.get('rung') or 'none'}**; the default profile runs `evaluation.mppi` = "
              f"{mppi.samples}/{mppi.first_samples} samples, horizon {mppi.horizon}, {mppi.episode} control steps "
              f"({mppi.sim_steps() / 1e3:.0f}k sim steps per evaluation on flat)."]
    if rule == "provisional":
        lines += ["", "The rule that decides is the search rule: Spearman over the search-found designs >= 0.7, or "
                  ">= 80% of the noise ceiling, on flat and ridged. Until every search-found design has its "
                  "thesis-setting scores at both controller seeds (measured in the background, hours), the "
                  "earlier rule over the base set stands in, and a search comparison run at the provisional "
                  "rung is a smoke run."]
    return "\n".join(lines) + "\n"
