import pybullet as pb
import pytest

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.sim.builder import BASE_ORIENTATION, build_at_rest
from robocompose.sim.physics import connect
from robocompose.sim.urdf import export_urdf


def test_urdf_loads_with_the_same_links_mass_and_joints(tmp_path, reference_rules):
    tree = derive(parse_rules(reference_rules)).tree
    path = export_urdf(tree, tmp_path / "robot.urdf")
    client = connect()
    try:
        body = pb.loadURDF(str(path), baseOrientation=BASE_ORIENTATION, physicsClientId=client)
        n = pb.getNumJoints(body, physicsClientId=client)
        assert n == tree.n_links - 1
        mass = sum(pb.getDynamicsInfo(body, i, physicsClientId=client)[0] for i in range(-1, n))
        assert mass == pytest.approx(sum(lk.mass for lk in tree.links()), rel=1e-4)
        revolute = sum(pb.getJointInfo(body, i, physicsClientId=client)[2] == pb.JOINT_REVOLUTE for i in range(n))
        assert revolute == tree.n_joints
        # the URDF robot has the same shape as the one built directly: compare link frame positions
        built = build_at_rest(tree, client)
        base_urdf = pb.getBasePositionAndOrientation(body, physicsClientId=client)[0]
        base_built = pb.getBasePositionAndOrientation(built.body, physicsClientId=client)[0]
        urdf_names = {pb.getJointInfo(body, i, physicsClientId=client)[12].decode(): i for i in range(n)}
        for node in range(1, tree.n_links):
            a = pb.getLinkState(body, urdf_names[f"link{node}"], physicsClientId=client)[4]
            b = pb.getLinkState(built.body, built.pb_link[node], physicsClientId=client)[4]
            rel_a = [x - y for x, y in zip(a, base_urdf, strict=True)]
            rel_b = [x - y for x, y in zip(b, base_built, strict=True)]
            assert rel_a == pytest.approx(rel_b, abs=1e-4)
    finally:
        pb.disconnect(physicsClientId=client)
