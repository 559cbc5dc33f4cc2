import numpy as np

from robocompose.search.metrics import distinct_solutions


def hamming(a, b):
    return sum(x != y for x, y in zip(a, b, strict=True))


def test_counts_different_designs_within_epsilon_of_the_best():
    designs = ["llllll", "llllll", "lllllw", "wwwwww", "bbbbbb"]
    fitness = np.array([5.0, 5.0, 4.6, 4.4, 1.0])
    assert distinct_solutions(designs, fitness, hamming, delta=1, epsilon=0.5) == 2  # duplicate and far ones out
    assert distinct_solutions(designs, fitness, hamming, delta=1, epsilon=0.7) == 3
    assert distinct_solutions(designs, fitness, hamming, delta=2, epsilon=0.7) == 2  # lllllw too close to llllll


def test_empty_set_has_no_solutions():
    assert distinct_solutions([], np.array([]), hamming) == 0
