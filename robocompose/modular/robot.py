"""Modular robots of thesis 5.1 in pybullet: a chassis with 6 ports, each empty or carrying a leg, a wheel or a
leg-wheel module (HEBI X-series actuators).

A design is a 6-letter port string over `n` (none), `l` (leg), `w` (wheel), `b` (both: leg-wheel), one letter
per port in the order front-left, mid-left, back-left, back-right, mid-right, front-right; 4^6 = 4096 designs.

Frames (world z up, the robot faces +x, its left is +y). Port k (k = 1, 3, ..., 11 in port order) sits at
angle k*pi/6 on the chassis rim; its *mount frame* is the chassis frame yawed by k*pi/6 - pi/2, so the mount's
x is tangential and its y points radially outward (as in the reference's mounting yaw).
- Leg: the base joint turns about mount z; at base angle pi/2 the leg points radially out (limits
  [pi/6, 5pi/6]). The leg frame has x along the leg; the shoulder lifts the leg for positive angles
  (limits [-pi/4, pi/4]); the elbow (limits [0.785, 2.356]) points the lower link straight down at pi/2.
- Wheel: the steering joint turns about mount -z (the actuator faces down, so a positive angle yaws the
  wheel clockwise), limits [-pi/3, pi/3]; the drive spins the wheel about the radial axis.
- Leg-wheel: the leg's three joints, a 0.175 m lower link, a drive about the leg's radial axis and the wheel.

Geometry the reference does not give, chosen here: the chassis is a disc reaching the ports (radius 0.176 m,
0.04 m thick); brackets are boxes; the wheel bracket drops the axle 0.185 m below the port so that every module
type holds the chassis at about the same height (foot 0.295 m, wheel 0.29 m, leg-wheel 0.28 m below the ports).
Masses sit where the parts are: every primitive of a link (actuator housing, bracket, link tube, foot, wheel)
carries its part's mass, and each link's inertial frame is its parts' centre of mass, its inertia the parts'
(solid cylinders, boxes and spheres, moved there by the parallel-axis theorem) along its principal axes. An
actuator's housing belongs to the link it is bolted to (the elbow X5-9 to the upper leg link, 0.275 m from the
shoulder). The chassis keeps the reference's mass and inertia about its centre.
Joint limits are enforced on the targets (`ModularRobot.command` clips), since pybullet's createMultiBody takes
none; joint damping is the reference's damping/friction figure, applied as pybullet joint damping.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robocompose.io.errors import InputError

MODULE_LETTERS = "nlwb"  # none, leg, wheel, leg-wheel (both)
N_PORTS = 6
PORT_NAMES = ("front-left", "mid-left", "back-left", "back-right", "mid-right", "front-right")
PORT_ANGLES = tuple(k * math.pi / 6 for k in (1, 3, 5, 7, 9, 11))  # rad, angle of each port on the rim
PORT_XY = tuple((0.1524 * s, 0.0880 * t) for s, t in ((1, 1), (0, 2), (-1, 1), (-1, -1), (0, -2), (1, -1)))
LEFT_SIDE = (True, True, True, False, False, False)

CHASSIS_MASS = 3.4  # kg
CHASSIS_INERTIA = (0.02, 0.02, 0.05)  # kg m^2, diagonal
CHASSIS_RADIUS, CHASSIS_THICKNESS = 0.176, 0.04  # m (our choice: a disc reaching the ports)
START_HEIGHT = 0.3  # m, chassis centre at the start


@dataclass(frozen=True)
class Actuator:
    """A HEBI X-series actuator: housing mass, rated torque and speed, joint damping, collision cylinder."""

    name: str
    mass: float  # kg
    torque: float  # N m, rated
    speed: float  # rad/s, rated
    damping: float  # N m s/rad
    length: float  # m, collision cylinder length (radius ACTUATOR_RADIUS)

    @property
    def max_force(self) -> float:
        return TORQUE_FRACTION * self.torque


TORQUE_FRACTION = 0.8  # torques are capped at 0.8 x the rating
ACTUATOR_RADIUS = 0.035
X5_9 = Actuator("X5-9", 0.360, 13.0, 1.466, 0.1, 0.025)
X8_3 = Actuator("X8-3", 0.460, 7.0, 8.796, 0.5, 0.04)
X8_9 = Actuator("X8-9", 0.480, 20.0, 3.14, 0.5, 0.04)
X8_16 = Actuator("X8-16", 0.500, 38.0, 1.571, 0.5, 0.04)

BRACKET_MASS = 0.215  # kg
LINK_LENGTH, LEGWHEEL_LINK_LENGTH = 0.275, 0.175  # m
LINK_RADIUS = 0.016  # m
FOOT_RADIUS, FOOT_MASS = 0.02, 0.01
WHEEL_RADIUS, WHEEL_WIDTH, WHEEL_MASS = 0.105, 0.0254, 0.498
SHOULDER_OFFSET = 0.09  # m, base joint -> shoulder joint along the leg (bracket)
WHEEL_DROP = 0.185  # m, port -> wheel axle, downwards (wheel module bracket)
WHEEL_OUT = 0.06  # m, port -> drive actuator, radially out (wheel module bracket)
AXLE_OFFSET = 0.045  # m, drive actuator -> wheel centre along the axle

FRICTION = {"chassis": 1.2, "foot": 1.2, "wheel": 1.0, "link": 0.8}  # lateral friction by link kind
WHEEL_ANISOTROPY = (0.8, 0.8, 1.8)  # friction scale along the wheel link's x, y, z (z = axle)

BASE_LIMITS = (math.pi / 6, 5 * math.pi / 6)
SHOULDER_LIMITS = (-math.pi / 4, math.pi / 4)
ELBOW_LIMITS = (0.785, 2.356)
STEER_LIMITS = (-math.pi / 3, math.pi / 3)
POSITION_GAIN, VELOCITY_GAIN = 0.1, 1.0  # pybullet's position-servo gains, written out

# Joint roles, in the order each module's joints are created (drive last).
MODULE_JOINTS = {"n": (), "l": ("base", "shoulder", "elbow"), "w": ("steer", "drive"),
                 "b": ("base", "shoulder", "elbow", "drive")}
ROLE_ACTUATOR = {"base": X8_9, "shoulder": X8_16, "elbow": X5_9, "steer": X5_9, "drive": X8_3}
ROLE_LIMITS = {"base": BASE_LIMITS, "shoulder": SHOULDER_LIMITS, "elbow": ELBOW_LIMITS, "steer": STEER_LIMITS,
               "drive": (-math.inf, math.inf)}
# Rest pose of each position-controlled joint (the pose the robot is built and settled in).
ROLE_REST = {"base": math.pi / 2, "shoulder": 0.0, "elbow": math.pi / 2, "steer": 0.0, "drive": 0.0}


def parse_design(design: str) -> str:
    """Check a port string (6 letters of n/l/w/b) and return it lower-cased."""
    if not isinstance(design, str) or len(design) != N_PORTS or any(c not in MODULE_LETTERS for c in design.lower()):
        raise InputError(f"design {design!r}: expected {N_PORTS} letters of {MODULE_LETTERS!r} (none/leg/wheel/"
                         f"leg-wheel), one per port in the order {', '.join(PORT_NAMES)}")
    return design.lower()


def valid_in_original(design: str) -> bool:
    """The original's validity rule: at most two empty ports, and none at ports 1, 3, 4 or 6 (the corners)."""
    design = parse_design(design)
    return design.count("n") <= 2 and all(design[i] != "n" for i in (0, 2, 3, 5))


