import numpy as np
import pandas as pd
import pytest

from robocompose.io import InputError
from robocompose.teams import heldout
from robocompose.teams.chips import ChipsConfig, prepare_chips
from robocompose.teams.decompose import DecomposeConfig, regions_table
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage
from robocompose.teams.experiments import decomposed_chips
from robocompose.teams.heldout import budget_picks, heldout_hypervolumes, remeasured, single_draw_costs
from robocompose.teams.params import ExperimentsConfig

TINY = CoverageConfig(iterations=3, n_observations=5)


@pytest.fixture(scope="module")
def test_chips(tmp_path_factory):
    chips = prepare_chips(ChipsConfig(n_synthetic=2, seed=4), tmp_path_factory.mktemp("chips"))
    return decomposed_chips(regions_table(chips, DecomposeConfig(n_regions=3, test_fraction=0.5)), "test")


def _points(chip_id: str) -> pd.DataFrame:
    """Two methods' fronts on one chip at search seed 0 (their costs there: the caller's)."""
    counts = [[2, 0, 0, 0, 1, 0, 0, 0, 1], [3, 1, 0, 2, 2, 0, 1, 0, 3], [5, 5, 5, 5, 5, 5, 5, 5, 5]]
    return pd.DataFrame({"method": ["eggan:0", "eggan:0", "random:512"], "chip_id": chip_id, "seed": 0,
                         "deployment_cost": [sum(c) for c in counts], "counts": counts})


def test_a_reported_cost_never_uses_the_seed_it_was_selected_on(test_chips, monkeypatch):
    chip, decomposition = test_chips[0]
    points = _points(chip.chip_id)
    at_search = AllocationEvaluator(chip_coverage(chip, decomposition, TINY), chip.chip_id, 0)
    points["coverage_cost"] = at_search(np.asarray(points.counts.tolist()).reshape(-1, 3, 3))[:, 0]
    used = []

    class Spy(AllocationEvaluator):
        def __init__(self, coverage, chip_id, seed, *args, **kwargs):
            used.append(seed)
            super().__init__(coverage, chip_id, seed, *args, **kwargs)

    monkeypatch.setattr(heldout, "AllocationEvaluator", Spy)
    again = remeasured(points, test_chips, TINY, [7, 8, 9])
    assert sorted(used) == [7, 8, 9]
    for row in again.itertuples():
        costs = [AllocationEvaluator(chip_coverage(chip, decomposition, TINY), chip.chip_id, seed)(
            np.reshape(row.counts, (1, 3, 3)))[0, 0] for seed in (7, 8, 9)]
        assert row.heldout_mean == pytest.approx(np.mean(costs))
        assert row.heldout_sd == pytest.approx(np.std(costs, ddof=1))
    assert (again.heldout_mean != again.coverage_cost).all()  # another start seed, another cost
    picks = budget_picks(again, [3, 30, 45])
    # nothing deploys <= 3 robots; the random front's one point deploys 45: within the last budget only
    assert list(zip(picks.method, picks.budget, strict=True)) == [("eggan:0", 30), ("eggan:0", 45), ("random:512", 45)]
    within = again[(again.method == "eggan:0") & (again.deployment_cost <= 30)]
    pick = within.loc[within.coverage_cost.idxmin()]  # chosen at the search seed ...
    row = picks[(picks.method == "eggan:0") & (picks.budget == 30)].iloc[0]
    assert row.selected_cost == pick.coverage_cost and row.heldout_mean == pick.heldout_mean  # ... reported held out
    hypervolumes = heldout_hypervolumes(again)
    assert hypervolumes.front_size.tolist() == [2, 1]
    single = single_draw_costs(test_chips[:1], TINY, [0], [3, 6], [7, 8])
    assert set(single.method) == set(heldout.SINGLE_DRAWS) and single.selected_cost.isna().all()
    assert sorted(set(used)) == [7, 8, 9]  # the single draws too: only held-out seeds


def test_heldout_seeds_must_not_include_a_search_seed():
    with pytest.raises(InputError, match="heldout_seeds"):
        ExperimentsConfig(seeds=[0, 1], heldout_seeds=[1, 100])
    with pytest.raises(InputError, match="heldout_seeds"):
        ExperimentsConfig(seeds=[0], heldout_seeds=[100])  # one seed has no spread


def test_heldout_hypervolume_is_of_the_same_allocations_at_their_heldout_cost():
    points = pd.DataFrame({"method": "eggan:0", "chip_id": "c", "seed": 0, "coverage_cost": [0.05, 0.10],
                           "deployment_cost": [40, 20], "counts": [[1], [1]], "heldout_mean": [0.20, 0.10],
                           "heldout_sd": [0.01, 0.01]})
    row = heldout_hypervolumes(points).iloc[0]
    assert row.hypervolume == pytest.approx(0.20 * 20 + 0.15 * 20)  # (0.10, 20) then (0.05, 40) up to (0.25, 60)
    assert row.heldout_hypervolume == pytest.approx(0.15 * 40)  # (0.20, 40) now inside (0.10, 20)'s box
