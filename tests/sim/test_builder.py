import numpy as np
import pybullet as pb
import pytest

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.tree import DesignTree
from robocompose.sim.builder import aabb, build_at_rest, depth_first_order
from robocompose.sim.physics import PhysicsSettings, add_floor, connect


@pytest.fixture()
def client():
    c = connect()
    yield c
    pb.disconnect(physicsClientId=c)


def test_physics_settings_are_explicit(client):
    params = pb.getPhysicsEngineParameters(physicsClientId=client)
    assert params["fixedTimeStep"] == pytest.approx(1 / 240)
    assert params["numSolverIterations"] == PhysicsSettings().solver_iterations == 10


def test_reference_designs_build_rest_on_floor_without_self_penetration(client, reference_rules):
    add_floor(client)
    tree = derive(parse_rules(reference_rules)).tree
    robot = build_at_rest(tree, client)
    assert not robot.self_penetrating
    assert pb.getNumJoints(robot.body, physicsClientId=client) == tree.n_links - 1
    lo, hi = aabb(robot.body, client)
    assert lo[2] == pytest.approx(0.0, abs=1e-6) and hi[0] == pytest.approx(0.0, abs=1e-6)
    masses = [pb.getDynamicsInfo(robot.body, i, physicsClientId=client)[0] for i in range(-1, tree.n_links - 1)]
    assert sum(masses) == pytest.approx(sum(lk.mass for lk in tree.links()))


def test_link_map_follows_tree_parents(client, reference_rules):
    tree = derive(parse_rules(reference_rules)).tree
    robot = build_at_rest(tree, client)
    assert robot.tree == tree.canonical_order()
    for node in range(1, tree.n_links):
        parent_link = pb.getJointInfo(robot.body, robot.pb_link[node], physicsClientId=client)[16]
        assert parent_link == robot.pb_link[robot.tree.parents[node]]
    assert sorted(depth_first_order(tree)) == list(range(tree.n_links))


def test_mirrored_legs_are_symmetric_about_the_body(client):
    # body with one leg pair: mount (fixed, mirrored) -> normal limb link with a swing joint
    tree = derive(parse_rules("0,7,2,16,8,5,6")).tree
    robot = build_at_rest(tree, client)
    tips = [np.array(pb.getLinkState(robot.body, robot.pb_link[i], physicsClientId=client)[4])
            for i in range(tree.n_links) if tree.parents[i] > 0]
    assert len(tips) == 2
    assert tips[0][1] == pytest.approx(-tips[1][1], abs=1e-6) and abs(tips[0][1]) > 0.05
    assert tips[0][0] == pytest.approx(tips[1][0], abs=1e-6)


def test_hinges_are_motorised_and_head_faces_forward(client):
    tree = derive(parse_rules("0,7,1,11,3,3,6")).tree  # two bodies joined by a roll hinge
    robot = build_at_rest(tree, client)
    assert len(robot.hinges) == 1
    base = np.array(pb.getBasePositionAndOrientation(robot.body, physicsClientId=client)[0])
    child = np.array(pb.getLinkState(robot.body, robot.pb_link[1], physicsClientId=client)[0])
    assert child[0] < base[0]  # the chain grows backwards from the head at the front (+x)


def test_overlapping_siblings_are_detected_as_self_penetration(client):
    # two hinged limb links on the same end of a body overlap at their shared joint
    tree = DesignTree((-1, 0, 0), (14, 2 * 14 + 4, 2 * 14 + 5))
    assert build_at_rest(tree, client).self_penetrating