def all_designs() -> list[str]:
    """All 4096 port strings, in lexicographic order of module index (n < l < w < b) per port."""
    import itertools

    return ["".join(p) for p in itertools.product(MODULE_LETTERS, repeat=N_PORTS)]


def mirror(design: str) -> str:
    """The left-right mirror image: ports front-left..front-right reversed (front-left <-> front-right, ...)."""
    return design[::-1]


def design_to_index(design: str) -> np.ndarray:
    """(6,) module indices 0..3 of a port string."""
    return np.array([MODULE_LETTERS.index(c) for c in parse_design(design)], dtype=np.int64)


def index_to_design(indices) -> str:
    return "".join(MODULE_LETTERS[int(i)] for i in indices)


@dataclass(frozen=True)
class Joint:
    """One actuated joint of a built robot."""

    index: int  # pybullet joint index
    port: int  # 0..5
    module: str  # module letter
    role: str  # base / shoulder / elbow / steer / drive
    actuator: Actuator
    limits: tuple[float, float]


@dataclass(frozen=True)
class ModularRobot:
    """A design built in a pybullet client."""

    client: int
    body: int
    design: str
    joints: tuple[Joint, ...]
    link_kinds: tuple[str, ...]  # kind of each pybullet link (chassis, actuator, link, foot, wheel), -1 first
    link_shapes: tuple[tuple[dict, ...], ...]  # primitives of each link in its link frame, -1 first (for logs)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(J,) positions and (J,) velocities of the actuated joints."""
        if not self.joints:
            return np.zeros(0), np.zeros(0)
        states = pb.getJointStates(self.body, [j.index for j in self.joints], physicsClientId=self.client)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    @functools.cached_property
    def target_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(J,) lower and (J,) upper bounds of the targets: joint limits for positions, +-rated speed for drives."""
        bounds = [(-j.actuator.speed, j.actuator.speed) if j.role == "drive" else j.limits for j in self.joints]
        return np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])

    def command(self, targets: np.ndarray, sent: np.ndarray | None = None) -> np.ndarray:
        """Send (J,) targets: positions (clipped to the joint limits) for joints, velocities for drives; returns the
        (J,) targets as sent.

        Positions are servoed at up to the actuator's rated speed; drives are velocity-controlled, with
        velocities clipped to the rated speed. Forces are capped at 0.8 x the rated torque. `sent`, the return
        value of the previous call: joints whose target has not changed since are skipped, since a pybullet
        motor keeps its command until the next (the bytes of a rollout are the same either way).
        """
        clipped = np.clip(targets, *self.target_bounds)
        for k, (joint, target) in enumerate(zip(self.joints, clipped.tolist(), strict=True)):
            if sent is not None and target == sent[k]:
                continue
            act = joint.actuator
            if joint.role == "drive":
                pb.setJointMotorControl2(self.body, joint.index, pb.VELOCITY_CONTROL, targetVelocity=target,
                                         force=act.max_force, physicsClientId=self.client)
            else:
                pb.setJointMotorControl2(self.body, joint.index, pb.POSITION_CONTROL, targetPosition=target,
                                         targetVelocity=0.0, positionGain=POSITION_GAIN, velocityGain=VELOCITY_GAIN,
                                         force=act.max_force, maxVelocity=act.speed, physicsClientId=self.client)
        return clipped

    def pose(self, targets: np.ndarray) -> np.ndarray:
        """Put the joints at (J,) `targets` (clipped to limits; drives at rest) and hold them there; returns the
        (J,) targets as sent (see `command`)."""
        held = np.array([0.0 if j.role == "drive" else np.clip(t, *j.limits)
                         for j, t in zip(self.joints, targets, strict=True)])
        for joint, position in zip(self.joints, held, strict=True):
            if joint.role != "drive":
                pb.resetJointState(self.body, joint.index, float(position), physicsClientId=self.client)
        return self.command(held)

    def rest_targets(self) -> np.ndarray:
        """(J,) targets of the rest pose (drives at rest)."""
        return np.array([ROLE_REST[j.role] for j in self.joints])


# --- building ---


@dataclass
class _Link:
    """One link to create: its joint to the parent and its shapes (pybullet shape arrays)."""

    parent: int  # index into the link list (0 = chassis)
    position: tuple[float, float, float]  # joint origin in the parent link frame
    orientation: tuple[float, float, float, float]  # link frame in the parent link frame (x, y, z, w)
    axis: tuple[float, float, float]  # joint axis in this link's frame
    joint_type: int
    kind: str
    shapes: list[dict]  # one primitive each: geom, size, position, orientation, color, mass (its part's, kg)
    role: str | None = None  # actuated joint role, None for fixed
    port: int = -1
    module: str = "n"

    @property
    def mass(self) -> float:
        return sum(s["mass"] for s in self.shapes)


_QUAT_Y_TO_Z = tuple(pb.getQuaternionFromEuler([math.pi / 2, 0, 0]))  # a z-axis primitive lying along y
_QUAT_X_TO_Z = tuple(pb.getQuaternionFromEuler([0, math.pi / 2, 0]))  # a z-axis primitive lying along x
_IDENTITY = (0.0, 0.0, 0.0, 1.0)
COLORS = {"chassis": (0.25, 0.45, 0.80, 1), "actuator": (0.85, 0.15, 0.15, 1), "link": (0.6, 0.6, 0.6, 1),
          "foot": (0.1, 0.1, 0.1, 1), "wheel": (0.15, 0.15, 0.15, 1), "bracket": (0.7, 0.7, 0.7, 1)}


def _cylinder(radius: float, length: float, mass: float, position, orientation=_IDENTITY,
              kind: str = "actuator") -> dict:
    return {"geom": pb.GEOM_CYLINDER, "radius": radius, "length": length, "position": position,
            "orientation": orientation, "color": COLORS[kind], "mass": mass}


def _actuator(actuator: Actuator, position, orientation=_IDENTITY) -> dict:
    """An actuator's housing: a cylinder of its collision size and mass."""
    return _cylinder(ACTUATOR_RADIUS, actuator.length, actuator.mass, position, orientation)


