"""The design tree: a robot as parent indices and node tokens, its geometry and its canonical id.

A token is `link_type * 14 + joint_type` (3 x 14 = 42 tokens). The joint types are the distinct joints
after mirroring (a mirrored left roll is a right roll, a mirrored swing is a swing), so a token tree
alone determines the physical robot; joint positions follow from the joint type.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

from robocompose.grammar.rules import Quaternion, axis_angle
from robocompose.io.errors import InputError

# (length, radius, density) of each link type.
LINK_TYPES: tuple[tuple[str, float, float, float], ...] = (
    ("long_limb", 0.15, 0.025, 1.0),
    ("body", 0.15, 0.045, 3.0),
    ("limb", 0.10, 0.025, 1.0),
)
_Y90, _YM90 = axis_angle(0, 1, 0, 90), axis_angle(0, 1, 0, -90)
_I = (1.0, 0.0, 0.0, 0.0)
X, Y, Z, MZ = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)
# (name, pybullet joint kind, rotation (w, x, y, z), hinge axis). "fixed" is the identity on a body and
# the limb-mount rotation on a limb link (the grammar never makes the other combinations).
JOINT_TYPES: tuple[tuple[str, str, Quaternion, tuple[float, float, float]], ...] = (
    ("root", "none", _I, Z),
    ("fixed", "fixed", _I, Z),
    ("fixed_mirrored", "fixed", _YM90, Z),
    ("roll", "hinge", _I, X),
    ("swing", "hinge", _I, Y),
    ("lift", "hinge", _I, Z),
    ("left_roll", "hinge", _YM90, X),
    ("right_roll", "hinge", _Y90, X),
    ("acute_lift", "hinge", axis_angle(0, 0, 1, 120), Z),
    ("acute_lift_mirrored", "hinge", axis_angle(0, 0, 1, 120), MZ),
    ("obtuse_lift", "hinge", axis_angle(0, 0, 1, 60), Z),
    ("obtuse_lift_mirrored", "hinge", axis_angle(0, 0, 1, 60), MZ),
    ("backwards_lift", "hinge", axis_angle(0, 0, 1, -60), Z),
    ("backwards_lift_mirrored", "hinge", axis_angle(0, 0, 1, -60), MZ),
)
N_JOINT_TYPES = len(JOINT_TYPES)
ROOT_JOINT = 0
N_TOKENS = len(LINK_TYPES) * N_JOINT_TYPES  # 42
BODY_LINK_TYPE = 1
BODY_TOTAL_MASS = 0.45  # all body links together weigh one body segment (GLSO's mass normalisation)


def token_of(link_type: int, joint_type: int) -> int:
    return link_type * N_JOINT_TYPES + joint_type


def split_token(token: int) -> tuple[int, int]:
    return divmod(token, N_JOINT_TYPES)


@dataclass(frozen=True)
class Link:
    """Geometry of one link and of the joint to its parent (all in the parent's frame)."""

    parent: int
    length: float
    radius: float
    mass: float
    joint_kind: str  # none | fixed | hinge
    joint_pos: float  # position along the parent, 0 = its near end, 1 = its far end
    joint_rot: Quaternion
    joint_axis: tuple[float, float, float]


@dataclass(frozen=True)
class DesignTree:
    """A robot: `parents[i]` is node i's parent (-1 for the root, which is node 0), `tokens[i]` its token.

    Nodes are in breadth-first order, parents before children. Grammar designs give the root, and only
    the root, the root joint type. Any token may sit anywhere (GLSO's no-grammar set draws them so): the
    root's joint type is then ignored (the root is the free base), and a non-root node with the root
    joint type is attached as GLSO builds its joint type 0, rigidly at the middle of its parent.
    """

    parents: tuple[int, ...]
    tokens: tuple[int, ...]

    def __post_init__(self) -> None:
        if len(self.parents) != len(self.tokens) or not self.parents:
            raise InputError("a design tree needs one parent and one token per node, and at least one node")
        if self.parents[0] != -1 or any(not 0 <= p < i for i, p in enumerate(self.parents) if i):
            raise InputError(f"parents must list the root first and each parent before its child: {self.parents}")
        if any(not 0 <= t < N_TOKENS for t in self.tokens):
            raise InputError(f"tokens must lie in 0..{N_TOKENS - 1}: {self.tokens}")

    @property
    def n_links(self) -> int:
        return len(self.tokens)

    @property
    def n_joints(self) -> int:
        """Actuated (hinge) joints (the root has none, whatever its token says)."""
        return sum(JOINT_TYPES[split_token(t)[1]][1] == "hinge" for t in self.tokens[1:])

    def children(self, i: int) -> list[int]:
        return [j for j, p in enumerate(self.parents) if p == i]

    def links(self) -> list[Link]:
        n_body = sum(split_token(t)[0] == BODY_LINK_TYPE for t in self.tokens)
        out = []
        for parent, token in zip(self.parents, self.tokens, strict=True):
            link_type, joint_type = split_token(token)
            _, length, radius, density = LINK_TYPES[link_type]
            mass = BODY_TOTAL_MASS / n_body if link_type == BODY_LINK_TYPE else length * density
            if parent < 0:
                joint_type = ROOT_JOINT
            jname, kind, rot, axis = JOINT_TYPES[joint_type]
            # Limb mounts (fixed joints on limb links) sit at the middle of their body.
            mount = kind == "fixed" and (jname == "fixed_mirrored" or link_type != BODY_LINK_TYPE)
            if jname == "fixed" and link_type != BODY_LINK_TYPE:
                rot = _Y90
            if parent >= 0 and joint_type == ROOT_JOINT:  # GLSO's joint type 0 off the root: a rigid mount
                kind, rot, mount = "fixed", _Y90, True
            out.append(Link(parent, length, radius, mass, kind, 0.5 if mount else 1.0, rot, axis))
        return out

    def canonical(self, i: int = 0) -> str:
        """A string that is the same for every ordering of siblings (children sorted by their own form)."""
        kids = sorted(self.canonical(j) for j in self.children(i))
        return f"{self.tokens[i]}" + (f"({','.join(kids)})" if kids else "")

    def canonical_order(self) -> DesignTree:
        """The same design with siblings sorted by their canonical form, in breadth-first order.

        Every ordering of one design gives this one tree, so it builds one multibody (pybullet link
        order, and MPPI's noise-to-joint assignment, follow node order). Equal sibling forms are equal
        subtrees, so ties cannot change the result.
        """
        forms = [""] * self.n_links
        for i in reversed(range(self.n_links)):  # children after parents: bottom-up
            kids = sorted(forms[j] for j in self.children(i))
            forms[i] = f"{self.tokens[i]}" + (f"({','.join(kids)})" if kids else "")
        order, parents, queue = [], [], [(0, -1)]
        while queue:
            node, parent = queue.pop(0)
            parents.append(parent)
            order.append(node)
            new = len(order) - 1
            queue.extend((j, new) for j in sorted(self.children(node), key=forms.__getitem__))
        return DesignTree(tuple(parents), tuple(self.tokens[i] for i in order))

    @property
    def design_id(self) -> str:
        """Canonical id: the first 16 hex digits of the SHA-256 of the canonical form."""
        return hashlib.sha256(self.canonical().encode()).hexdigest()[:16]


def mirrored(rot: Quaternion, axis: tuple[float, float, float]) -> tuple[Quaternion, tuple[float, float, float]]:
    """A joint's rotation and axis seen through the body's sagittal plane (RoboGrammar's mirror flag)."""
    w, x, y, z = rot
    ax, ay, az = axis
    return (w, -x, -y, z), (ax, ay, -az)


def mirror_joint(joint_type: int, link_type: int) -> int:
    """The joint type a mirrored subtree gives a joint of `joint_type` on a link of `link_type`."""
    name, kind, rot, axis = JOINT_TYPES[joint_type]
    if name == "fixed" and link_type != BODY_LINK_TYPE:
        rot = _Y90
    return classify_joint(kind, *mirrored(rot, axis), link_type)


def classify_joint(kind: str, rot: Quaternion, axis: tuple[float, float, float], link_type: int) -> int:
    """The joint type of a (mirrored) joint as found in a built grammar graph."""
    for j, (name, k, r, a) in enumerate(JOINT_TYPES):
        if name == "root":
            continue
        if name == "fixed" and link_type != BODY_LINK_TYPE:
            r = _Y90
        if k == kind and _close(r, rot) and (kind == "fixed" or _close(a, axis)):
            return j
    raise InputError(f"no joint type for kind={kind} rotation={rot} axis={axis} on link type {link_type}")


def classify_link(length: float, radius: float) -> int:
    for i, (_, l_, r_, _) in enumerate(LINK_TYPES):
        if math.isclose(length, l_) and math.isclose(radius, r_):
            return i
    raise InputError(f"no link type of length {length} and radius {radius}")


def _close(a, b) -> bool:
    return all(math.isclose(x, y, abs_tol=1e-9) for x, y in zip(a, b, strict=True))
