"""The four RoboGrammar terrains as pybullet scenes (floors are boxes whose top is at height 0).

RoboGrammar's world is Y-up with z lateral; ours is Z-up. The conversion (x -> X, y -> Z, z -> -Y, a
proper rotation) is applied to every obstacle position so that the slalom of the wall task keeps its
handedness. Robots start with their front at x = 0 (`START_X`) and are rewarded for moving along +x.

| task        | floor (half x, half lateral) | friction | obstacles                                   |
|-------------|------------------------------|----------|---------------------------------------------|
| flat        | 40 x 10                      | 0.5      | -                                           |
| frozen_lake | 20 x 10                      | 0.05     | -                                           |
| ridged      | 20 x 10                      | 0.5      | 20 ridges, heights 0.02..0.40 m, ~1 m apart |
| wall        | 20 x 10                      | 0.5      | side walls at +-1 m, 10 slalom walls        |

Obstacle positions come from a generator seeded with 0 (`TERRAIN_SEED`), so a task is one fixed scene.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robocompose.io.errors import InputError, shown
from robocompose.sim.physics import add_floor

START_X = 0.0  # the robot's front starts here
TERRAIN_SEED = 0
OBSTACLE_COLOR = (0.55, 0.50, 0.45, 1.0)


@dataclass(frozen=True)
class Task:
    """A terrain: its floor, its friction and how much further ahead than usual the controller plans."""

    name: str
    floor_half_extents: tuple[float, float]  # (x, lateral) in m
    friction: float
    horizon_scale: int = 1  # MPPI horizon multiplier: the wall task plans 2 x 16 = 32 control steps


TASKS: dict[str, Task] = {
    "flat": Task("flat", (40.0, 10.0), 0.5),
    "frozen_lake": Task("frozen_lake", (20.0, 10.0), 0.05),
    "ridged": Task("ridged", (20.0, 10.0), 0.5),
    "wall": Task("wall", (20.0, 10.0), 0.5, horizon_scale=2),
}
TASK_NAMES = tuple(TASKS)


def get_task(name: str) -> Task:
    """The task called `name`; ValueError listing the known tasks otherwise."""
    try:
        return TASKS[name]
    except KeyError:
        raise InputError(f"unknown task {shown(name)}; known tasks: {list(TASKS)}") from None


def _box(client: int, half_extents, centre, friction: float) -> int:
    """A static box with the given (x, y, z) half-extents and centre, in world (Z-up) coordinates."""
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=client)
    visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=list(half_extents), rgbaColor=list(OBSTACLE_COLOR),
                                  physicsClientId=client)
    body = pb.createMultiBody(0, shape, visual, basePosition=list(centre), physicsClientId=client)
    pb.changeDynamics(body, -1, lateralFriction=friction, physicsClientId=client)
    return body


def obstacles(name: str) -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """(half-extents, centre) of each obstacle box of task `name`, in world (Z-up) coordinates."""
    rng = np.random.default_rng(TERRAIN_SEED)
    boxes = []
    if name == "ridged":
        for i in range(20):
            x = float(rng.normal(0.5, 0.1)) + i
            top = 0.02 * (i + 1)
            boxes.append(((0.1, 10.0, top / 2), (x, 0.0, top / 2)))
    elif name == "wall":
        for lateral in (-1.0, 1.0):  # side walls along x
            boxes.append(((20.0, 0.05, 0.5), (0.0, lateral, 0.5)))
        for i in range(10):
            x = float(rng.normal(2 * i + 0.5, 0.1))
            z = float(rng.normal((i % 2) - 0.5, 0.1))  # RoboGrammar's lateral z is our -y
            boxes.append(((0.05, 0.25, 0.5), (x, -z, 0.5)))
    return boxes


def build_terrain(task: Task, client: int) -> list[int]:
    """Add the task's floor and obstacles to `client`; returns their body ids (floor first)."""
    bodies = [add_floor(client, task.floor_half_extents, task.friction)]
    bodies += [_box(client, half, centre, task.friction) for half, centre in obstacles(task.name)]
    return bodies