def _box(half_extents, mass: float, position, kind: str = "bracket") -> dict:
    return {"geom": pb.GEOM_BOX, "half_extents": half_extents, "position": position, "orientation": _IDENTITY,
            "color": COLORS[kind], "mass": mass}


def _sphere(radius: float, mass: float, position, kind: str = "foot") -> dict:
    return {"geom": pb.GEOM_SPHERE, "radius": radius, "position": position, "orientation": _IDENTITY,
            "color": COLORS[kind], "mass": mass}


def _solid_inertia(shape: dict) -> np.ndarray:
    """(3, 3) inertia of a uniform solid primitive about its centre, in its own frame (cylinders along z)."""
    m = shape["mass"]
    if shape["geom"] == pb.GEOM_CYLINDER:
        r, length = shape["radius"], shape["length"]
        side = m * (3 * r * r + length * length) / 12
        return np.diag([side, side, m * r * r / 2])
    if shape["geom"] == pb.GEOM_BOX:
        a, b, c = shape["half_extents"]
        return np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 3
    return np.eye(3) * (2 / 5 * m * shape["radius"] ** 2)  # sphere


def inertial_frame(shapes: list[dict]) -> tuple[np.ndarray, tuple[float, float, float, float], np.ndarray]:
    """A link's inertial frame from its parts: (3,) centre of mass and principal-axes quaternion (x, y, z, w) in
    the link frame, and the (3,) principal moments.

    Each part's inertia is rotated into the link frame and moved to the common centre of mass by the parallel-axis
    theorem; the sum's eigenvectors are the principal axes.
    """
    from scipy.spatial.transform import Rotation

    masses = np.array([s["mass"] for s in shapes])  # (P,)
    positions = np.array([s["position"] for s in shapes], dtype=np.float64)  # (P, 3)
    com = masses @ positions / masses.sum()
    inertia = np.zeros((3, 3))
    for shape, mass, position in zip(shapes, masses, positions, strict=True):
        rotation = np.array(pb.getMatrixFromQuaternion(shape["orientation"])).reshape(3, 3)
        d = position - com
        inertia += rotation @ _solid_inertia(shape) @ rotation.T + mass * (d @ d * np.eye(3) - np.outer(d, d))
    if np.allclose(inertia, np.diag(np.diag(inertia)), rtol=0, atol=1e-12):
        return com, _IDENTITY, np.diag(inertia).copy()  # already principal (keeps symmetric parts unrotated)
    moments, axes = np.linalg.eigh(inertia)  # columns of `axes` are the principal axes
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1  # a proper rotation
    return com, tuple(float(v) for v in Rotation.from_matrix(axes).as_quat()), moments


