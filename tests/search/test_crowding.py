import numpy as np
import pytest

from robocompose.search.crowding import CrowdingConfig, crowding_generation, run_crowding
from robocompose.search.ga import GAConfig, run_ga
from robocompose.search.metrics import distinct_solutions


def test_crowding_keeps_both_peaks_where_the_ga_keeps_one(peaks):
    problem = peaks(peaks=("000000", "333333"))
    crowd = run_crowding(problem, CrowdingConfig(population=50, generations=40, seed=0))
    ga = run_ga(problem, GAConfig(population=50, generations=40, seed=0))
    assert {"000000", "333333"} <= set(crowd.population)
    near_peaks = lambda pop: {min(("000000", "333333"), key=lambda p: problem.distance(d, p)) for d in pop}  # noqa: E731
    assert len(near_peaks(crowd.population)) == 2
    assert distinct_solutions(crowd.population, crowd.fitness, problem.distance, 1, 0.5) > \
        distinct_solutions(ga.population, ga.fitness, problem.distance, 1, 0.5)
    assert crowd.evaluations == 50 * 40


class Worsening:
    """Every child is worse than every parent: crowding must leave the population as it is."""

    def __init__(self, base):
        self.base = base

    def __getattr__(self, name):
        return getattr(self.base, name)

    def evaluate(self, designs):
        return np.full(len(designs), -1.0)


def test_a_child_replaces_its_parent_only_if_strictly_fitter(peaks):
    problem = Worsening(peaks())
    rng = np.random.default_rng(0)
    population = peaks().sample(rng, 10)
    fitness = np.zeros(10)
    new, new_fitness = crowding_generation(problem, population, fitness, rng, CrowdingConfig(population=10))
    assert new == population and (new_fitness == 0).all()
    equal = Worsening(peaks())
    equal.evaluate = lambda designs: np.zeros(len(designs))  # ties: parents stay
    new, _ = crowding_generation(equal, population, fitness, rng, CrowdingConfig(population=10))
    assert new == population


def test_children_compete_with_the_closer_parent(peaks):
    problem = peaks()
    rng = np.random.default_rng(1)
    population, fitness = ["000000", "333333"], np.array([-5.0, -5.0])  # any child beats its parent
    config = CrowdingConfig(population=2, crossover_rate=0.0, mutation_rate=0.0)
    new, _ = crowding_generation(problem, population, fitness, rng, config)
    assert new == population  # copies replace exactly their own parent, never the other one


def test_population_must_be_even():
    with pytest.raises(ValueError, match="even"):
        CrowdingConfig(population=7)
