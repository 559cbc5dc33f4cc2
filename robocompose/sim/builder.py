"""Design tree -> pybullet multibody, following RoboGrammar's robot model.

Each link is a capsule along its local x axis whose link frame sits at its joint (the near sphere
centre); a child's joint sits `joint_pos * L_parent` along the parent's x, rotated by the joint
rotation; hinge axes are in the child's frame. Link frames follow RoboGrammar's Y-up convention
(x forward, y up, z lateral) and the base is turned so that y is world up and the robot's head (its
local -x) faces world +x, the direction of travel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robocompose.grammar.tree import DesignTree

# Robot (Y-up) -> world (Z-up) rotation: x -> -X, y -> Z, z -> Y.
ROBOT_TO_WORLD = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
KP, KD, MAX_TORQUE = 0.01, 0.5, 1.0  # RoboGrammar's position-servo motors
LINK_FRICTION = 0.9
SELF_PENETRATION_TOLERANCE = 1e-3  # m; deeper overlap at placement means the design is invalid
_CAPSULE_ALONG_X = pb.getQuaternionFromEuler([0.0, np.pi / 2, 0.0])  # pybullet capsules lie along z


def _child_orientation(joint_rot) -> list[float]:
    """pybullet (x, y, z, w) orientation of a child frame in its parent's frame.

    RoboGrammar hands its joint rotation to Bullet as `rotParentToThis` (parent -> child vectors);
    pybullet wants the child frame in the parent frame, its inverse: the conjugate.
    """
    w, x, y, z = joint_rot
    return [-x, -y, -z, w]


def _matrix_to_xyzw(m: np.ndarray) -> list[float]:
    w = np.sqrt(max(0.0, 1 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    return [float(x), float(y), float(z), float(w)]


BASE_ORIENTATION = _matrix_to_xyzw(ROBOT_TO_WORLD)


@dataclass(frozen=True)
class BuiltRobot:
    """A robot in a pybullet world, built from `tree` (the canonical order of the design it was given)."""

    tree: DesignTree
    client: int
    body: int
    pb_link: tuple[int, ...]  # pybullet link index of each tree node (-1 for the root, the base)
    hinges: tuple[int, ...]  # pybullet joint indices of the actuated joints, in tree order
    self_penetrating: bool


def depth_first_order(tree: DesignTree) -> list[int]:
    """Tree nodes in depth-first pre-order: the order pybullet assigns link indices in."""
    order, stack = [], [0]
    while stack:
        node = stack.pop()
        order.append(node)
        stack.extend(reversed(tree.children(node)))
    return order


BODY_COLOR, LIMB_COLOR = (0.25, 0.45, 0.80, 1.0), (0.95, 0.55, 0.25, 1.0)


def build(tree: DesignTree, client: int, visual: bool = False,
          position=(0.0, 0.0, 0.0)) -> tuple[int, tuple[int, ...]]:
    """Create the multibody with its link frames, masses, motors and self-collision filter.

    Visual shapes (for pictures) double the build time, so they are made only when asked for.
    Returns the body id and the pybullet link index of each tree node. pybullet numbers links in
    depth-first order whatever order they are given in, so they are given in that order and checked.
    """
    order = depth_first_order(tree)
    pb_link = [0] * tree.n_links
    for k, node in enumerate(order):
        pb_link[node] = k - 1
    tree_links = tree.links()
    links = [tree_links[node] for node in order]
    shapes, visuals = [], []
    for link in links:
        shapes.append(pb.createCollisionShape(
            pb.GEOM_CAPSULE, radius=link.radius, height=link.length,
            collisionFramePosition=[link.length / 2, 0, 0], collisionFrameOrientation=_CAPSULE_ALONG_X,
            physicsClientId=client))
        visuals.append(pb.createVisualShape(
            pb.GEOM_CAPSULE, radius=link.radius, length=link.length,
            rgbaColor=list(BODY_COLOR if link.radius > 0.03 else LIMB_COLOR),
            visualFramePosition=[link.length / 2, 0, 0], visualFrameOrientation=_CAPSULE_ALONG_X,
            physicsClientId=client) if visual else -1)
    kinds = {"fixed": pb.JOINT_FIXED, "hinge": pb.JOINT_REVOLUTE}
    children = links[1:]
    body = pb.createMultiBody(
        baseMass=links[0].mass,
        baseCollisionShapeIndex=shapes[0],
        baseVisualShapeIndex=visuals[0],
        basePosition=list(position),
        baseOrientation=BASE_ORIENTATION,
        baseInertialFramePosition=[links[0].length / 2, 0, 0],
        linkMasses=[lk.mass for lk in children],
        linkCollisionShapeIndices=shapes[1:],
        linkVisualShapeIndices=visuals[1:],
        linkPositions=[[lk.joint_pos * tree_links[lk.parent].length, 0, 0] for lk in children],
        linkOrientations=[_child_orientation(lk.joint_rot) for lk in children],
        linkInertialFramePositions=[[lk.length / 2, 0, 0] for lk in children],
        linkInertialFrameOrientations=[[0, 0, 0, 1]] * len(children),
        linkParentIndices=[pb_link[lk.parent] + 1 for lk in children],  # 0 = the base
        linkJointTypes=[kinds[lk.joint_kind] for lk in children],
        linkJointAxis=[list(lk.joint_axis) for lk in children],
        flags=pb.URDF_USE_SELF_COLLISION,
        physicsClientId=client,
    )
    for i in range(-1, len(children)):
        pb.changeDynamics(body, i, lateralFriction=LINK_FRICTION, linearDamping=0.0, angularDamping=0.0,
                          jointDamping=0.0, physicsClientId=client)
    for k, lk in enumerate(children):
        if pb.getJointInfo(body, k, physicsClientId=client)[16] != pb_link[lk.parent]:
            raise RuntimeError("pybullet reordered the links of a design tree; the link map is wrong")
    _filter_self_collision(tree, body, client, pb_link)
    hinges = [pb_link[i] for i, lk in enumerate(tree_links) if lk.joint_kind == "hinge"]
    if hinges:
        pb.setJointMotorControlArray(
            body, hinges, pb.POSITION_CONTROL, targetPositions=[0.0] * len(hinges),
            targetVelocities=[0.0] * len(hinges), positionGains=[KP] * len(hinges),
            velocityGains=[KD] * len(hinges), forces=[MAX_TORQUE] * len(hinges), physicsClientId=client)
    return body, tuple(pb_link)


def _filter_self_collision(tree: DesignTree, body: int, client: int, pb_link: list[int]) -> None:
    """Hinge parent-child pairs and links in one rigid (fixed-joint) group do not collide."""
    links = tree.links()
    group = list(range(len(links)))  # rigid group representative of each link
    for i, lk in enumerate(links[1:], start=1):
        if lk.joint_kind == "fixed":
            group[i] = group[lk.parent]
    for i, lk in enumerate(links):
        for j in range(i):
            if group[i] == group[j] or lk.parent == j:
                pb.setCollisionFilterPair(body, body, pb_link[i], pb_link[j], 0, physicsClientId=client)


def place_on_floor(body: int, client: int, floor_top: float = 0.0, front_x: float = 0.0) -> None:
    """Move the robot so its lowest point rests on the floor and its front touches x = front_x."""
    lo, hi = aabb(body, client)
    pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=client)
    # getBasePositionAndOrientation gives the base's inertial frame; reset wants the same frame.
    shift = np.array([front_x - hi[0], 0.0, floor_top - lo[2]])
    pb.resetBasePositionAndOrientation(body, list(np.array(pos) + shift), orn, physicsClientId=client)


def aabb(body: int, client: int) -> tuple[np.ndarray, np.ndarray]:
    """World bounding box over all links."""
    n = pb.getNumJoints(body, physicsClientId=client)
    boxes = [pb.getAABB(body, i, physicsClientId=client) for i in range(-1, n)]
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)


def self_penetrating(body: int, client: int) -> bool:
    pb.performCollisionDetection(physicsClientId=client)
    return any(c[8] < -SELF_PENETRATION_TOLERANCE
               for c in pb.getContactPoints(body, body, physicsClientId=client))


def build_at_rest(tree: DesignTree, client: int, floor_top: float = 0.0, front_x: float = 0.0,
                  visual: bool = False) -> BuiltRobot:
    """Build the robot in `client`, resting on the floor with its front at `front_x`.

    The design is built in its canonical order, so every ordering of its siblings gives one robot;
    `pb_link` and `hinges` index the nodes of `BuiltRobot.tree`.
    """
    tree = tree.canonical_order()
    body, pb_link = build(tree, client, visual=visual)
    place_on_floor(body, client, floor_top, front_x)
    hinges = tuple(pb_link[i] for i, lk in enumerate(tree.links()) if lk.joint_kind == "hinge")
    return BuiltRobot(tree, client, body, pb_link, hinges, self_penetrating(body, client))