@functools.cache
def _parts_inertial(parts: tuple) -> tuple[np.ndarray, tuple[float, float, float, float], np.ndarray]:
    """`inertial_frame` of a link's parts given as a tuple of sorted item tuples (hashable): the same module
    links recur in every design, so a batch of builds computes each once. Callers must not modify the arrays."""
    return inertial_frame([dict(items) for items in parts])


def _link_mass(length: float) -> float:
    return 0.4 * (length + 0.03) + 0.26


def _leg_links(parent_mount: int, port: int, module: str, first: int, lower_length: float) -> list[_Link]:
    """Base, upper and lower links of a leg (or leg-wheel) on `port`; `first` is the index of the base link."""
    base_shapes = [_actuator(X8_9, (0, 0, 0)),
                   _box((0.5 * (SHOULDER_OFFSET - ACTUATOR_RADIUS), 0.025, 0.015), BRACKET_MASS,
                        (SHOULDER_OFFSET / 2, 0, 0)),
                   _actuator(X8_16, (SHOULDER_OFFSET, 0, 0), _QUAT_Y_TO_Z)]
    mount = _mount_orientation(port)
    base = _Link(parent_mount, (*PORT_XY[port], 0.0), mount, (0, 0, 1), pb.JOINT_REVOLUTE, "actuator",
                 base_shapes, "base", port, module)
    # The shoulder axis is the leg frame's -y, so a positive angle lifts the leg's far end.
    upper = _Link(first, (SHOULDER_OFFSET, 0, 0), _IDENTITY, (0, -1, 0), pb.JOINT_REVOLUTE, "link",
                  [_cylinder(LINK_RADIUS, LINK_LENGTH, _link_mass(LINK_LENGTH), (LINK_LENGTH / 2, 0, 0),
                             _QUAT_X_TO_Z, "link"),
                   _actuator(X5_9, (LINK_LENGTH, 0, 0), _QUAT_Y_TO_Z)],
                  "shoulder", port, module)
    # The elbow turns about +y, so at pi/2 the lower link's x points straight down and its z radially out.
    lower_shapes = [_cylinder(LINK_RADIUS, lower_length, _link_mass(lower_length), (lower_length / 2, 0, 0),
                              _QUAT_X_TO_Z, "link")]
    if module == "b":
        lower_shapes.append(_actuator(X8_3, (lower_length, 0, 0)))
    lower = _Link(first + 1, (LINK_LENGTH, 0, 0), _IDENTITY, (0, 1, 0), pb.JOINT_REVOLUTE, "link",
                  lower_shapes, "elbow", port, module)
    return [base, upper, lower]


