"""Rest-contact features (GLSO's property-predictor target), as GLSO's `collect_data.py` computes them.

1. Placement: the robot is built with its front edge (largest forward coordinate) at x = 0 and its
   lowest point on the floor (top at z = 0), its base on the lateral line y = 0, in a world of dt 1/24 s
   with a floor of friction 0.5. It rests for 10 steps with its motors holding their zero targets.
2. One point per contact pair: Bullet keeps one contact manifold per pair of touching collision
   objects (robot link and floor, or two robot links); GLSO reads the first point of each of the first
   8 manifolds, in Bullet's internal order, on the side of the manifold's first body (for a robot-floor
   pair the floor, added to the world first). pybullet lists contact points manifold by manifold in
   that order, so the first point of each (link, other body, other link) pair is it; we take it on the
   floor's side (on the robot's side it would lie up to ~2 cm under the floor: the coarse rest steps
   let links sink in) and on either side of a robot-robot pair.
3. Points off the floor (height above 1e-2 m: a robot-robot touch) are dropped, not the design.
4. The rest are (forward, lateral) in world metres x 10, **sorted by forward position** (the thesis:
   "sorted based on their x values"; GLSO's code leaves Bullet's manifold order, which its comment
   assumes is sorted), then padded to 8 points with (2.0, 0): every real point has x <= 0 (the front
   is at x = 0), so the padding lies beyond the data's range.
5. GLSO's rejection rule: fewer than 4 floor points (`too_few_contacts`), or a floor point on the
   mid-plane (|lateral| < 1e-2 m) away from the front (|x| > 1e-2 m) (`midline_contact`: the body drags
   on the ground). Before that, a design that self-penetrates when placed (`self_collision`) or whose
   rest state is not finite (`unstable`) is invalid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robocompose.grammar.tree import DesignTree
from robocompose.sim.builder import SELF_PENETRATION_TOLERANCE, build_at_rest
from robocompose.sim.physics import PhysicsSettings, add_floor, configure
from robocompose.sim.self_collision import capsule_self_penetrating

MAX_PAIRS = 8  # contact manifolds read (GLSO: the first 8)
MIN_POINTS = 4  # fewer floor points: invalid
ON_FLOOR = 1e-2  # m; a point higher than this is not on the floor (dropped)
MIDLINE = 1e-2  # m; |lateral| below this is on the mid-plane ...
FRONT = 1e-2  # m; ... and |forward| above this is away from the front
SCALE = 10.0
PAD_X = 2.0  # forward coordinate of a padding point (scaled); its lateral is 0
REST_SETTINGS = PhysicsSettings(time_step=1 / 24)  # coarse steps: only the resting pose matters
REST_STEPS = 10
FLOOR_FRICTION = 0.5
REASONS = ("self_collision", "unstable", "too_few_contacts", "midline_contact")  # checked in this order


@dataclass(frozen=True)
class ContactResult:
    """16 numbers (8 points x (forward, lateral), scaled x10, sorted by forward, padded), and validity."""

    features: np.ndarray  # (16,) float32
    n_points: int  # floor points kept
    dropped: int  # points of the first 8 pairs that were off the floor
    valid: bool
    reason: str  # "" when valid, else one of REASONS


def contact_vector(points: np.ndarray) -> np.ndarray:
    """(n, 2) floor points (forward, lateral) in metres, n <= 8 -> the (16,) feature vector."""
    order = np.lexsort((points[:, 1], points[:, 0])) if len(points) else np.zeros(0, dtype=np.int64)
    out = np.zeros((MAX_PAIRS, 2), dtype=np.float32)
    out[: len(points)] = points[order] * SCALE
    out[len(points):, 0] = PAD_X
    return out.ravel()


def rejection(points: np.ndarray) -> str:
    """GLSO's rule on the (n, 2) floor points (metres): "" if valid, else the reason."""
    if len(points) < MIN_POINTS:
        return "too_few_contacts"
    if ((np.abs(points[:, 0]) > FRONT) & (np.abs(points[:, 1]) < MIDLINE)).any():
        return "midline_contact"
    return ""


def pair_points(contacts: list) -> np.ndarray:
    """The first point (world x, y, z) of each of the first 8 contact pairs, in pybullet's order.

    `contacts` is `getContactPoints(bodyA=robot)`: a robot-world point is taken on the world's side
    (B), a robot-robot pair (listed from either side) on its A side.
    """
    seen, out = set(), []
    for c in contacts:
        body_a, body_b, link_a, link_b = c[1:5]
        own = body_b == body_a
        key = (body_b, *sorted((link_a, link_b))) if own else (body_b, link_a, link_b)
        if key not in seen:
            seen.add(key)
            out.append(c[5] if own else c[6])
            if len(out) == MAX_PAIRS:
                break
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def contact_features(tree: DesignTree, client: int, rest_self_penetrating: bool = True) -> ContactResult:
    """Rest the robot on a flat floor for 10 coarse steps and read its contact vector (see the module).

    With `rest_self_penetrating` False, a self-penetrating design is returned at once with padding
    features, decided by the static capsule test before anything is built (callers that reject it save the
    build and the rest steps).
    """
    empty = contact_vector(np.zeros((0, 2)))
    if not rest_self_penetrating and capsule_self_penetrating(tree.canonical_order(), SELF_PENETRATION_TOLERANCE):
        return ContactResult(empty, 0, 0, False, "self_collision")  # decided without building it
    configure(client, REST_SETTINGS)
    add_floor(client, friction=FLOOR_FRICTION)
    robot = build_at_rest(tree, client)
    for _ in range(REST_STEPS):
        pb.stepSimulation(physicsClientId=client)
    raw = pair_points(pb.getContactPoints(bodyA=robot.body, physicsClientId=client))
    if not np.isfinite(raw).all():
        return ContactResult(empty, 0, 0, False, "unstable")
    on_floor = np.abs(raw[:, 2]) <= ON_FLOOR
    # Rounded so that the sort does not hinge on the last bits of the solver.
    points = np.round(raw[on_floor, :2], 6)
    features, dropped = contact_vector(points), int((~on_floor).sum())
    reason = "self_collision" if robot.self_penetrating else rejection(points)
    return ContactResult(features, len(points), dropped, not reason, reason)
