import numpy as np
import pybullet as pb
import pytest

from robocompose.grammar.derivation import random_derivation
from robocompose.grammar.tree import DesignTree
from robocompose.sim.builder import SELF_PENETRATION_TOLERANCE, build, build_at_rest
from robocompose.sim.contacts import FLOOR_FRICTION, REST_SETTINGS
from robocompose.sim.physics import add_floor, configure, connect
from robocompose.sim.self_collision import (
    capsule_self_penetrating,
    exempt_pairs,
    link_segments,
    segment_distances,
)


def test_segment_distances_against_hand_computed_cases():
    a = np.array([[[0, 0, 0], [1, 0, 0]]] * 5, dtype=float)
    b = np.array([[[0.5, 1, 0], [0.5, 2, 0]],  # perpendicular, closest at a's middle: 1
                  [[2, 0, 0], [3, 0, 0]],  # collinear, end to end: 1
                  [[0, 0.5, 0], [1, 0.5, 0]],  # parallel above: 0.5
                  [[0.5, -1, 1], [0.5, 1, 1]],  # crossing at height 1: 1
                  [[1.5, 0.5, 0], [3, 2, 0]]], dtype=float)  # skew, end points closest: |(0.5, 0.5)|
    np.testing.assert_allclose(segment_distances(a, b), [1, 1, 0.5, 1, np.sqrt(0.5)], atol=1e-12)
    np.testing.assert_allclose(segment_distances(b, a), segment_distances(a, b), atol=1e-12)


def _enumeration_candidates(n: int, seed: int = 0, min_links: int = 11):
    """The first `n` derivations of the enumeration's stream with at least `min_links` links."""
    k, trees = 0, []
    while len(trees) < n:
        derivation = random_derivation(np.random.default_rng([seed, k]), 40)
        k += 1
        if derivation is not None and derivation.tree.n_links >= min_links:
            trees.append(derivation.tree.canonical_order())
    return trees


def _pybullet_checks(trees: list[DesignTree]) -> list[bool]:
    """pybullet's own self-penetration check (the one the static test replaced): build each design at rest, run
    collision detection, and look for a self-contact deeper than the tolerance."""
    client = connect()
    try:
        flags = []
        for tree in trees:
            configure(client, REST_SETTINGS)
            add_floor(client, friction=FLOOR_FRICTION)
            body = build_at_rest(tree, client).body
            pb.performCollisionDetection(physicsClientId=client)
            flags.append(any(c[8] < -SELF_PENETRATION_TOLERANCE
                             for c in pb.getContactPoints(body, body, physicsClientId=client)))
        return flags
    finally:
        pb.disconnect(client)


def test_link_frames_are_the_builds():
    tree = _enumeration_candidates(1)[0]
    client = connect()
    try:
        body, pb_link = build(tree, client)
        segments = link_segments(tree.links())
        origin, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        inertial = np.array(pb.getDynamicsInfo(body, -1, physicsClientId=client)[3])
        rotation = np.array(pb.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        root = np.array(origin) - rotation @ inertial  # the base's link frame (its joint end)
        for node in range(1, tree.n_links):  # every link frame, mapped by the base's pose
            state = pb.getLinkState(body, pb_link[node], computeForwardKinematics=True, physicsClientId=client)
            np.testing.assert_allclose(root + rotation @ segments[node, 0], state[4], atol=1e-6)
    finally:
        pb.disconnect(client)


def test_the_static_test_agrees_with_pybullets_on_enumeration_candidates():
    trees = _enumeration_candidates(300)
    flags = _pybullet_checks(trees)
    assert 0 < sum(flags) < len(flags)  # both outcomes occur
    # a joint's parent and child always overlap at the joint: without the exempt pairs every design would collide
    assert all(len(exempt_pairs(tree.links())) >= tree.n_links - 1 for tree in trees)
    assert [capsule_self_penetrating(tree, SELF_PENETRATION_TOLERANCE) for tree in trees] == flags


@pytest.mark.slow
def test_the_static_test_agrees_with_pybullets_on_10000_enumeration_candidates():
    trees = _enumeration_candidates(10_000, seed=1)
    flags = _pybullet_checks(trees)
    static = [capsule_self_penetrating(tree, SELF_PENETRATION_TOLERANCE) for tree in trees]
    disagree = [k for k, (a, b) in enumerate(zip(static, flags, strict=True)) if a != b]
    assert not disagree, f"{len(disagree)} of {len(trees)} disagree, first {disagree[:5]}"
