import numpy as np
import pytest

from robocompose.search.ga import GAConfig, run_ga, tournament
from robocompose.search.random_search import run_random


def test_ga_finds_the_peak_and_spends_population_times_generations(peaks):
    problem = peaks()
    result = run_ga(problem, GAConfig(population=20, generations=30, seed=1))
    assert result.best_fitness == 6 and result.best == "000000"
    assert result.evaluations == 20 * 30 and problem.calls == 30  # one batch per generation
    assert len(result.population) == 20 and result.fitness.shape == (20,)


def test_ga_finds_the_peak_where_random_sampling_with_the_same_evaluations_does_not(peaks):
    ga = [run_ga(peaks(), GAConfig(population=20, generations=15, seed=s)).best_fitness for s in range(5)]
    random = [run_random(peaks(), 20 * 15, seed=s).best_fitness for s in range(5)]  # 1 design in 4096
    assert ga == [6] * 5 and max(random) < 6


def test_elitism_keeps_the_best_in_the_final_population_and_it_is_lost_without(peaks):
    def final_and_best(elite, seed):
        result = run_ga(peaks(), GAConfig(population=10, generations=15, elite=elite, mutation_rate=0.9, seed=seed))
        return result.fitness.max(), result.best_fitness

    assert all(final == best for final, best in (final_and_best(1, s) for s in range(4)))
    assert all(final < best for final, best in (final_and_best(0, s) for s in range(4)))


def test_same_seed_same_run_other_seed_other_run(peaks):
    a, b = run_ga(peaks(), GAConfig(seed=3, generations=5)), run_ga(peaks(), GAConfig(seed=3, generations=5))
    c = run_ga(peaks(), GAConfig(seed=4, generations=5))
    assert a.population == b.population and a.population != c.population


def test_tournament_picks_the_fitter_of_two():
    rng = np.random.default_rng(0)
    fitness = np.array([0.0, 1.0])
    picks = [tournament(fitness, rng) for _ in range(200)]
    assert 0.7 < np.mean(picks) < 0.8  # index 1 wins unless both draws are 0 (p = 1/4)


def test_bad_config_is_rejected():
    with pytest.raises(ValueError, match="population"):
        GAConfig(population=1)
