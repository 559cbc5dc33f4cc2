import numpy as np
import pytest
from pymoo.core.population import Population
from pymoo.core.problem import Problem

from robocompose.teams.nsga2 import (
    AllocationProblem,
    DeploymentShareSampling,
    NSGA2Config,
    RankRouletteSelection,
    SinglePointArithmeticCrossover,
    UniformMutation,
    hypervolume,
    non_dominated,
    run_nsga2,
)
from robocompose.teams.species import deployment_cost


def toy_objectives(counts: np.ndarray) -> np.ndarray:
    """Cheap stand-in for coverage: costs 1 per empty region, else falls with the robots per region."""
    per_region = counts.sum(-1)  # (B, K)
    coverage = np.where(per_region == 0, 1.0, 0.02 / np.maximum(per_region, 1)).sum(-1)
    return np.stack([coverage, deployment_cost(counts)], axis=-1).astype(np.float64)


def dominates(a: np.ndarray, b: np.ndarray) -> bool:
    return bool((a <= b).all() and (a < b).any())


@pytest.mark.parametrize("population", [8, 20])
def test_every_returned_front_is_mutually_non_dominated(population):
    result = run_nsga2(toy_objectives, 3, 3, 20, NSGA2Config(population=population, generations=6, seed=1))
    front = result.front
    assert len(front) >= 2
    assert not any(dominates(p, q) for p in front for q in front)
    np.testing.assert_array_equal(front, toy_objectives(result.counts))
    assert np.all(np.diff(front[:, 1]) > 0)  # sorted by deployment cost
    assert result.evaluations == population * 6
    assert result.hypervolume == pytest.approx(hypervolume(front))


def test_nsga2_is_deterministic_given_its_seed_and_improves_with_generations():
    first = run_nsga2(toy_objectives, 3, 3, 20, NSGA2Config(population=10, generations=2, seed=3))
    again = run_nsga2(toy_objectives, 3, 3, 20, NSGA2Config(population=10, generations=2, seed=3))
    longer = run_nsga2(toy_objectives, 3, 3, 20, NSGA2Config(population=10, generations=15, seed=3))
    np.testing.assert_array_equal(first.front, again.front)
    assert longer.hypervolume >= first.hypervolume


def test_hypervolume_against_hand_computed_areas():
    reference = (0.25, 60.0)
    assert hypervolume(np.array([[0.05, 10.0]]), reference) == pytest.approx(0.2 * 50)
    two = np.array([[0.05, 10.0], [0.01, 30.0]])
    assert hypervolume(two, reference) == pytest.approx(0.2 * 50 + 0.04 * 30)
    assert hypervolume(np.array([[1.0, 5.0]]), reference) == 0.0  # outside the box


def test_non_dominated_drops_dominated_and_duplicate_points():
    points = np.array([[0.1, 10.0], [0.1, 10.0], [0.2, 12.0], [0.05, 20.0], [0.3, 5.0]])
    assert non_dominated(points).tolist() == [0, 3, 4]


def test_operators_follow_the_thesis_definitions():
    rng = np.random.default_rng(0)
    problem = Problem(n_var=12, n_obj=2, xl=0.0, xu=1.0)
    parents = np.stack([np.zeros((500, 12)), np.ones((500, 12))])  # (2, n_matings, n_var)
    children = SinglePointArithmeticCrossover(0.5)._do(problem, parents, random_state=rng)
    np.testing.assert_allclose(children[0] + children[1], 1.0)  # blends are complementary
    cuts = np.argmax(children[0] != 0.0, axis=1)  # first blended gene: the genes before it are copied
    for child, cut in zip(children[0], cuts, strict=True):
        assert (child[:cut] == 0).all() and np.ptp(child[cut:]) == 0  # copied head, then one blend
    assert len(set(cuts.tolist())) == 12  # the cut point is drawn over every gene
    genes = np.full((2000, 12), 0.5)
    mutated = UniformMutation(0.1)._do(problem, genes, random_state=rng)
    assert abs((mutated != 0.5).mean() - 0.1) < 0.01


def test_initial_population_spans_deployment_costs():
    problem = AllocationProblem(4, 3, 20, toy_objectives)
    genomes = DeploymentShareSampling()._do(problem, 400, random_state=np.random.default_rng(0))
    deployed = deployment_cost(problem.counts(genomes))
    assert deployed.min() < 12 and deployed.max() > 48


def test_roulette_wheel_gives_each_individual_a_slice_by_its_crowded_comparison_order():
    population = Population.new("X", np.zeros((4, 2)))
    population.set("rank", np.array([1, 0, 0, 2]))
    population.set("crowding", np.array([5.0, 0.5, np.inf, 9.0]))
    # order best first: index 2 (rank 0, infinite crowding), 1, 0, 3 -> slices 4, 3, 2, 1 of 10
    picks = RankRouletteSelection()._do(None, population, 20000, 2, random_state=np.random.default_rng(0))
    assert picks.shape == (20000, 2)
    shares = np.bincount(picks.ravel(), minlength=4) / picks.size
    np.testing.assert_allclose(shares, [0.2, 0.3, 0.4, 0.1], atol=0.01)
