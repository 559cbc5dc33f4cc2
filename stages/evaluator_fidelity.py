"""DVC stage `evaluator_fidelity`: the MPPI fidelity ladder's table and the default evaluator it selects.

params (evaluator_fidelity) + measured/fidelity/designs.csv + measured/fidelity/scores/*.csv ->
reports/fidelity/summary.csv, reports/metrics/evaluator_fidelity.json. With `measure: false` (default
profile) it only summarises the committed score pieces (seconds); with `measure: true` (paper profile) it
first scores every missing (task, rung, design) into the pieces (hours, resumable).
"""

from robocompose.evaluation import fidelity
from robocompose.io import atomic_write_json
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    config = load_section(fidelity.FidelityConfig, "evaluator_fidelity")
    designs = fidelity.read_design_set(config.directory)
    with timed("evaluator_fidelity") as timing:
        timing["evaluations"] = fidelity.measure(config, designs) if config.measure else 0
        summary = fidelity.summarise(fidelity.read_scores(config.directory), designs, config.top)
        fidelity.write_summary(summary)
        atomic_write_json("reports/metrics/evaluator_fidelity.json",
                          fidelity.choose_default(summary, config.tasks, config.min_spearman,
                                                  config.search_spearman, config.ceiling_share))


if __name__ == "__main__":
    run_stage(main)