def _mount_orientation(port: int) -> tuple[float, float, float, float]:
    return tuple(pb.getQuaternionFromEuler([0, 0, PORT_ANGLES[port] - math.pi / 2]))


def _wheel_link(parent: int, position, orientation, port: int, module: str) -> _Link:
    """The wheel: a cylinder about its link's z axis (the axle), spun by the drive joint about z."""
    return _Link(parent, position, orientation, (0, 0, 1), pb.JOINT_REVOLUTE, "wheel",
                 [_cylinder(WHEEL_RADIUS, WHEEL_WIDTH, WHEEL_MASS, (0, 0, 0), kind="wheel")], "drive", port, module)


def _module_links(port: int, module: str, first: int) -> list[_Link]:
    """Links of the module on `port`; `first` is the list index its first link will get."""
    if module == "n":
        return []
    if module in "lb":
        lower_length = LINK_LENGTH if module == "l" else LEGWHEEL_LINK_LENGTH
        links = _leg_links(0, port, module, first, lower_length)
        if module == "l":
            links.append(_Link(first + 2, (LINK_LENGTH, 0, 0), _IDENTITY, (0, 0, 1), pb.JOINT_FIXED, "foot",
                               [_sphere(FOOT_RADIUS, FOOT_MASS, (0, 0, 0))], None, port, module))
        else:  # lower link frame: x down, z radially out; the wheel sits beside the drive along z
            links.append(_wheel_link(first + 2, (lower_length, 0, AXLE_OFFSET), _IDENTITY, port, module))
        return links
    # Wheel: steering link (X5-9 housing, bracket down to the drive, X8-3 housing), then the wheel.
    steer_shapes = [_actuator(X5_9, (0, 0, 0)),
                    _box((0.02, 0.01, WHEEL_DROP / 2), BRACKET_MASS,
                         (0, WHEEL_OUT - ACTUATOR_RADIUS - 0.01, -WHEEL_DROP / 2)),
                    _actuator(X8_3, (0, WHEEL_OUT, -WHEEL_DROP), _QUAT_Y_TO_Z)]
    steer = _Link(0, (*PORT_XY[port], 0.0), _mount_orientation(port), (0, 0, -1), pb.JOINT_REVOLUTE, "actuator",
                  steer_shapes, "steer", port, module)
    # The wheel frame's z is the mount's y (radially out): a rotation of -pi/2 about x.
    axle_frame = tuple(pb.getQuaternionFromEuler([-math.pi / 2, 0, 0]))
    wheel = _wheel_link(first, (0, WHEEL_OUT + AXLE_OFFSET, -WHEEL_DROP), axle_frame, port, module)
    return [steer, wheel]


