"""Recording an evaluation's trajectory: an MCAP log for Foxglove and an animated GIF.

Pass a `RolloutRecorder` as the `observer` of `robocompose.evaluation.evaluate.evaluate` (with
`visual=True` for pictures); after each control step it stores the world pose of every link frame, the
step's reward and, every `frame_every` steps, a camera image following the robot.

MCAP layout: `/scene` (logged right after the first `/tf`) holds the terrain (frame "world") and one
frame-locked entity per link (a capsule along the link frame's x axis); `/tf` moves the link frames ("link0"
is the root); `/reward` carries the mean per-step reward of each control step. Times are simulated
seconds, so the log is deterministic.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as pb

from robocompose.io import (
    McapWriter,
    atomic_path,
    capsule_primitives,
    cube_primitive,
    frame_transform,
    pose,
    scene_entity,
)
from robocompose.sim.builder import BODY_COLOR, LIMB_COLOR
from robocompose.sim.render import camera_image

_Z_TO_X = (0.0, np.sqrt(0.5), 0.0, np.sqrt(0.5))  # rotates a primitive's z axis onto the link's x axis
TERRAIN_COLOR = (0.75, 0.75, 0.72, 1.0)
# Camera (distance m, yaw deg, pitch deg) following the robot; on the wall task it looks down from above
# the 1 m walls, from inside the side walls (a side view would show only the side wall).
CAMERA = {"default": (1.4, 30.0, -20.0), "wall": (1.8, 30.0, -65.0)}


class RolloutRecorder:
    """Observer of an evaluation that keeps link poses, rewards and (optionally) GIF frames."""

    def __init__(self, step_seconds: float, frame_every: int = 2, image_size: tuple[int, int] = (320, 240),
                 images: bool = True):
        """`step_seconds`: simulated time of one control step (interval x time step)."""
        self.step_seconds, self.frame_every = step_seconds, frame_every
        self.image_size, self.images = image_size, images
        self.times: list[float] = []
        self.rewards: list[float] = []
        self.poses: list[list[tuple]] = []  # per step: (position, orientation) of each link frame
        self.frames: list[np.ndarray] = []
        self.scene: list[dict] = []

    def __call__(self, world, step: int, reward: float) -> None:
        if not self.scene:
            self.scene = _scene(world)
        self.times.append((step + 1) * self.step_seconds)
        self.rewards.append(reward)
        self.poses.append(link_frames(world))
        if self.images and step % self.frame_every == 0:
            position = self.poses[-1][0][0]
            width, height = self.image_size
            distance, yaw, pitch = CAMERA.get(world.task.name, CAMERA["default"])
            self.frames.append(camera_image(world.client, position, distance=distance, yaw=yaw, pitch=pitch,
                                            width=width, height=height))

    def write_mcap(self, path: str | Path) -> Path:
        with McapWriter(path) as log:
            for step, (t, frames, reward) in enumerate(zip(self.times, self.poses, self.rewards, strict=True)):
                log.frame_transforms(t, [frame_transform("world", f"link{i}", p, q) for i, (p, q) in enumerate(frames)])
                if step == 0:  # the scene after the first /tf, so the link frames it is locked to exist
                    log.scene_update(t, self.scene)
                log.scalars("/reward", t, {"reward": reward})
        return Path(path)

    def write_gif(self, path: str | Path) -> Path:
        from PIL import Image

        if not self.frames:
            raise ValueError(f"{path}: no frames were recorded (images off, or the episode had no steps)")
        images = [Image.fromarray(frame) for frame in self.frames]
        with atomic_path(path) as tmp:
            images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                           duration=round(1000 * self.step_seconds * self.frame_every), loop=0)
        return Path(path)


def link_frames(world) -> list[tuple]:
    """World (position, orientation) of each tree node's link frame (at its joint), in tree order."""
    client, body = world.client, world.body
    frames = []
    for node, pb_link in enumerate(world.robot.pb_link):
        if pb_link < 0:  # the base: pybullet reports its inertial frame, half a link ahead of the joint
            position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=client)
            length = world.tree.links()[node].length
            position, orientation = pb.multiplyTransforms(position, orientation, [-length / 2, 0, 0], [0, 0, 0, 1])
        else:
            state = pb.getLinkState(body, pb_link, computeForwardKinematics=True, physicsClientId=client)
            position, orientation = state[4], state[5]
        frames.append((tuple(position), tuple(orientation)))
    return frames


def _scene(world) -> list[dict]:
    """Terrain boxes in the world frame, and one capsule entity per link frame."""
    boxes = []
    for body in world.terrain:
        shape = pb.getCollisionShapeData(body, -1, physicsClientId=world.client)[0]
        half = np.array(shape[3]) / 2  # box dimensions (full extents)
        position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=world.client)
        boxes.append(cube_primitive(pose(position, orientation), 2 * half, TERRAIN_COLOR))
    entities = [scene_entity("terrain", "world", cubes=boxes, frame_locked=False)]
    for i, link in enumerate(world.tree.links()):
        color = BODY_COLOR if link.radius > 0.03 else LIMB_COLOR
        capsule = capsule_primitives(pose((link.length / 2, 0, 0), _Z_TO_X), link.radius, link.length, color)
        entities.append(scene_entity(f"link{i}", f"link{i}", **capsule))
    return entities
