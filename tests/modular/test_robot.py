import math

import numpy as np
import pybullet as pb
import pytest

from robocompose.modular.robot import (
    MODULE_JOINTS,
    START_HEIGHT,
    all_designs,
    build_robot,
    design_to_index,
    index_to_design,
    parse_design,
    valid_in_original,
)
from robocompose.sim.physics import connect


@pytest.fixture
def client():
    c = connect()
    yield c
    pb.disconnect(physicsClientId=c)


def test_design_space_has_4096_designs_and_1296_the_original_accepts():
    designs = all_designs()
    assert len(designs) == len(set(designs)) == 4096
    assert sum(valid_in_original(d) for d in designs) == 3 ** 4 * 4 ** 2  # corners non-empty, mids free
    assert not valid_in_original("nlllll") and valid_in_original("lnllnl") and not valid_in_original("lnlnnl")
    assert index_to_design(design_to_index("lwbnlw")) == "lwbnlw"


@pytest.mark.parametrize("bad", ["lwbnl", "lwbnlx", 123])
def test_bad_port_strings_are_rejected_with_the_port_order(bad):
    with pytest.raises(ValueError, match="front-left"):
        parse_design(bad)


def test_each_module_has_its_joints_in_port_order(client):
    robot = build_robot("lwbnlw", client)
    roles = [(j.port, j.role) for j in robot.joints]
    expected = [(p, r) for p, m in enumerate("lwbnlw") for r in MODULE_JOINTS[m]]
    assert roles == expected
    drive = next(j for j in robot.joints if j.role == "drive")
    assert drive.actuator.name == "X8-3" and drive.actuator.max_force == pytest.approx(0.8 * 7.0)


def _lowest_point(robot) -> float:
    n = pb.getNumJoints(robot.body, physicsClientId=robot.client)
    return min(pb.getAABB(robot.body, i, physicsClientId=robot.client)[0][2] for i in range(-1, n))


@pytest.mark.parametrize("design,reach", [("llllll", 0.295), ("wwwwww", 0.29), ("bbbbbb", 0.28)])
def test_every_module_type_reaches_the_ground_from_the_start_height(client, design, reach):
    robot = build_robot(design, client)
    assert START_HEIGHT - _lowest_point(robot) == pytest.approx(reach, abs=2e-3)


def test_a_leg_points_radially_out_and_its_foot_hangs_below_the_shoulder(client):
    robot = build_robot("lnnnnn", client)  # front-left port at angle pi/6
    foot = pb.getLinkState(robot.body, 3, physicsClientId=client)[4]  # base, upper, lower, foot
    angle = math.atan2(foot[1] - 0.088, foot[0] - 0.1524)
    assert angle == pytest.approx(math.pi / 6, abs=1e-6)
    assert math.hypot(foot[0] - 0.1524, foot[1] - 0.088) == pytest.approx(0.09 + 0.275, abs=1e-6)
    assert foot[2] == pytest.approx(START_HEIGHT - 0.275, abs=1e-6)


def test_positive_shoulder_angle_lifts_the_foot(client):
    robot = build_robot("lnnnnn", client)
    low = pb.getLinkState(robot.body, 3, physicsClientId=client)[4][2]
    pb.resetJointState(robot.body, 1, 0.3, physicsClientId=client)
    high = pb.getLinkState(robot.body, 3, physicsClientId=client)[4][2]
    assert high > low + 0.05


def test_targets_are_clipped_to_the_joint_limits(client):
    robot = build_robot("lnnnnn", client)
    robot.pose(np.array([10.0, -10.0, 0.0]))
    q, _ = robot.joint_state()
    np.testing.assert_allclose(q, [5 * math.pi / 6, -math.pi / 4, 0.785])


def test_chassis_carries_the_reference_mass_and_inertia(client):
    robot = build_robot("nnnnnn", client)
    info = pb.getDynamicsInfo(robot.body, -1, physicsClientId=client)
    assert info[0] == pytest.approx(3.4)
    np.testing.assert_allclose(info[2], (0.02, 0.02, 0.05))
    assert info[1] == pytest.approx(1.2)  # chassis lateral friction
