import numpy as np
import pytest
from pymoo.core.population import Population
from pymoo.core.problem import Problem
from pymoo.operators.sampling.rnd import FloatRandomSampling

from robocompose.search.nsga2 import (
    GenomeProblem,
    NSGA2Config,
    RankRouletteSelection,
    SinglePointArithmeticCrossover,
    UniformMutation,
    hypervolume,
    non_dominated,
    nsga2_generation,
    run_nsga2,
    run_nsga2_together,
)


class Schaffer(GenomeProblem):
    """A two-objective toy on one gene x in [-2, 4]: x^2 and (x - 2)^2; its Pareto set is x in [0, 2]."""

    def __init__(self):
        super().__init__(n_var=1, n_obj=2, xl=-2.0, xu=4.0)

    def objectives(self, X):
        return np.stack([X[:, 0] ** 2, (X[:, 0] - 2) ** 2], axis=-1)


def dominates(a: np.ndarray, b: np.ndarray) -> bool:
    return bool((a <= b).all() and (a < b).any())


@pytest.mark.parametrize("population", [8, 20])
def test_the_front_is_mutually_non_dominated_sorted_by_the_last_objective_and_near_the_pareto_set(population):
    front = run_nsga2(Schaffer(), FloatRandomSampling(), NSGA2Config(population=population, generations=20, seed=1))
    assert len(front.objectives) >= 2 and not any(dominates(p, q) for p in front.objectives for q in front.objectives)
    np.testing.assert_array_equal(front.objectives, Schaffer().objectives(front.genomes))
    assert np.all(np.diff(front.objectives[:, -1]) > 0)
    assert front.evaluations == population * 20 and front.seconds > 0
    assert (front.genomes > -0.1).all() and (front.genomes < 2.1).all()


def test_nsga2_is_deterministic_given_its_seed_and_improves_with_generations():
    reference = (4.0, 4.0)
    first, again, longer = (run_nsga2(Schaffer(), FloatRandomSampling(), NSGA2Config(population=10, generations=g,
                                                                                     seed=3)) for g in (2, 2, 15))
    np.testing.assert_array_equal(first.objectives, again.objectives)
    assert hypervolume(longer.objectives, reference) >= hypervolume(first.objectives, reference)


def test_runs_stepped_together_are_each_the_run_it_would_be_alone():
    settings = [NSGA2Config(population=8, generations=6, seed=1), NSGA2Config(population=12, generations=3, seed=2),
                NSGA2Config(population=8, generations=6, seed=5)]
    seen = []
    together, seconds = run_nsga2_together([(Schaffer(), config) for config in settings], FloatRandomSampling(),
                                           lambda asked: seen.append([len(g) for _, g in asked]))
    for config, front in zip(settings, together, strict=True):
        alone = run_nsga2(Schaffer(), FloatRandomSampling(), config)
        np.testing.assert_array_equal(front.genomes, alone.genomes)
        assert front.evaluations == alone.evaluations and front.seconds == seconds
    # every generation of every run still going is prefetched in one call; the shorter run drops out
    assert seen == [[8, 12, 8]] * 3 + [[8, 8]] * 3


def test_one_generation_keeps_the_batch_and_does_not_lose_hypervolume():
    rng = np.random.default_rng(0)
    problem = Schaffer()
    genomes = rng.uniform(-2, 4, size=(12, 1))
    objectives = problem.objectives(genomes)
    evolved, evolved_objectives = nsga2_generation(genomes, objectives, problem, 0.5, 0.1, rng)
    assert evolved.shape == genomes.shape
    np.testing.assert_array_equal(evolved_objectives, problem.objectives(evolved))
    assert hypervolume(evolved_objectives, (16.0, 16.0)) >= hypervolume(objectives, (16.0, 16.0))


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


def test_roulette_wheel_gives_each_individual_a_slice_by_its_crowded_comparison_order():
    population = Population.new("X", np.zeros((4, 2)))
    population.set("rank", np.array([1, 0, 0, 2]))
    population.set("crowding", np.array([5.0, 0.5, np.inf, 9.0]))
    # order best first: index 2 (rank 0, infinite crowding), 1, 0, 3 -> slices 4, 3, 2, 1 of 10
    picks = RankRouletteSelection()._do(None, population, 20000, 2, random_state=np.random.default_rng(0))
    assert picks.shape == (20000, 2)
    shares = np.bincount(picks.ravel(), minlength=4) / picks.size
    np.testing.assert_allclose(shares, [0.2, 0.3, 0.4, 0.1], atol=0.01)
