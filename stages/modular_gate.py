"""DVC stage `modular_gate`: does the terrain decide the design? The gate of issue 46 (item 3) on the block world's
committed tables (its pool and test terrains: the reference row) and on every terrain-family probe committed under
measured/modular/families/<family>/ (`robocompose.modular.family_truth.gate_directories`, `robocompose.modular.gate`).

measured/modular/{pool,exhaustive,families} -> reports/metrics/modular_gate.json (`worlds`, per world: terrains,
designs, mean optimum; per best-of-k the greedy portfolio's, k-NN's and ridge's mean, the ceiling's gain in metres
and as a share of the mean optimum, its one-sided paired Wilcoxon p, whether it passes; whether the world passes;
`in_progress`: each probe with fewer than `PROBE_TERRAINS` tables, not gated), reports/plots/modular_gate.csv
(each held-out terrain's score per world, k and answer). Reads tables only: no simulation.
"""

from pathlib import Path

import pandas as pd

from robocompose.io import atomic_write_json, atomic_write_text
from robocompose.io.timings import timed
from robocompose.modular.family_truth import FAMILIES_DIR, POOL_DIR, gate_directories
from robocompose.modular.truth import COMMITTED_DIR
from robocompose.stage import run_stage

BLOCK_WORLD = "block world"  # the reference row: the thesis's world on its pool and test tables
PROBE_TERRAINS = 20  # a probe's planned size (issue 46: ~20 terrains); a folder with fewer is in progress, not gated


def worlds(families: Path = FAMILIES_DIR) -> tuple[dict[str, list[Path]], dict[str, int]]:
    """The worlds to gate (the block world, then each probe folder under `families` with a full probe, by name) and
    the probes still in progress (their table counts): a probe is committed in pieces as its terrains finish."""
    probes = {p.name: len(list(p.glob("*-*.parquet"))) for p in sorted(families.iterdir()) if p.is_dir()}
    probes = {name: count for name, count in probes.items() if count}
    gated = {name: [families / name] for name, count in probes.items() if count >= PROBE_TERRAINS}
    return ({BLOCK_WORLD: [POOL_DIR, COMMITTED_DIR], **gated},
            {name: count for name, count in probes.items() if name not in gated})


def main() -> None:
    summaries, scores = {}, []
    gated, in_progress = worlds()
    with timed("modular_gate"):
        for name, directories in gated.items():
            result = gate_directories(directories)
            summaries[name] = result.summary
            scores.append(result.scores.assign(world=name))
    atomic_write_json("reports/metrics/modular_gate.json", {
        "worlds": summaries,
        "in_progress": {name: {"terrains": count, "planned": PROBE_TERRAINS} for name, count in in_progress.items()}})
    table = pd.concat(scores, ignore_index=True)[["world", "terrain", "k", "method", "score"]]
    atomic_write_text("reports/plots/modular_gate.csv", table.round(4).to_csv(index=False))


if __name__ == "__main__":
    run_stage(main)
