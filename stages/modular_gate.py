"""DVC stage `modular_gate`: does the terrain decide the design? The gate of issue 46 (item 3) on the block world's
committed tables (its pool and test terrains: the reference row) and on every terrain-family probe committed under
measured/modular/families/<family>/ (`robocompose.modular.family_truth.gate_directories`, `robocompose.modular.gate`).

measured/modular/{pool,exhaustive,families} -> reports/metrics/modular_gate.json (per world: terrains, designs, mean
optimum; per best-of-k the greedy portfolio's, k-NN's and ridge's mean, the ceiling's gain in metres and as a share
of the mean optimum, its one-sided paired Wilcoxon p, whether it passes; whether the world passes),
reports/plots/modular_gate.csv (each held-out terrain's score per world, k and answer). Reads tables only: no
simulation.
"""

from pathlib import Path

import pandas as pd

from robocompose.io import atomic_write_json, atomic_write_text
from robocompose.io.timings import timed
from robocompose.modular.family_truth import FAMILIES_DIR, POOL_DIR, gate_directories
from robocompose.modular.truth import COMMITTED_DIR
from robocompose.stage import run_stage

BLOCK_WORLD = "block world"  # the reference row: the thesis's world on its pool and test tables


def worlds() -> dict[str, list[Path]]:
    """The block world, then each family probe's folder holding tables, by name."""
    probes = sorted(p for p in FAMILIES_DIR.iterdir() if p.is_dir() and any(p.glob("*-*.parquet")))
    return {BLOCK_WORLD: [POOL_DIR, COMMITTED_DIR], **{p.name: [p] for p in probes}}


def main() -> None:
    summaries, scores = {}, []
    with timed("modular_gate"):
        for name, directories in worlds().items():
            result = gate_directories(directories)
            summaries[name] = result.summary
            scores.append(result.scores.assign(world=name))
    atomic_write_json("reports/metrics/modular_gate.json", summaries)
    table = pd.concat(scores, ignore_index=True)[["world", "terrain", "k", "method", "score"]]
    atomic_write_text("reports/plots/modular_gate.csv", table.round(4).to_csv(index=False))


if __name__ == "__main__":
    run_stage(main)
