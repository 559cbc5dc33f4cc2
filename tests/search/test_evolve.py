import numpy as np

from robocompose.search.evolve import evolve


class Recording:
    """A problem that keeps the fitness of every batch it evaluates."""

    def __init__(self, base):
        self.base, self.batches = base, []

    def __getattr__(self, name):
        return getattr(self.base, name)

    def evaluate(self, designs):
        self.batches.append(self.base.evaluate(designs))
        return self.batches[-1]


def test_generation_runs_generations_minus_one_times_and_the_history_is_the_best_evaluated(peaks):
    problem, calls = Recording(peaks()), []

    def generation(counted, population, fitness, rng):
        calls.append(len(population))
        children = [counted.mutate(d, rng, 0.5) for d in population]
        return children, counted.evaluate(children)

    result = evolve(problem, generation, population=8, generations=5, seed=1)
    assert calls == [8] * 4  # generation 0 is the random sample
    assert len(problem.batches) == 5 and result.evaluations == 8 * 5
    batch_best = [batch.max() for batch in problem.batches]  # the random walk rises and falls: 2 3 2 2 4
    assert result.best_per_generation == np.maximum.accumulate(batch_best).tolist() != batch_best
    assert result.best_fitness == max(batch_best)


def test_one_generation_is_the_random_sample(peaks):
    def never(*args):
        raise AssertionError("no generation step for generations=1")

    result = evolve(peaks(), never, population=6, generations=1, seed=2)
    assert result.population == peaks().sample(np.random.default_rng(2), 6)
    assert result.best_per_generation == [result.best_fitness] and result.evaluations == 6
