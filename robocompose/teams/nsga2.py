"""NSGA-II on team allocations (thesis 5.2, Table 5.4): the team-formation problem bound to the generic
`robocompose.search.nsga2` (its operators and loop).

Genomes: teams/genomes.py (the thesis's K x O fractions, and EG-GAN's share x split), decoded to K x O fractions
that species.allocation_to_counts turns into robots; both start from the same first population (the draws of
`deployment_share_draws`), so only the genome differs between their runs.
Objectives, both minimised: coverage cost (area-weighted ergodic metric per region, ergodic.py) and
deployment cost (robots deployed). The initial population (not given by the thesis) deploys a uniform
share s ~ U(0, 1) of each species, split over the regions by a flat Dirichlet draw, so it spans every
deployment cost from 0 to 60 (uniform genes would deploy nearly the whole bank).

Hypervolume: reference point (0.25, 60) on (coverage cost, deployment cost), the thesis's. The
coverage cost is ergodic.py's: the area-weighted ergodic metric in units of one random glance per
region, so 0.25 admits the allocations that cover every region better than 4 random glances each;
one that leaves a region empty costs > 1 and stays outside, and inside the box the hypervolume
grows with coverage at a fixed robot count, not only with fewer robots. 60 is the whole bank
(3 species x 20). The box has area 15; the thesis reports 9.4 (NSGA-II:20) and 11.9 (NSGA-II:50).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pymoo.core.sampling import Sampling

from robocompose.search.nsga2 import Front, GenomeProblem, NSGA2Config, hypervolume, run_nsga2, run_nsga2_together
from robocompose.teams.genomes import GENOMES
from robocompose.teams.species import allocation_to_counts

REFERENCE_POINT = (0.25, 60.0)


def deployment_share_draws(rng: np.random.Generator, n: int, n_regions: int, n_species: int) -> np.ndarray:
    """(n, K, O) fractions: per species a share s ~ U(0, 1), split over the regions by a flat Dirichlet draw."""
    share = rng.random((n, 1, n_species))  # (n, 1, O) deployed share per species
    split = rng.dirichlet(np.ones(n_regions), size=(n, n_species))  # (n, O, K)
    return share * split.transpose(0, 2, 1)


class DeploymentShareSampling(Sampling):
    """The first population: `deployment_share_draws` in the problem's genome."""

    def _do(self, problem, n_samples, *args, random_state=None, **kwargs):
        return GENOMES[problem.genome].encode(deployment_share_draws(random_state, n_samples, *problem.shape))


class AllocationProblem(GenomeProblem):
    """Genome (`GENOMES[genome]`) -> [coverage cost, deployment cost] via `evaluate` of the robot counts."""

    def __init__(self, n_regions: int, n_species: int, robots_per_species: int,
                 evaluate: Callable[[np.ndarray], np.ndarray], genome: str = "fractions"):
        super().__init__(n_var=GENOMES[genome].size(n_regions, n_species), n_obj=2, xl=0.0, xu=1.0)
        self.shape = (n_regions, n_species)
        self.genome = genome
        self.robots_per_species = robots_per_species
        self.evaluate_counts = evaluate

    def counts(self, X: np.ndarray) -> np.ndarray:
        """(B, K, O) robot counts of (B, n_var) genomes."""
        return allocation_to_counts(GENOMES[self.genome].decode(X, *self.shape), self.robots_per_species)

    def objectives(self, X: np.ndarray) -> np.ndarray:
        return self.evaluate_counts(self.counts(X))


def team_hypervolume(front: np.ndarray) -> float:
    """Area dominated by (n, 2) [coverage cost, deployment cost] inside the thesis's box up to REFERENCE_POINT."""
    return hypervolume(front, REFERENCE_POINT)


@dataclass
class NSGA2Result:
    front: np.ndarray  # (F, 2) mutually non-dominated [coverage cost, deployment cost], by deployment
    counts: np.ndarray  # (F, K, O) the allocations of the front
    hypervolume: float
    seconds: float  # wall time of the search
    evaluations: int  # objective evaluations requested by NSGA-II (cached or not)


def _result(problem: AllocationProblem, front: Front) -> NSGA2Result:
    return NSGA2Result(front.objectives, problem.counts(front.genomes), team_hypervolume(front.objectives),
                       front.seconds, front.evaluations)


def allocation_nsga2(evaluate: Callable[[np.ndarray], np.ndarray], n_regions: int, n_species: int,
                     robots_per_species: int, config: NSGA2Config, genome: str = "fractions",
                     stop: Callable[[], bool] | None = None) -> NSGA2Result:
    """Run NSGA-II on the allocations of one chip; `evaluate` maps (B, K, O) counts to (B, 2) objectives; `stop`
    ends the run after a generation (a spend budget)."""
    problem = AllocationProblem(n_regions, n_species, robots_per_species, evaluate, genome)
    return _result(problem, run_nsga2(problem, DeploymentShareSampling(), config, stop))


def allocation_nsga2_together(runs: list[tuple[Callable[[np.ndarray], np.ndarray], NSGA2Config, str]],
                              n_regions: int, n_species: int, robots_per_species: int,
                              prefetch: Callable[[np.ndarray], object]) -> tuple[list[NSGA2Result], float]:
    """NSGA-II runs (each: its `evaluate`, settings, genome) on the allocations of one chip, stepped together;
    `prefetch` sees each generation's (B, K, O) counts of every run at once. Their results and wall time."""
    problems = [AllocationProblem(n_regions, n_species, robots_per_species, evaluate, genome)
                for evaluate, _, genome in runs]
    fronts, seconds = run_nsga2_together(
        [(problem, config) for problem, (_, config, _) in zip(problems, runs, strict=True)],
        DeploymentShareSampling(),
        lambda asked: prefetch(np.concatenate([problem.counts(genomes) for problem, genomes in asked])))
    return [_result(problem, front) for problem, front in zip(problems, fronts, strict=True)], seconds
