"""Rollout logs of modular designs: MCAP with Foxglove schemas (plays in Foxglove's 3D panel) and animated GIFs.

MCAP layout: `/scene` (logged right after the first `/tf`, at t = 0) with the terrain blocks (world frame) and
every link's primitives (frame-locked to `link<i>`, the chassis is `link-1`); `/tf` every control step with
world -> link<i> transforms; `/robot` scalars (chassis x, y, z and up-axis z) every control step.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as pb

from robocompose.io import (
    McapWriter,
    atomic_path,
    cube_primitive,
    cylinder_primitive,
    frame_transform,
    pose,
    scene_entity,
    sphere_primitive,
)
from robocompose.modular.evaluate import EvalSettings, Result, rollout, up_z
from robocompose.modular.robot import ModularRobot
from robocompose.modular.terrain import Terrain, generate_terrain

GIF_EVERY = 5  # control steps per GIF frame (12 frames per simulated second at 20 sim steps / control step)
GIF_SIZE = (320, 240)


def link_poses(robot: ModularRobot) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(link index, (3,) position, (4,) quaternion) of every link frame in the world, the chassis (-1) first."""
    position, orientation = pb.getBasePositionAndOrientation(robot.body, physicsClientId=robot.client)
    poses = [(-1, np.array(position), np.array(orientation))]
    n = pb.getNumJoints(robot.body, physicsClientId=robot.client)
    if n:
        states = pb.getLinkStates(robot.body, list(range(n)), physicsClientId=robot.client)
        poses += [(i, np.array(s[4]), np.array(s[5])) for i, s in enumerate(states)]
    return poses


def _primitives(shapes) -> dict[str, list]:
    out = {"cubes": [], "spheres": [], "cylinders": []}
    for s in shapes:
        at = pose(s["position"], s["orientation"])
        if s["geom"] == pb.GEOM_BOX:
            out["cubes"].append(cube_primitive(at, [2 * h for h in s["half_extents"]], s["color"]))
        elif s["geom"] == pb.GEOM_SPHERE:
            out["spheres"].append(sphere_primitive(at, [2 * s["radius"]] * 3, s["color"]))
        else:  # pybullet cylinders and Foxglove's both lie along their frame's z
            out["cylinders"].append(cylinder_primitive(at, [2 * s["radius"], 2 * s["radius"], s["length"]],
                                                       s["color"]))
    return out


def terrain_entity(terrain: Terrain) -> dict:
    cubes = [cube_primitive(pose((c[0], c[1], h / 2)), (2 * s[0], 2 * s[1], h), (0.55, 0.45, 0.35, 1))
             for c, s, h in zip(terrain.centers, terrain.half_sides, terrain.heights, strict=True) if h > 1e-4]
    return scene_entity("terrain", "world", cubes=cubes, frame_locked=False)


def record_rollout(design: str, terrain_seed: int, settings: EvalSettings, mcap: str | Path | None = None,
                   gif: str | Path | None = None) -> Result:
    """Simulate like `rollout` and write the MCAP log and/or GIF; the result equals the unrecorded rollout's."""
    terrain = generate_terrain(terrain_seed, settings.terrain)
    frames: list[np.ndarray] = []
    steps = [0]

    def on_step(t: float, robot: ModularRobot) -> None:
        if log is not None:
            poses = link_poses(robot)
            log.frame_transforms(t, [frame_transform("world", f"link{i}", p, q) for i, p, q in poses])
            if steps[0] == 0:  # the scene after the first /tf, so the link frames it is locked to exist
                entities = [terrain_entity(terrain)]
                entities += [scene_entity(f"link{i}", f"link{i}", **_primitives(shapes))
                             for i, shapes in enumerate(robot.link_shapes, start=-1)]
                log.scene_update(t, entities)
            position, orientation = poses[0][1], poses[0][2]
            log.scalars("/robot", t, {"x": position[0], "y": position[1], "z": position[2],
                                      "up_z": up_z(orientation)})
        if gif is not None and steps[0] % GIF_EVERY == 0:
            from robocompose.sim.render import camera_image

            target = link_poses(robot)[0][1]
            frames.append(camera_image(robot.client, target, distance=1.8, yaw=30.0, pitch=-25.0,
                                       width=GIF_SIZE[0], height=GIF_SIZE[1]))
        steps[0] += 1

    if mcap is not None:
        with McapWriter(mcap) as log:
            result = rollout(design, terrain, settings, visual=gif is not None, on_step=on_step)
    else:
        log = None
        result = rollout(design, terrain, settings, visual=gif is not None, on_step=on_step)
    if gif is not None:
        save_gif(frames, gif)
    return result


def save_gif(frames: list[np.ndarray], path: str | Path, fps: float = 12.0) -> Path:
    from PIL import Image

    images = [Image.fromarray(f) for f in frames]
    with atomic_path(path) as tmp:
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    return Path(path)
