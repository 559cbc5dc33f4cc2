import numpy as np

from robocompose.search.evolve import evolve


def test_generation_runs_generations_minus_one_times_and_its_evaluations_count(peaks):
    problem, calls = peaks(), []

    def generation(counted, population, fitness, rng):
        calls.append(len(population))
        children = [counted.mutate(d, rng, 0.5) for d in population]
        return children, counted.evaluate(children)

    result = evolve(problem, generation, population=8, generations=5, seed=0)
    assert calls == [8] * 4  # generation 0 is the random sample
    assert len(result.best_per_generation) == 5 and problem.calls == 5
    assert result.evaluations == 8 * 5
    assert (np.diff(result.best_per_generation) >= 0).all()  # the best ever evaluated, so never worse


def test_one_generation_is_the_random_sample(peaks):
    def never(*args):
        raise AssertionError("no generation step for generations=1")

    result = evolve(peaks(), never, population=6, generations=1, seed=2)
    assert result.population == peaks().sample(np.random.default_rng(2), 6)
    assert result.best_per_generation == [result.best_fitness] and result.evaluations == 6