def _collision_and_visual(client: int, shapes: list[dict], visual: bool) -> tuple[int, int]:
    kwargs = {"shapeTypes": [s["geom"] for s in shapes],
              "radii": [s.get("radius", 0.0) for s in shapes],
              "halfExtents": [list(s.get("half_extents", (0, 0, 0))) for s in shapes],
              "lengths": [s.get("length", 0.0) for s in shapes],
              "collisionFramePositions": [list(s["position"]) for s in shapes],
              "collisionFrameOrientations": [list(s["orientation"]) for s in shapes]}
    collision = pb.createCollisionShapeArray(**kwargs, physicsClientId=client)
    if not visual:
        return collision, -1
    kwargs["visualFramePositions"] = kwargs.pop("collisionFramePositions")
    kwargs["visualFrameOrientations"] = kwargs.pop("collisionFrameOrientations")
    kwargs["rgbaColors"] = [list(s["color"]) for s in shapes]
    return collision, pb.createVisualShapeArray(**kwargs, physicsClientId=client)


def build_robot(design: str, client: int, position=(0.0, 0.0, START_HEIGHT), visual: bool = False) -> ModularRobot:
    """Create the robot of port string `design` with its chassis centre at `position`, in its rest pose.

    Self-collision is on between all links except a joint's parent and child.
    """
    design = parse_design(design)
    links: list[_Link] = []
    for port, module in enumerate(design):
        links.extend(_module_links(port, module, len(links) + 1))
    chassis_shape = [_cylinder(CHASSIS_RADIUS, CHASSIS_THICKNESS, CHASSIS_MASS, (0, 0, 0), kind="chassis")]
    shapes = [_collision_and_visual(client, chassis_shape, visual)]
    shapes += [_collision_and_visual(client, link.shapes, visual) for link in links]
    inertials = [_parts_inertial(tuple(tuple(sorted(shape.items())) for shape in link.shapes)) for link in links]
    body = pb.createMultiBody(
        baseMass=CHASSIS_MASS, baseCollisionShapeIndex=shapes[0][0], baseVisualShapeIndex=shapes[0][1],
        basePosition=list(position), baseOrientation=[0, 0, 0, 1],
        linkMasses=[lk.mass for lk in links],
        linkCollisionShapeIndices=[s[0] for s in shapes[1:]],
        linkVisualShapeIndices=[s[1] for s in shapes[1:]],
        linkPositions=[list(lk.position) for lk in links],
        linkOrientations=[list(lk.orientation) for lk in links],
        linkInertialFramePositions=[list(com) for com, _, _ in inertials],
        linkInertialFrameOrientations=[list(axes) for _, axes, _ in inertials],
        linkParentIndices=[lk.parent for lk in links],
        linkJointTypes=[lk.joint_type for lk in links],
        linkJointAxis=[list(lk.axis) for lk in links],
        flags=pb.URDF_USE_SELF_COLLISION,
        physicsClientId=client,
    )
    pb.changeDynamics(body, -1, lateralFriction=FRICTION["chassis"], localInertiaDiagonal=list(CHASSIS_INERTIA),
                      physicsClientId=client)
    joints = []
    for i, (link, (_, _, moments)) in enumerate(zip(links, inertials, strict=True)):
        friction = FRICTION.get(link.kind, FRICTION["link"])
        damping = ROLE_ACTUATOR[link.role].damping if link.role else 0.0
        pb.changeDynamics(body, i, lateralFriction=friction, jointDamping=damping,
                          localInertiaDiagonal=[float(v) for v in moments], physicsClientId=client)
        if link.kind == "wheel":
            pb.changeDynamics(body, i, anisotropicFriction=list(WHEEL_ANISOTROPY), physicsClientId=client)
        if link.parent > 0:  # a joint's parent and child never collide
            pb.setCollisionFilterPair(body, body, i, link.parent - 1, 0, physicsClientId=client)
        else:
            pb.setCollisionFilterPair(body, body, i, -1, 0, physicsClientId=client)
        if link.role is not None:
            joints.append(Joint(i, link.port, link.module, link.role, ROLE_ACTUATOR[link.role], ROLE_LIMITS[link.role]))
            pb.resetJointState(body, i, ROLE_REST[link.role], physicsClientId=client)
    robot = ModularRobot(client, body, design, tuple(joints), ("chassis", *(lk.kind for lk in links)),
                         (tuple(chassis_shape), *(tuple(lk.shapes) for lk in links)))
    robot.command(robot.rest_targets())
    return robot
