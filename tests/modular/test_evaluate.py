import math

import numpy as np
import pytest

from robocompose.fanout.cache import EvaluationCache
from robocompose.modular.evaluate import (
    EvalSettings,
    FitnessRule,
    chunk_size,
    evaluate_designs,
    rollout,
    rollouts,
    task_id,
    up_z,
)
from robocompose.modular.terrain import TerrainConfig, generate_terrain

SHORT = EvalSettings(control_steps=36)  # 3 s episodes
FLAT = TerrainConfig(max_height_range=(0.0, 0.0))


def flat_rollout(design: str, settings: EvalSettings = SHORT):
    return rollout(design, generate_terrain(0, FLAT), settings)


def test_six_wheels_travel_farther_than_an_empty_chassis_on_flat_ground():
    wheels, empty = flat_rollout("wwwwww"), flat_rollout("nnnnnn")
    assert wheels.status == "ok" and wheels.distance > 2.0  # ~0.9 m/s at the X8-3's rated speed
    assert empty.status == "stalled" and abs(empty.distance) < 0.01


def test_wheels_spinning_backwards_drive_the_robot_backwards():
    backwards = flat_rollout("wwwwww", EvalSettings(control_steps=36, controller="tripod_reversed_wheels"))
    assert backwards.distance < -2.0


def test_the_tripod_gait_walks_six_legs_forward_on_flat_ground():
    legs = flat_rollout("llllll")
    assert legs.status == "ok" and 0.3 < legs.distance < 3.0


def test_on_flat_ground_wheels_win_and_on_rough_ground_legs_do():
    # The default profile's episode (50 control steps, 4.2 s) on its course. Measured: flat ground, six wheels
    # 3.78 m and six legs 1.47 m; all blocks 16 cm high (seeds 0 and 11), six wheels stall at 0.38 / 0.41 m
    # while six legs walk 1.16 / 1.28 m.
    course = (-1.0, 5.0)
    settings = EvalSettings(control_steps=50, terrain=TerrainConfig(x_range=course, max_height_range=(0.0, 0.0)))
    flat = generate_terrain(0, settings.terrain)
    assert rollout("wwwwww", flat, settings).distance > 2 * rollout("llllll", flat, settings).distance
    rough = TerrainConfig(x_range=course, max_height_range=(0.16, 0.16))
    for seed in (0, 11):
        wheels = rollout("wwwwww", generate_terrain(seed, rough), settings)
        legs = rollout("llllll", generate_terrain(seed, rough), settings)
        assert wheels.status == "stalled" and legs.distance > 2 * wheels.distance


def test_rollouts_are_deterministic():
    a, b = flat_rollout("lwbnlw"), flat_rollout("lwbnlw")
    assert (a.distance, a.status, a.sim_steps) == (b.distance, b.status, b.sim_steps)


ROUGH = EvalSettings(control_steps=12, terrain=TerrainConfig(x_range=(-1.0, 5.0), max_height_range=(0.2, 0.2)))


def _outcome(result):
    return result.distance, result.status, result.sim_steps


def test_rollouts_in_one_client_equal_rollouts_each_in_a_fresh_client_in_any_order():
    # One client per work item: each design's world is reset and rebuilt, so a robot swapped in after others
    # moves exactly as it does alone (removeBody instead of the reset does not; see `rollouts`).
    terrain = generate_terrain(3, ROUGH.terrain)
    designs = ["bbbbbb", "lwbllw", "wnwwnw"]
    alone = [_outcome(rollout(d, terrain, ROUGH)) for d in designs]
    assert [_outcome(r) for r in rollouts(designs, terrain, ROUGH)] == alone
    assert [_outcome(r) for r in rollouts(designs[::-1], terrain, ROUGH)] == alone[::-1]
    assert len(set(alone)) == len(designs)  # the designs differ, so a leaked world would show


def test_work_items_keep_eight_per_worker_when_a_batch_is_small():
    assert chunk_size(1296, 2) == 8 and chunk_size(48, 2) == 3 and chunk_size(10, 2) == 1 and chunk_size(0, 2) == 1


def test_a_stalled_robot_stops_after_the_stall_window():
    empty = flat_rollout("nnnnnn")
    assert empty.sim_steps == SHORT.settle_steps + (SHORT.stall_window + 1) * SHORT.sim_steps_per_control


