import numpy as np
import pytest


class PeaksProblem:
    """Strings of 6 genes in 0..3; fitness = genes matching the nearest of the peaks (a max of 6 at a peak)."""

    def __init__(self, peaks=("000000",)):
        self.peaks = peaks
        self.calls = 0

    def sample(self, rng, n):
        return ["".join(str(v) for v in row) for row in rng.integers(4, size=(n, 6))]

    def mutate(self, design, rng, rate):
        return "".join(str(rng.integers(4)) if rng.random() < rate else g for g in design)

    def crossover(self, a, b, rng):
        swap = rng.random(6) < 0.5
        return ("".join(y if s else x for x, y, s in zip(a, b, swap, strict=True)),
                "".join(x if s else y for x, y, s in zip(a, b, swap, strict=True)))

    def distance(self, a, b):
        return float(sum(x != y for x, y in zip(a, b, strict=True)))

    def evaluate(self, designs):
        self.calls += 1
        return np.array([max(6 - self.distance(d, p) for p in self.peaks) for d in designs])


@pytest.fixture
def peaks():
    return PeaksProblem
