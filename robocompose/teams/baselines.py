"""Coverage baselines of thesis Table 5.5, at a deployment budget of B robots.

Each draws B robots at random from the bank (N robots of each species, without replacement):
- decomposition + random allocation (the thesis's "randomly grouped into teams and allocated to each
  sub-region"): a uniformly random split of the B robots into K non-empty teams, one per region; teams plan in
  their regions exactly as for any allocation (ergodic.ChipCoverage).
- decomposition + uniform random robots (ours, labelled apart): each robot joins the team of a uniformly drawn
  region, so regions may stay empty (with 15 robots in 8 regions, 75% of draws leave one empty).
- no decomposition: the robots start anywhere on the chip (on terrain they can move on) and plan
  jointly, as one team, for uniform coverage of the whole chip.
Both are scored by the same cost as every allocation (ergodic.py): the area-weighted sum over the
regions of the ergodic metric of the observations attributed to the region, in units of one random
glance. For the decomposed plans an observation counts for its robot's team; the joint plan has no
teams, so each observation counts for the region it lies in (a region nobody visits costs what an
empty team does).
"""

from __future__ import annotations

import numpy as np
import torch

from robocompose.io.errors import InputError
from robocompose.teams.ergodic import ChipCoverage, Robots, ergodic_cost
from robocompose.teams.species import coverage_weights


def random_species_counts(rng: np.random.Generator, budget: int, n_species: int,
                          robots_per_species: int) -> np.ndarray:
    """(O,) species counts of `budget` robots drawn without replacement from the bank."""
    bank = np.repeat(np.arange(n_species), robots_per_species)
    return np.bincount(rng.choice(bank, size=budget, replace=False), minlength=n_species)


def random_allocation(rng: np.random.Generator, budget: int, n_regions: int, n_species: int,
                      robots_per_species: int) -> np.ndarray:
    """(K, O) counts: `budget` random robots, each sent to a uniformly drawn region."""
    species = np.repeat(np.arange(n_species), random_species_counts(rng, budget, n_species,
                                                                   robots_per_species))
    regions = rng.integers(n_regions, size=budget)
    counts = np.zeros((n_regions, n_species), dtype=np.int64)
    np.add.at(counts, (regions, species), 1)
    return counts


def random_teams(rng: np.random.Generator, budget: int, n_regions: int, n_species: int,
                 robots_per_species: int) -> np.ndarray:
    """(K, O) counts: `budget` random robots split at random into `n_regions` non-empty teams (team sizes: a
    uniformly drawn composition of the budget into K positive parts; robots shuffled into them)."""
    if budget < n_regions:
        raise InputError(f"budget {budget}: expected at least one robot per region ({n_regions})")
    species = np.repeat(np.arange(n_species), random_species_counts(rng, budget, n_species, robots_per_species))
    cuts = np.sort(rng.choice(np.arange(1, budget), size=n_regions - 1, replace=False))
    sizes = np.diff(np.concatenate([[0], cuts, [budget]]))  # (K,) >= 1 each, summing to the budget
    regions = np.repeat(np.arange(n_regions), sizes)
    counts = np.zeros((n_regions, n_species), dtype=np.int64)
    np.add.at(counts, (regions, rng.permutation(species)), 1)
    return counts


def joint_plan(decomposed: ChipCoverage, species_counts: np.ndarray, seed: int) -> tuple[Robots, torch.Tensor]:
    """Robots of (B, O) teams started anywhere on the chip and planned jointly for the whole chip
    (team b = allocation b), and their (N, T, 2) observations."""
    whole_chip = ChipCoverage(decomposed.terrain.numpy(), np.zeros_like(decomposed.regions), 1, decomposed.config)
    _, robots, observations = whole_chip.evaluate(species_counts[:, None, :], seed)
    return robots, observations


def no_decomposition_costs(decomposed: ChipCoverage, species_counts: np.ndarray, seed: int
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Teams of (B, O) robots planning jointly over the whole chip, scored per region.

    Returns ((B,) coverage costs, (B,) number of regions none of the team's observations fall in).
    """
    regions = decomposed.regions
    robots, observations = joint_plan(decomposed, species_counts, seed)  # (N, T, 2)
    height, width = regions.shape
    points = observations.reshape(-1, 2).double()  # (N*T, 2)
    col = (points[:, 0] * width).long().clamp(0, width - 1)
    row = (points[:, 1] * height).long().clamp(0, height - 1)
    region_of_point = torch.as_tensor(regions)[row, col]  # (N*T,)
    allocation_of_point = robots.team.repeat_interleave(observations.shape[1])  # team b = allocation b
    weights = torch.as_tensor(coverage_weights())[robots.species].repeat_interleave(observations.shape[1])
    n_regions = decomposed.n_regions
    team_of_point = allocation_of_point * n_regions + region_of_point  # (N*T,)
    metrics = ergodic_cost(points[:, None, :], weights[:, None], team_of_point,
                           decomposed.phi.repeat(len(species_counts), 1, 1))  # (B*K,)
    visited = torch.zeros(len(species_counts) * n_regions, dtype=torch.bool)
    visited[team_of_point] = True
    return decomposed.coverage_cost(metrics), (~visited).reshape(-1, n_regions).sum(1).numpy()