def test_up_axis_of_a_flipped_body_points_down():
    assert up_z(np.array([0, 0, 0, 1.0])) == pytest.approx(1.0)
    assert up_z(np.array([1.0, 0, 0, 0])) == pytest.approx(-1.0)  # rolled by pi
    assert up_z(np.array([math.sin(math.pi / 4), 0, 0, math.cos(math.pi / 4)])) == pytest.approx(0.0, abs=1e-12)


def test_settings_hash_covers_the_terrain_ranges():
    assert SHORT.settings_hash() != EvalSettings(control_steps=36, terrain=FLAT).settings_hash()
    assert SHORT.settings_hash() == EvalSettings(control_steps=36).settings_hash()


@pytest.mark.parametrize("module, name, value", [
    ("robocompose.modular.robot", "WHEEL_RADIUS", 0.2),  # robot constants
    ("robocompose.modular.robot", "FRICTION", 0.5),
    ("robocompose.modular.robot", "CHASSIS_MASS", 9.0),
    ("robocompose.modular.terrain", "CHUNK", 8),  # how the terrain's boxes are built
    ("robocompose.modular.evaluate", "BLOWUP_SPEED", 40.0),
])
def test_settings_hash_changes_with_every_constant_that_shapes_a_rollout(monkeypatch, module, name, value):
    import importlib

    before = SHORT.settings_hash()
    monkeypatch.setattr(importlib.import_module(module), name, value)
    assert SHORT.settings_hash() != before


def test_settings_hash_covers_gait_gravity_damping_and_code(monkeypatch):
    import dataclasses

    import robocompose.modular.controller as controller
    import robocompose.modular.evaluate as modular_evaluate
    import robocompose.sim.physics as physics

    before = SHORT.settings_hash()
    slow = dataclasses.replace(controller.TripodGait(), period=2.0)
    monkeypatch.setattr(controller.TripodController.__init__, "__defaults__", (slow,))
    assert SHORT.settings_hash() != before
    monkeypatch.undo()
    for field, value in (("gravity", -9.0), ("link_damping", 0.04)):
        monkeypatch.setattr(physics.PhysicsSettings, field, value)  # the dataclass default of that field
        monkeypatch.setattr(physics.PhysicsSettings.__init__, "__defaults__", tuple(
            value if f.name == field else getattr(physics.PhysicsSettings, f.name)
            for f in dataclasses.fields(physics.PhysicsSettings)))
        assert SHORT.settings_hash() != before
        monkeypatch.undo()
    monkeypatch.setattr(modular_evaluate, "result_digest", lambda *entries: "changed-source")
    assert SHORT.settings_hash() != before


def test_batch_evaluation_goes_through_the_cache_and_skips_invalid_designs(tmp_path):
    cache = EvaluationCache(tmp_path / "cache.parquet")
    rule = FitnessRule()
    settings = EvalSettings(control_steps=12)
    designs = ["wwwwww", "nnnnnn", "wwwwww", "lnllnl"]  # nnnnnn: invalid in the original
    first = evaluate_designs(designs, 5, settings, rule, cache)
    assert [r.status for r in first][1] == "invalid" and rule.fitness(first[1]) == -10.0
    assert len(cache) == 2  # each distinct simulated design once; invalid ones are not cached
    assert first[0] == first[2]
    key = ("wwwwww", task_id(5), settings.settings_hash(), 0)
    assert cache.get(key)["reward"] == first[0].distance
    again = evaluate_designs(designs, 5, settings, rule, EvaluationCache(tmp_path / "cache.parquet"))
    assert again == first  # read back from the parquet file, seconds included
    simulated = evaluate_designs(["nnnnnn"], 5, settings, FitnessRule(invalid="simulate"), cache)[0]
    assert simulated.status == "ok" and abs(simulated.distance) < 0.01  # simulated: an empty chassis stays put


def test_unknown_controller_and_bad_rule_are_rejected():
    with pytest.raises(ValueError, match="controller"):
        EvalSettings(controller="neural")
    with pytest.raises(ValueError, match="invalid"):
        FitnessRule(invalid="ignore")
