"""A static self-penetration test: the robot at placement is capsules on a kinematic tree at zero joint
angles, so whether it self-penetrates is a question of segment distances, without building it in pybullet.

Link i is a capsule of radius r_i around the segment from its frame origin (its joint) to L_i along its
local x (builder.py's collision shape: a capsule of height L_i centred at L_i / 2). A child's frame sits
joint_pos * L_parent along the parent's x, rotated by the inverse of the joint rotation (builder.py hands
RoboGrammar's rotParentToThis to Bullet as its conjugate). Two capsules penetrate by
r_i + r_j - d(segment_i, segment_j); Bullet's capsule-capsule test reports that depth as a negative contact
distance, and builder.self_penetrating calls a design invalid when one pair is deeper than
SELF_PENETRATION_TOLERANCE. Pairs that do not collide in the build (`exempt_pairs`: one rigid group, or a
joint's parent and child) are skipped here too. On 10,000 enumeration candidates the test agrees with
pybullet's (tests/sim/test_self_collision.py). Where a design is simulated, builder.build_at_rest keeps
pybullet's check: its collision-detection pass is part of the initial state every rollout was measured from
(without it, rewards moved in the 3rd digit). `exempt_pairs` restates builder._filter_self_collision, which is
left as it is so that the evaluator's result digest, and with it every cached evaluation and the fidelity
record, stays valid; the next change that moves that digest anyway should make the builder call it.
"""

from __future__ import annotations

import numpy as np

from robocompose.grammar.tree import DesignTree, Link


def exempt_pairs(links: list[Link]) -> set[tuple[int, int]]:
    """(i, j), j < i, of links that never collide: one rigid (fixed-joint) group, or a parent and its child."""
    group = list(range(len(links)))  # rigid group representative of each link
    for i, link in enumerate(links[1:], start=1):
        if link.joint_kind == "fixed":
            group[i] = group[link.parent]
    return {(i, j) for i, link in enumerate(links) for j in range(i) if group[i] == group[j] or link.parent == j}


def _rotation(q: tuple[float, float, float, float]) -> np.ndarray:
    """3 x 3 matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def link_segments(links: list[Link]) -> np.ndarray:
    """(N, 2, 3) end points of each link's capsule axis in the root's frame, at zero joint angles."""
    origins, frames = np.zeros((len(links), 3)), np.zeros((len(links), 3, 3))
    for i, link in enumerate(links):
        if link.parent < 0:
            frames[i] = np.eye(3)
            continue
        parent = link.parent
        origins[i] = origins[parent] + frames[parent][:, 0] * (link.joint_pos * links[parent].length)
        frames[i] = frames[parent] @ _rotation(link.joint_rot).T
    return np.stack([origins, origins + frames[:, :, 0] * np.array([lk.length for lk in links])[:, None]], axis=1)


def segment_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P,) shortest distances between segments a[p] and b[p], each (P, 2, 3) of positive length (Ericson,
    Real-Time Collision Detection 5.1.9; parallel segments take s = 0, which gives the same distance)."""
    d1, d2, r = a[:, 1] - a[:, 0], b[:, 1] - b[:, 0], a[:, 0] - b[:, 0]  # (P, 3)
    aa, ee = (d1 * d1).sum(1), (d2 * d2).sum(1)
    bb, c, f = (d1 * d2).sum(1), (d1 * r).sum(1), (d2 * r).sum(1)
    denom = aa * ee - bb * bb  # >= 0; 0 for parallel segments
    s = np.clip(np.divide(bb * f - c * ee, denom, out=np.zeros_like(denom), where=denom > 0), 0.0, 1.0)
    t = (bb * s + f) / ee
    s = np.where(t < 0, np.clip(-c / aa, 0.0, 1.0), np.where(t > 1, np.clip((bb - c) / aa, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    gap = a[:, 0] + d1 * s[:, None] - b[:, 0] - d2 * t[:, None]
    return np.sqrt((gap * gap).sum(1))


def penetration_depths(tree: DesignTree) -> np.ndarray:
    """(P,) r_i + r_j - d(segment_i, segment_j) of every pair of links that may collide (positive: overlap)."""
    links = tree.links()
    exempt = exempt_pairs(links)
    pairs = np.array([(i, j) for i in range(len(links)) for j in range(i) if (i, j) not in exempt],
                     dtype=np.int64).reshape(-1, 2)
    segments, radii = link_segments(links), np.array([lk.radius for lk in links])
    return radii[pairs[:, 0]] + radii[pairs[:, 1]] - segment_distances(segments[pairs[:, 0]], segments[pairs[:, 1]])


def capsule_self_penetrating(tree: DesignTree, tolerance: float) -> bool:
    """Whether some pair of links overlaps by more than `tolerance` metres at placement."""
    depths = penetration_depths(tree)
    return bool(len(depths)) and bool(depths.max() > tolerance)
