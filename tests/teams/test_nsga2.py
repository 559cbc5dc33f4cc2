import numpy as np
import pytest

from robocompose.search.nsga2 import NSGA2Config
from robocompose.teams.nsga2 import (
    REFERENCE_POINT,
    AllocationProblem,
    DeploymentShareSampling,
    allocation_nsga2,
    team_hypervolume,
)
from robocompose.teams.species import deployment_cost


def toy_objectives(counts: np.ndarray) -> np.ndarray:
    """Cheap stand-in for coverage: costs 1 per empty region, else falls with the robots per region."""
    per_region = counts.sum(-1)  # (B, K)
    coverage = np.where(per_region == 0, 1.0, 0.02 / np.maximum(per_region, 1)).sum(-1)
    return np.stack([coverage, deployment_cost(counts)], axis=-1).astype(np.float64)


@pytest.mark.parametrize("population", [8, 20])
def test_the_front_holds_allocations_and_their_objectives_by_deployment_cost(population):
    result = allocation_nsga2(toy_objectives, 3, 3, 20, NSGA2Config(population=population, generations=6, seed=1))
    assert len(result.front) >= 2 and result.counts.shape == (len(result.front), 3, 3)
    np.testing.assert_array_equal(result.front, toy_objectives(result.counts))
    assert np.all(np.diff(result.front[:, 1]) > 0)  # sorted by deployment cost
    assert result.evaluations == population * 6
    assert result.hypervolume == pytest.approx(team_hypervolume(result.front)) and result.hypervolume > 0


def test_the_team_hypervolume_is_the_thesis_box():
    assert REFERENCE_POINT == (0.25, 60.0)
    assert team_hypervolume(np.array([[0.05, 10.0]])) == pytest.approx(0.2 * 50)


def test_initial_population_spans_deployment_costs():
    problem = AllocationProblem(4, 3, 20, toy_objectives)
    genomes = DeploymentShareSampling()._do(problem, 400, random_state=np.random.default_rng(0))
    deployed = deployment_cost(problem.counts(genomes))
    assert deployed.min() < 12 and deployed.max() > 48
    np.testing.assert_array_equal(problem.objectives(genomes), toy_objectives(problem.counts(genomes)))

