import json

import pandas as pd
import pytest

from robocompose.fanout.cache import EvaluationCache
from robocompose.io.errors import InputError
from robocompose.modular.evaluate import EvalSettings, FitnessRule
from robocompose.modular.experiments.terrain_study import candidate_settings, criteria, directory_criterion, probe_table
from robocompose.modular.terrain import generate_terrain
from robocompose.modular.truth import exhaustive_terrain, write_committed

TINY = EvalSettings(control_steps=3, settle_steps=10)
RULE = FitnessRule()


def _table(distances: dict[int, dict[str, float]]) -> pd.DataFrame:
    return pd.DataFrame([{"terrain_seed": seed, "design": design, "distance": distance}
                         for seed, by_design in distances.items() for design, distance in by_design.items()])


# Smooth terrains favour wheels, rough ones leg-wheels or legs; "wbwwww" is the compromise. Four kinds, each twice
# (the criterion asks for >= 8 terrains).
KINDS = [{"wwwwww": 4.0, "bbbbbb": 3.0, "llllll": 1.0, "wbwwww": 3.6},
         {"wwwwww": 4.0, "bbbbbb": 3.2, "llllll": 1.0, "wbwwww": 3.6},
         {"wwwwww": 0.5, "bbbbbb": 3.0, "llllll": 1.5, "wbwwww": 2.6},
         {"wwwwww": 0.5, "bbbbbb": 0.6, "llllll": 1.5, "wbwwww": 1.0}]
HAND_BUILT = _table({seed: KINDS[(seed - 1) % 4] for seed in range(1, 9)})


def test_criteria_count_distinct_optima_and_the_regret_of_the_best_average_design():
    row = criteria(HAND_BUILT).iloc[0]
    # means: wwwwww 2.25, bbbbbb 2.45, llllll 1.25, wbwwww 2.7 -> wbwwww; optima 4, 4, 3, 1.5 (mean 3.125)
    assert row.average_design == "wbwwww" and row.optimum_designs == " ".join(["wwwwww wwwwww bbbbbb llllll"] * 2)
    assert row.terrains == 8 and row.distinct_optima == 3 and row.mean_optimum == pytest.approx(3.125)
    assert row.mean_regret == pytest.approx((0.4 + 0.4 + 0.4 + 0.5) / 4)
    assert row.regret_ratio == pytest.approx(0.425 / 3.125) and bool(row.holds)
    # Two distributions in one table are judged apart; on the second the wheels win everywhere.
    flat = HAND_BUILT.assign(distribution="flat", distance=HAND_BUILT.distance.where(
        HAND_BUILT.design != "wwwwww", 9.0))
    both = criteria(pd.concat([HAND_BUILT.assign(distribution="mixed"), flat]))
    assert list(both.distribution) == ["mixed", "flat"] and list(both.holds) == [True, False]
    assert both.set_index("distribution").loc["flat", "distinct_optima"] == 1


def test_criteria_fail_below_three_distinct_optima_or_eight_terrains_even_with_a_large_regret():
    legs_never_best = HAND_BUILT.copy()
    rough = (legs_never_best.terrain_seed % 4 == 0) & (legs_never_best.design == "bbbbbb")
    legs_never_best.loc[rough, "distance"] = 2.0  # leg-wheels now beat the legs there
    row = criteria(legs_never_best).iloc[0]
    assert row.distinct_optima == 2 and row.regret_ratio > 0.1 and not row.holds
    row = criteria(HAND_BUILT[HAND_BUILT.terrain_seed <= 4]).iloc[0]
    assert row.terrains == 4 and row.distinct_optima == 3 and row.regret_ratio > 0.1 and not row.holds


def test_candidate_settings_override_terrain_fields_and_reject_unknown_ones():
    candidates = candidate_settings(TINY, {"tall": {"max_height_range": [0.0, 0.4]}}, "c.yaml")
    tall = candidates["tall"]
    assert tall.terrain.max_height_range == (0.0, 0.4) and tall.terrain.spacing_range == TINY.terrain.spacing_range
    assert tall.control_steps == TINY.control_steps and tall.settings_hash() != TINY.settings_hash()
    with pytest.raises(InputError, match=r"c.yaml: tall.height: unknown terrain field"):
        candidate_settings(TINY, {"tall": {"height": 0.4}}, "c.yaml")
    with pytest.raises(InputError, match="c.yaml: expected at least one"):
        candidate_settings(TINY, {}, "c.yaml")


def test_probe_table_runs_every_candidate_on_every_terrain_and_reports_each_piece():
    candidates = candidate_settings(TINY, {"low": {"max_height_range": [0.0, 0.01]},
                                           "tall": {"max_height_range": [0.3, 0.4]}}, "c.yaml")
    pieces = []
    table = probe_table(candidates, [5, 6], RULE, EvaluationCache(), None, designs=["wwwwww", "nnnnnn"],
                        on_piece=lambda t: pieces.append(len(t)))
    assert pieces == [2, 4, 6, 8]  # terrain by terrain, both candidates on each
    assert list(table.distribution) == ["low", "low", "tall", "tall"] * 2
    heights = table.groupby(["distribution", "terrain_seed"]).terrain_max_height.first()
    assert heights[("low", 5)] == generate_terrain(5, candidates["low"].terrain).max_height <= 0.01
    assert heights[("tall", 6)] > 0.25  # each block <= H, the tallest close to H in [0.3, 0.4]
    assert (table[table.design == "nnnnnn"].status == "invalid").all()


def test_directory_criterion_reads_the_tables_of_one_provenance(tmp_path):
    for seed in (1, 2):
        table = exhaustive_terrain(seed, TINY, RULE, EvaluationCache(), None, designs=["wwwwww", "llllll"])
        write_committed(table, TINY, RULE, seconds=1.0, directory=tmp_path)
    per_terrain, totals = directory_criterion(tmp_path)
    assert list(per_terrain.terrain_seed) == [1, 2] and totals["terrains"] == 2
    assert totals["terrain"]["max_height_range"] == list(TINY.terrain.max_height_range)
    other = tmp_path / "blocks-2.json"
    other.write_text(json.dumps({**json.loads(other.read_text()), "physics_digest": "0" * 16}))
    with pytest.raises(InputError, match="blocks-2.parquet: measured under other settings"):
        directory_criterion(tmp_path)
    other.unlink()
    with pytest.raises(InputError, match="blocks-2.json is missing"):
        directory_criterion(tmp_path)
    with pytest.raises(InputError, match="no exhaustive tables"):
        directory_criterion(tmp_path / "empty")
