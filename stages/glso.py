"""DVC stage `glso`: every (task, method, seed) search run of thesis 8, fanned out over the Executor.

params (compute, glso, evaluation) + models/vae_{full,nopred,nogram}.pt -> data/glso/steps.parquet (all step
tables), data/glso/runs/ (per run; persistent), data/glso/rollouts/<task>.{mcap,gif,png} (each task's best design
replayed, and its picture at rest),
reports/metrics/glso.json (with every registered method's title and figure groups: the report names the methods
from there; and the rung and MPPI settings the runs used). Every run, and the replay of each task's best design,
scores at `glso.rung`'s MPPI settings if one is named, else at `evaluation.mppi` (`GLSOConfig.evaluator`). Each
run's checkpoint, data/glso/checkpoints/<run>.ckpt (its step rows as JSON; the run replays them to resume), is not
a DVC output: it only saves time (its key covers the run, the settings, the evaluator's settings hash and the
code): a killed stage resumes every run where it stopped.
"""

from pathlib import Path

from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.fanout.compute import ComputeConfig
from robocompose.glso.registry import describe
from robocompose.glso.runs import GLSOConfig, record_best, run_all, summarise
from robocompose.grammar.tree import DesignTree
from robocompose.io import atomic_write_json, write_table
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.sim.render import render_design
from robocompose.stage import run_stage

OUT = Path("data/glso")


def main() -> None:
    config = load_section(GLSOConfig, "glso")
    evaluation = config.evaluator(load_section(EvaluationConfig, "evaluation"))  # the runs' and the replays'
    compute = load_section(ComputeConfig, "compute")
    with timed("glso") as timing, compute.executor() as executor:
        steps, timing["run_seconds"] = run_all(config, evaluation, OUT, executor, compute.cache)
        timing["runs"] = int(steps.groupby(["task", "method", "seed"]).ngroups)
        timing["objective_calls"] = len(steps)
        write_table(steps, OUT / "steps.parquet", "glso_steps")
        best = record_best(steps, evaluation, OUT / "rollouts", executor)
        for row in best.itertuples():  # Fig. 7.2: each task's best design at rest, beside its rollout
            render_design(DesignTree(tuple(row.parents), tuple(row.tokens)), OUT / "rollouts" / f"{row.task}.png",
                          width=320, height=240)
        atomic_write_json("reports/metrics/glso.json", {
            "final_best": summarise(steps), "budget": config.budget, "seeds": config.seeds, "methods": describe(),
            "best_design": {row.task: {"method": row.method, "seed": int(row.seed), "design_id": row.design_id,
                                       "score": round(float(row.score), 4)} for row in best.itertuples()},
            "rung": config.rung, "mppi": evaluation.mppi.as_dict(),
            "settings_hash": {task: evaluation.settings_hash(task) for task in config.tasks}})


if __name__ == "__main__":
    run_stage(main)
