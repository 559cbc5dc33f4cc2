"""Benchmark: EG-GAN for teams against NSGA-II:50 on the same chip (thesis Table 5.4), the shipped generator.

eggan.teams.query_ms: the generator's part of a query (noise, forward pass, rounding of the
    `samples` allocations), mean over QUERIES queries; the decomposition is timed apart
    (eggan.teams.decompose_ms) and the optimiser that measures the front is not part of the query.
eggan.teams.speedup_vs_nsga2: NSGA-II:50's wall time (50 generations, empty cache) over the query's,
    measured in the same run on the same chip (synthetic chip of a seed no chip set uses).
eggan.teams.hv_share: EG-GAN's front hypervolume over NSGA-II:50's on that chip, both measured by the
    ergodic optimiser. Goals (issue 14): query <= 5 ms; >= 1000x faster at >= 95% of the hypervolume.
"""

from __future__ import annotations

import time

import numpy as np
import torch

from robocompose.eggan.learners import LEARNERS
from robocompose.io.provenance import ROOT
from robocompose.search.nsga2 import NSGA2Config
from robocompose.teams.chips import synthetic_chip
from robocompose.teams.compose import SHIPPED_MODEL
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.eggan_problem import TeamsProblem
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage
from robocompose.teams.generative import query_front, teams_generator_info
from robocompose.teams.nsga2 import allocation_nsga2
from robocompose.teams.species import SPECIES

QUERIES = 20
CHIP_SEED = 7  # not the default profile's chip seed (0)


def run() -> dict[str, float]:
    torch.set_num_threads(1)
    saved = teams_generator_info(ROOT / SHIPPED_MODEL)
    params = saved["params"]
    coverage = CoverageConfig(**params["coverage"])
    chip = synthetic_chip(CHIP_SEED)
    started = time.perf_counter()
    decomposition = decompose_chip(chip, DecomposeConfig(**{**params["decompose"], "n_regions": saved["n_regions"]}))
    decompose_ms = 1000 * (time.perf_counter() - started)
    learner = LEARNERS["teams"]["eggan"]
    generator, _ = learner.load(ROOT / SHIPPED_MODEL, TeamsProblem([(chip, decomposition)], coverage))
    draws = learner.answer(generator, params["eggan"]["samples"])
    measured = AllocationEvaluator(chip_coverage(chip, decomposition, coverage), chip.chip_id, seed=0)
    query_front(draws, chip, decomposition, coverage, 0, measured)  # warm-up; the front's teams optimised once
    queries = [query_front(draws, chip, decomposition, coverage, 0, measured) for _ in range(QUERIES)]
    query_seconds = float(np.mean([q.generator_seconds for q in queries]))
    evaluate = AllocationEvaluator(chip_coverage(chip, decomposition, coverage), chip.chip_id, seed=0)
    nsga2 = allocation_nsga2(evaluate, decomposition.n_regions, len(SPECIES), coverage.robots_per_species,
                             NSGA2Config(population=50, generations=50, seed=0))  # from an empty memo
    return {"eggan.teams.query_ms": 1000 * query_seconds, "eggan.teams.decompose_ms": decompose_ms,
            "eggan.teams.speedup_vs_nsga2": nsga2.seconds / query_seconds,
            "eggan.teams.hv_share": queries[0].hypervolume / nsga2.hypervolume,
            "eggan.teams.nsga2_seconds": nsga2.seconds}


if __name__ == "__main__":
    print(run())
