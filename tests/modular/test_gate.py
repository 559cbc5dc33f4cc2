import numpy as np
import pandas as pd
import pytest

from robocompose.io.errors import InputError
from robocompose.modular.gate import GateConfig, gate, greedy_portfolio, height_map_features


def _world(terrains: int, designs: int, decides: bool, seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A synthetic table. Deciding: each design peaks at its own terrain value h (designs spread over [0, 1]),
    falling 20 m per unit of h away, and h is a feature. Not deciding: design quality plus a terrain offset plus
    noise, with a feature that says nothing about which design wins."""
    rng = np.random.default_rng(seed)
    h = rng.uniform(0, 1, terrains)
    if decides:
        peaks = np.linspace(0, 1, designs)
        table = 3.0 - 20 * np.abs(h[:, None] - peaks[None, :])
    else:
        table = rng.uniform(1, 3, designs)[None, :] + 2 * h[:, None] + rng.normal(0, 0.1, (terrains, designs))
    index = pd.Index(range(terrains), name="terrain_seed")
    return (pd.DataFrame(table, index=index, columns=[f"d{j}" for j in range(designs)]),
            pd.DataFrame({"h": h, "noise": rng.normal(size=terrains)}, index=index))


def test_the_gate_passes_where_the_terrain_decides():
    table, features = _world(30, 60, decides=True)
    summary = gate(table, features).summary
    assert summary["passes"], summary["k"]
    for k in ("3", "10"):
        assert summary["k"][k]["gain_share"] >= 0.05 and summary["k"][k]["p"] < 0.05


def test_the_gate_fails_where_one_design_is_best_everywhere():
    table, features = _world(30, 60, decides=False)
    summary = gate(table, features).summary
    assert not summary["passes"]
    assert all(summary["k"][k]["gain_m"] <= 0.05 for k in ("3", "10"))


def test_the_gate_fails_where_two_terrain_types_are_covered_by_a_portfolio_of_two():
    """Two types with different best designs and a feature telling them apart: the terrain decides, but a
    portfolio of 3 already holds both winners, so predicting the terrain gains nothing at k = 3 and 10."""
    rng = np.random.default_rng(1)
    kind = np.arange(20) % 2
    table = rng.uniform(0, 1, (20, 30))
    table[:, 0] += 3 * (kind == 0)
    table[:, 1] += 3 * (kind == 1)
    index = pd.Index(range(20))
    summary = gate(pd.DataFrame(table, index=index), pd.DataFrame({"kind": kind}, index=index)).summary
    assert summary["k"]["1"]["gain_share"] > 0.3 and summary["k"]["1"]["p"] < 0.05  # best-of-1 does gain
    assert not summary["passes"] and summary["k"]["3"]["gain_m"] <= 0.05


def test_the_greedy_portfolio_covers_before_it_averages():
    table = np.array([[3.0, 0.0, 2.0], [0.0, 3.0, 2.0]])
    assert greedy_portfolio(table, 1) == [2]  # best on average first
    assert greedy_portfolio(table, 2) == [2, 0]  # then the best addition (ties to the lower column)
    assert greedy_portfolio(table, 3) == [2, 0, 1]
    assert greedy_portfolio(table, 9) == [2, 0, 1]


def test_height_map_features_see_walls_and_ice():
    flat, wall, sheet = np.zeros((50, 20)), np.zeros((50, 20)), np.zeros((50, 20))
    wall[10] = 0.12
    sheet[20:30] = 0.005
    f, w, s = height_map_features(flat), height_map_features(wall), height_map_features(sheet)
    assert f["max"] == 0 and f["first_obstacle"] == 1.0
    assert w["above_100mm"] == pytest.approx(1 / 50) and w["first_obstacle"] == pytest.approx(10 / 50)
    assert s["above_2mm"] == pytest.approx(10 / 50) and s["above_50mm"] == 0 and s["first_obstacle"] == 1.0


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"ks": (1, 3), "pass_ks": (3, 10)}, ["pass_ks", "[3, 10]", "[1, 3]"]),
    ({"ks": (0, 3)}, ["ks", "positive"]),
    ({"neighbours": 0}, ["neighbours", "0"]),
    ({"alpha": 1.5}, ["alpha", "1.5"]),
])
def test_bad_gate_settings_are_refused(kwargs, words):
    with pytest.raises(InputError) as err:
        GateConfig(**kwargs)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_the_gate_refuses_too_few_terrains_and_mismatched_features():
    table, features = _world(4, 5, decides=True)
    with pytest.raises(InputError, match="at least neighbours"):
        gate(table, features)
    table, features = _world(10, 5, decides=True)
    with pytest.raises(InputError, match="features"):
        gate(table, features.iloc[1:])
