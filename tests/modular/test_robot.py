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


def test_each_link_carries_its_parts_mass_at_their_centre(client):
    from robocompose.modular.robot import LINK_LENGTH, X5_9, _link_mass

    robot = build_robot("lnnnnn", client)
    mass, _, _, com, _ = pb.getDynamicsInfo(robot.body, 1, physicsClientId=client)[:5]  # the upper leg link
    tube = _link_mass(LINK_LENGTH)
    assert mass == pytest.approx(tube + X5_9.mass)
    # The tube's centre is half way, the elbow actuator sits at its far end: the centre of mass is between them.
    assert com[0] == pytest.approx((tube * LINK_LENGTH / 2 + X5_9.mass * LINK_LENGTH) / (tube + X5_9.mass))
    assert com[1:] == pytest.approx((0.0, 0.0))
    total = sum(pb.getDynamicsInfo(robot.body, i, physicsClientId=client)[0] for i in range(-1, 4))
    assert total == pytest.approx(3.4 + 0.48 + 0.215 + 0.5 + tube + 0.36 + _link_mass(LINK_LENGTH) + 0.01)


def test_link_inertia_comes_from_its_parts(client):
    from robocompose.modular.robot import WHEEL_MASS, WHEEL_RADIUS, WHEEL_WIDTH

    robot = build_robot("wnnnnn", client)
    wheel = pb.getDynamicsInfo(robot.body, 1, physicsClientId=client)
    side = WHEEL_MASS * (3 * WHEEL_RADIUS ** 2 + WHEEL_WIDTH ** 2) / 12
    np.testing.assert_allclose(wheel[2], (side, side, WHEEL_MASS * WHEEL_RADIUS ** 2 / 2))  # a solid disc
    steer = pb.getDynamicsInfo(robot.body, 0, physicsClientId=client)  # actuator, bracket, drive actuator
    assert steer[3][2] < -0.05  # the drive hangs 0.185 m below the port: so does most of the link's mass
    # Principal moments of a body reaching 0.2 m down: far above those of one actuator about its axis.
    assert max(steer[2]) > 10 * 0.36 * 0.035 ** 2 / 2


def test_the_gaits_base_offset_turns_corner_legs_towards_the_middle_legs(client):
    # The original's offsets [1, 0, -1, 1, 0, -1] x pi/8 act on base joints about the mount's +z, so +pi/8 turns
    # the front-left leg counter-clockwise seen from above: from its radial pi/6 towards the mid-left leg.
    from robocompose.modular.controller import TripodController
    from robocompose.modular.evaluate import _state

    robot = build_robot("llllll", client)
    feet = [4 * k + 3 for k in range(6)]  # base, upper, lower, foot per leg

    def foot_xy(port):
        return np.array(pb.getLinkState(robot.body, feet[port], physicsClientId=client)[4][:2])

    rest_gap = np.linalg.norm(foot_xy(0) - foot_xy(1))
    controller = TripodController()
    controller.reset(robot)
    robot.pose(controller.act(_state(robot, 0.25)))  # the base swing is zero at a quarter period
    offset = foot_xy(0) - np.array([0.1524, 0.0880])
    assert math.atan2(offset[1], offset[0]) == pytest.approx(math.pi / 6 + math.pi / 8, abs=1e-6)
    back_left = foot_xy(2) - np.array([-0.1524, 0.0880])
    assert math.atan2(back_left[1], back_left[0]) == pytest.approx(5 * math.pi / 6 - math.pi / 8, abs=1e-6)
    assert np.linalg.norm(foot_xy(0) - foot_xy(1)) < rest_gap - 0.1
