import pytest

from robocompose.search.random_search import run_random


def test_random_sampling_keeps_the_best_of_n(peaks):
    problem = peaks()
    result = run_random(problem, 10, seed=0)
    assert result.evaluations == 10 and len(result.population) == 10
    assert result.best_fitness == result.fitness.max() and result.best == result.population[result.fitness.argmax()]
    assert run_random(peaks(), 10, seed=0).population == result.population


def test_needs_at_least_one_design(peaks):
    with pytest.raises(ValueError):
        run_random(peaks(), 0)
