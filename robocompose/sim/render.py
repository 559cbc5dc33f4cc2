"""Headless pictures of designs with pybullet's CPU renderer (ER_TINY_RENDERER)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as pb

from robocompose.io.atomic import atomic_path

WIDTH, HEIGHT = 480, 360


def camera_image(client: int, target, distance: float, yaw: float = 35.0, pitch: float = -30.0,
                 width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """An RGB image (H, W, 3) uint8 looking at `target` from the front-left and above."""
    view = pb.computeViewMatrixFromYawPitchRoll(cameraTargetPosition=list(target), distance=distance,
                                                yaw=yaw, pitch=pitch, roll=0, upAxisIndex=2)
    proj = pb.computeProjectionMatrixFOV(fov=45, aspect=width / height, nearVal=0.01, farVal=50)
    _, _, rgba, _, _ = pb.getCameraImage(width, height, view, proj, renderer=pb.ER_TINY_RENDERER,
                                         lightDirection=[1, -1, 2], physicsClientId=client)
    return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]


def save_png(image: np.ndarray, path: str | Path) -> Path:
    from PIL import Image

    with atomic_path(path) as tmp:
        Image.fromarray(image).save(tmp, format="PNG")
    return Path(path)


def render_design(tree, path: str | Path, width: int = WIDTH, height: int = HEIGHT) -> Path:
    """Picture of a design resting on a floor, from the front-left and a little above, legs in view."""
    from robocompose.sim.builder import aabb, build_at_rest
    from robocompose.sim.physics import add_floor, connect

    client = connect()
    try:
        add_floor(client)
        robot = build_at_rest(tree, client, visual=True)
        lo, hi = aabb(robot.body, client)
        image = camera_image(client, (lo + hi) / 2, distance=1.1 * float(max(hi - lo)) + 0.35,
                             yaw=35.0, pitch=-18.0, width=width, height=height)
    finally:
        pb.disconnect(physicsClientId=client)
    return save_png(image, path)
