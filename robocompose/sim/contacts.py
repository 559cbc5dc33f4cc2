"""Rest-contact features (GLSO's property-predictor target): where a robot touches flat ground at rest."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robocompose.grammar.tree import DesignTree
from robocompose.sim.builder import build_at_rest
from robocompose.sim.physics import PhysicsSettings, add_floor, configure

MAX_POINTS = 8
MIN_POINTS = 4
ON_FLOOR = 1e-2  # m; a robot-floor contact point higher than this means the rest state is broken
SCALE = 10.0
PAD = (2.0, 0.0)  # padding point (scaled units)
REST_SETTINGS = PhysicsSettings(time_step=1 / 24)  # coarse steps: only the resting pose matters
REST_STEPS = 10
FLOOR_FRICTION = 0.5


@dataclass(frozen=True)
class ContactResult:
    """16 numbers (8 points x (forward, lateral), scaled x10, sorted by forward, padded), and validity."""

    features: np.ndarray  # (16,) float32
    n_points: int
    valid: bool
    reason: str  # "" when valid, else why not


def contact_features(tree: DesignTree, client: int, rest_self_penetrating: bool = True) -> ContactResult:
    """Rest the robot on a flat floor for 10 coarse steps and read its ground contacts.

    Points are the 2D contact locations on the ground (forward x, lateral y), relative to the root
    link's centre of mass, in metres x 10, sorted by x (the thesis's contact vector). A design is valid
    when it does not self-penetrate, its rest state is finite, it touches the ground at >= 4 points and
    every contact lies on the floor plane. With `rest_self_penetrating` False, a self-penetrating design
    is returned at once with padding features (callers that reject it save the rest steps).
    """
    configure(client, REST_SETTINGS)
    floor = add_floor(client, friction=FLOOR_FRICTION)
    robot = build_at_rest(tree, client)
    if robot.self_penetrating and not rest_self_penetrating:
        return ContactResult(np.tile(np.float32(PAD), MAX_POINTS), 0, False, "self_collision")
    for _ in range(REST_STEPS):
        pb.stepSimulation(physicsClientId=client)
    ref = np.array(pb.getBasePositionAndOrientation(robot.body, physicsClientId=client)[0])
    raw = np.array([c[6] for c in pb.getContactPoints(robot.body, floor, physicsClientId=client)]).reshape(-1, 3)
    if not np.isfinite(raw).all() or not np.isfinite(ref).all():
        return ContactResult(np.tile(np.float32(PAD), MAX_POINTS), 0, False, "unstable")
    off_floor = bool((np.abs(raw[:, 2]) > ON_FLOOR).any())
    # Rounded before sorting so that the order does not hinge on the last bits of the solver.
    points = sorted((round(x - ref[0], 6), round(y - ref[1], 6)) for x, y, _ in raw)[:MAX_POINTS]
    feats = np.tile(np.array(PAD, dtype=np.float32), MAX_POINTS)
    if points:
        feats[: 2 * len(points)] = (np.array(points) * SCALE).ravel()
    if robot.self_penetrating:
        return ContactResult(feats, len(points), False, "self_collision")
    if len(points) < MIN_POINTS:
        return ContactResult(feats, len(points), False, "too_few_contacts")
    if off_floor:
        return ContactResult(feats, len(points), False, "contact_off_floor")
    return ContactResult(feats, len(points), True, "")
