import pybullet as pb
import pytest

from robocompose.sim.physics import connect
from robocompose.tasks.terrains import TASK_NAMES, build_terrain, get_task, obstacles


def _height_at(client: int, x: float, y: float) -> float:
    hit = pb.rayTest([x, y, 5.0], [x, y, -5.0], physicsClientId=client)[0]
    return hit[3][2]


def test_the_four_tasks_and_their_floors():
    assert TASK_NAMES == ("flat", "frozen_lake", "ridged", "wall")
    assert get_task("frozen_lake").friction == 0.05 and get_task("flat").friction == 0.5
    assert get_task("flat").floor_half_extents == (40.0, 10.0)
    assert get_task("wall").horizon_scale == 2 and get_task("flat").horizon_scale == 1
    with pytest.raises(ValueError, match="known tasks"):
        get_task("mars")


def test_ridges_rise_by_2_cm_about_every_metre():
    boxes = obstacles("ridged")
    assert len(boxes) == 20
    tops = [centre[2] + half[2] for half, centre in boxes]
    assert tops == pytest.approx([0.02 * (i + 1) for i in range(20)])
    assert all(abs(centre[0] - (i + 0.5)) < 0.5 for i, (_, centre) in enumerate(boxes))
    assert obstacles("ridged") == boxes  # one fixed scene


def test_wall_task_is_a_slalom_between_side_walls():
    boxes = obstacles("wall")
    sides, slalom = boxes[:2], boxes[2:]
    assert [c[1] for _, c in sides] == [-1.0, 1.0] and len(slalom) == 10
    lateral = [c[1] for _, c in slalom]
    assert all((y > 0) == (i % 2 == 0) for i, y in enumerate(lateral))  # alternating sides
    assert obstacles("flat") == [] and obstacles("frozen_lake") == []


def test_floor_top_is_at_zero_and_ridges_stand_on_it():
    client = connect()
    try:
        bodies = build_terrain(get_task("ridged"), client)
        assert len(bodies) == 21
        assert _height_at(client, -1.0, 0.0) == pytest.approx(0.0, abs=1e-6)
        (half, centre) = obstacles("ridged")[3]
        assert _height_at(client, centre[0], 0.0) == pytest.approx(0.08, abs=1e-6)
    finally:
        pb.disconnect(physicsClientId=client)
