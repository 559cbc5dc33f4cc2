import pandas as pd
import pytest

from robocompose.modular.evaluate import Result
from robocompose.modular.plugins import eggan_problem
from robocompose.modular.robot import all_designs, valid_in_original


def _synthetic_truth(distance_of, terrain_seed: int = 1007) -> pd.DataFrame:
    """A full exhaustive table with made-up distances: valid designs get distance_of(design) (None: unstable)."""
    designs = all_designs()
    distance = [distance_of(d) if valid_in_original(d) else None for d in designs]
    return pd.DataFrame({"terrain_seed": terrain_seed, "design": designs,
                         "fitness": [-10.0 if x is None else x for x in distance], "distance": distance,
                         "status": ["invalid" if not valid_in_original(d) else "ok" if x is not None else "unstable"
                                    for d, x in zip(designs, distance, strict=True)],
                         "sim_steps": [100 if valid_in_original(d) else 0 for d in designs],
                         "seconds": [0.5 if valid_in_original(d) else 0.0 for d in designs]})


@pytest.fixture
def synthetic_truth():
    return _synthetic_truth


@pytest.fixture
def fake_rollouts(monkeypatch):
    """The EG-GAN problem's rollouts faked (distance = wheels minus the terrain seed mod 3); the calls made, as
    (terrain seed, designs)."""
    calls = []

    def fake(designs, terrain_seed, settings, rule, cache=None, executor=None, save_every=0):
        calls.append((terrain_seed, list(designs)))
        return [Result(None, "invalid", 0, 0.0) if rule.skips(d) else Result(float(d.count("w")) - terrain_seed % 3,
                                                                                "ok", 10, 0.01) for d in designs]

    monkeypatch.setattr(eggan_problem, "evaluate_designs", fake)
    return calls
