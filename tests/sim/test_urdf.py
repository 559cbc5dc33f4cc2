import numpy as np
import pybullet as pb
import pytest

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.sim.builder import build_at_rest
from robocompose.sim.physics import connect
from robocompose.sim.urdf import export_urdf


def _frames(body: int, links: list[int], client: int) -> tuple[np.ndarray, np.ndarray]:
    """World positions (n, 3) and rotation matrices (n, 3, 3) of link frames."""
    states = [pb.getLinkState(body, i, physicsClientId=client) for i in links]
    return (np.array([s[4] for s in states]),
            np.array([np.reshape(pb.getMatrixFromQuaternion(s[5]), (3, 3)) for s in states]))


def test_urdf_is_z_up_and_loads_as_the_simulator_builds_it(tmp_path, reference_rules):
    """Loaded with the identity orientation (as a Z-up viewer shows it), the URDF robot is the built one at rest:
    same links, mass and joints, every link frame at the same place up to a translation, turned the same way."""
    tree = derive(parse_rules(reference_rules)).tree
    path = export_urdf(tree, tmp_path / "robot.urdf")
    client = connect()
    try:
        body = pb.loadURDF(str(path), baseOrientation=[0, 0, 0, 1], physicsClientId=client)
        n = pb.getNumJoints(body, physicsClientId=client)
        assert n == tree.n_links - 1
        mass = sum(pb.getDynamicsInfo(body, i, physicsClientId=client)[0] for i in range(-1, n))
        assert mass == pytest.approx(sum(lk.mass for lk in tree.links()), rel=1e-4)
        revolute = sum(pb.getJointInfo(body, i, physicsClientId=client)[2] == pb.JOINT_REVOLUTE for i in range(n))
        assert revolute == tree.n_joints
        built = build_at_rest(tree, client)  # pb_link indexes its canonical order, as the URDF link names do
        urdf_names = {pb.getJointInfo(body, i, physicsClientId=client)[12].decode(): i for i in range(n)}
        nodes = range(1, tree.n_links)
        pos_urdf, rot_urdf = _frames(body, [urdf_names[f"link{k}"] for k in nodes], client)
        pos_built, rot_built = _frames(built.body, [built.pb_link[k] for k in nodes], client)
        np.testing.assert_allclose(pos_urdf - pos_urdf.mean(0), pos_built - pos_built.mean(0), atol=1e-5)
        np.testing.assert_allclose(rot_urdf, rot_built, atol=1e-5)  # no turn: upright, head towards +x
        lo, hi = (np.array(v) for v in pb.getAABB(body, -1, physicsClientId=client))
        built_lo, built_hi = (np.array(v) for v in pb.getAABB(built.body, -1, physicsClientId=client))
        # the root link lies along x like the built one (AABB margins of cylinder + spheres vs capsule differ)
        np.testing.assert_allclose(hi - lo, built_hi - built_lo, atol=0.01)
    finally:
        pb.disconnect(physicsClientId=client)
