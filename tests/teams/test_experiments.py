import dataclasses

import numpy as np
import pandas as pd
import pytest

from robocompose.fanout.executor import Executor
from robocompose.teams.chips import ChipsConfig, prepare_chips
from robocompose.teams.decompose import DecomposeConfig, regions_table
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage, teams_cache
from robocompose.teams.experiments import (
    coverage_baselines,
    decomposed_chips,
    example_allocation,
    example_trajectories,
    nsga2_alone,
    nsga2_runs,
    random_fronts,
)
from robocompose.teams.params import ExperimentsConfig

TINY = CoverageConfig(iterations=3, n_observations=5)
EXPERIMENTS = ExperimentsConfig(populations=[4, 6], generations=2, table_5_4_chips=1,
                                table_5_5_chips=1, seeds=[0, 1], budgets=[3, 6])


@pytest.fixture(scope="module")
def test_chips(tmp_path_factory):
    chips = prepare_chips(ChipsConfig(n_synthetic=4, seed=2), tmp_path_factory.mktemp("chips"))
    regions = regions_table(chips, DecomposeConfig(n_regions=3, test_fraction=0.5))
    return decomposed_chips(regions, "test")


def test_decomposed_test_chips_carry_their_regions(test_chips):
    assert len(test_chips) == 2
    chip, decomposition = test_chips[0]
    assert decomposition.centres.shape == (3, 6) and chip.classes.shape == (300, 300)
    assert set(np.unique(decomposition.raster(chip.terrain))) == {0, 1, 2}


def test_nsga2_runs_record_every_population_and_a_front_per_run(test_chips):
    cache = teams_cache()
    runs, fronts, seconds = nsga2_runs(test_chips, TINY, EXPERIMENTS, cache)
    assert runs.population.tolist() == [4, 6, 4, 6] and (runs.evaluations == [8, 12, 8, 12]).all()
    assert runs.seed.tolist() == [0, 0, 1, 1] and "seconds" not in runs  # wall time: not in the table
    assert set(runs.genome) == {"fractions"}
    chip_id = test_chips[0][0].chip_id
    assert [(run["chip_id"], run["seed"]) for run in seconds["nsga2_groups"]] == [(chip_id, 0), (chip_id, 1)]
    # the time a user waits for: each run alone, on the first chip and seed
    assert [(run["population"], run["seed"]) for run in seconds["nsga2_alone"]] == [(4, 0), (6, 0)]
    assert all(run["seconds"] > 0 for group in seconds.values() for run in group)
    assert (runs.distinct_teams < runs.team_lookups).all()  # the memo saved optimisations in every run
    # teams_eggan times the same runs alone again, beside EG-GAN's queries
    alone = nsga2_alone(*test_chips[0], TINY, EXPERIMENTS)
    assert [{k: v for k, v in run.items() if k != "seconds"} for run in alone] == \
        [{k: v for k, v in run.items() if k != "seconds"} for run in seconds["nsga2_alone"]]
    # the runs of a chip and seed share their memo: a team two of them met was optimised once
    optimised = cache.frame().groupby("seed").size()
    assert (optimised <= runs.groupby("seed").distinct_teams.sum()).all()
    assert (optimised >= runs.groupby("seed").distinct_teams.max()).all()
    chips = {chip.chip_id: (chip, decomposition) for chip, decomposition in test_chips}
    for row in fronts.itertuples():  # every front point is the sum of its teams' cached costs
        memo = AllocationEvaluator(chip_coverage(*chips[row.chip_id], TINY), row.chip_id, row.seed, cache)
        assert memo(np.reshape(row.counts, (1, 3, 3)))[0, 0] == pytest.approx(row.coverage_cost, rel=1e-6)
        assert memo.optimised == 0
    for _, front in fronts.groupby(["genome", "population", "seed"]):
        points = front[["coverage_cost", "deployment_cost"]].to_numpy()
        assert not any((p <= q).all() and (p < q).any() for p in points for q in points)
    for counts, deployed in zip(fronts.counts, fronts.deployment_cost, strict=True):
        assert len(counts) == 9 and sum(counts) == deployed
    counts, seed = example_allocation(fronts, test_chips[0][0].chip_id, 3)
    assert counts.shape == (3, 3) and seed in (0, 1)
    chip, decomposition = test_chips[0]
    trajectories = example_trajectories(chip, decomposition, TINY, counts, seed)
    assert len(trajectories) == counts.sum() * TINY.n_observations
    assert trajectories[["x", "y"]].to_numpy().min() >= 0 and trajectories[["x", "y"]].to_numpy().max() < 1


def test_random_fronts_are_prefixes_of_one_draw_measured_by_the_optimiser(test_chips):
    table, points = random_fronts(test_chips, TINY, EXPERIMENTS)
    assert table.draws.tolist() == [64, 512] * 2 and table.seed.tolist() == [0, 0, 1, 1]
    for _, rows in table.groupby("seed"):
        small, large = rows.hypervolume.tolist()
        assert 0 < small <= large  # 512 draws hold the 64: their front can only gain
        few, many = rows.distinct_teams.tolist()
        assert 0 < few < many  # the teams of the first 64 draws, then of all 512
    assert table.hypervolume.nunique() == 4  # another seed, other draws
    sizes = points.groupby(["chip_id", "seed", "draws"]).size()
    assert sizes.tolist() == table.front_size.tolist()  # the points are the fronts the table summarises
    for _, front in points.groupby(["seed", "draws"]):
        assert (np.diff(front.deployment_cost) > 0).all() and (np.diff(front.coverage_cost) < 0).all()
    again, again_points = random_fronts(test_chips, TINY, EXPERIMENTS)
    pd.testing.assert_frame_equal(again, table, check_exact=True)
    pd.testing.assert_frame_equal(again_points, points, check_exact=True)


def test_nsga2_on_each_genome_starts_from_the_same_first_population(test_chips):
    both = dataclasses.replace(EXPERIMENTS, genomes=["fractions", "share_split"], populations=[6], seeds=[0])
    fronts = {generations: nsga2_runs(test_chips, TINY, dataclasses.replace(both, generations=generations),
                                      teams_cache())[1] for generations in (1, 3)}
    first = {genome: rows.counts.map(tuple).tolist() for genome, rows in fronts[1].groupby("genome")}
    assert first["fractions"] == first["share_split"]  # generation 1 is the first population alone
    later = {genome: rows.counts.map(tuple).tolist() for genome, rows in fronts[3].groupby("genome")}
    assert later["fractions"] != later["share_split"]  # then the genomes' children differ


def test_a_team_budget_stops_nsga2_after_the_generation_that_reaches_it(test_chips):
    from robocompose.search.nsga2 import NSGA2Config
    from robocompose.teams.experiments import budgeted_nsga2_runs

    chip, decomposition = test_chips[0]
    config = NSGA2Config(population=4, generations=30, seed=0)
    free, _, _ = budgeted_nsga2_runs([(chip, decomposition, config, "share_split")], TINY, teams_cache())
    capped, _, _ = budgeted_nsga2_runs([(chip, decomposition, config, "share_split")], TINY, teams_cache(),
                                       max_teams=[10])
    assert capped.distinct_teams[0] >= 10 and capped.evaluations[0] < free.evaluations[0]
    # the generation before the last had fewer: at most one generation's new teams (4 allocations x 3 regions)
    assert capped.distinct_teams[0] < 10 + 4 * 3


def test_coverage_baselines_deploy_exactly_the_budget(test_chips):
    table = coverage_baselines(test_chips, TINY, EXPERIMENTS)
    assert len(table) == 3 * 2 * 2  # methods x budgets x seeds on one chip
    assert (table.deployment_cost == table.budget).all()
    assert (table[table.method == "dec_random_allocation"].empty_regions == 0).all()  # the thesis's: teams fill K
    assert np.isfinite(table.coverage_cost).all() and (table.coverage_cost > 0).all()


def test_every_row_of_a_table_runs_on_the_same_chips_and_seeds(test_chips):
    config = dataclasses.replace(EXPERIMENTS, table_5_4_chips=1, table_5_5_chips=2, seeds=[3], populations=[4, 6])
    runs, _, _ = nsga2_runs(test_chips, TINY, config, teams_cache())
    for _, rows in runs.groupby("population"):
        assert list(zip(rows.chip_id, rows.seed, strict=True)) == [(test_chips[0][0].chip_id, 3)]
    coverage = coverage_baselines(test_chips, TINY, config)
    pairs = {(chip.chip_id, 3) for chip, _ in test_chips[:2]}
    for _, rows in coverage.groupby(["method", "budget"]):
        assert set(zip(rows.chip_id, rows.seed, strict=True)) == pairs


def test_tables_and_cache_are_the_same_on_two_worker_processes_as_in_process(test_chips):
    config = dataclasses.replace(EXPERIMENTS, table_5_4_chips=2, table_5_5_chips=2, seeds=[0])
    serial_cache, parallel_cache = teams_cache(), teams_cache()
    serial = [*nsga2_runs(test_chips, TINY, config, serial_cache)[:2], coverage_baselines(test_chips, TINY, config)]
    with Executor(workers=2) as executor:
        assert executor.backend == "processes"
        parallel = [*nsga2_runs(test_chips, TINY, config, parallel_cache, executor)[:2],
                    coverage_baselines(test_chips, TINY, config, executor)]
    runs, fronts, coverage = serial
    assert len(runs) == 4 and coverage.chip_id.nunique() == 2
    for expected, got in zip(serial, parallel, strict=True):
        pd.testing.assert_frame_equal(got, expected, check_exact=True)
    pd.testing.assert_frame_equal(parallel_cache.frame(), serial_cache.frame(), check_exact=True)
