"""Controllers of modular robots: the hand-crafted alternating-tripod gait, and the interface a learned policy fills.

A controller sees a `RobotState` each control step and returns one target per actuated joint (a position for
joints, a velocity for wheel drives), in the order of `ModularRobot.joints`. The thesis's main results used a
learned modular policy (a graph network over modules, Whitman et al.); its "effect of the controller"
experiment, which we reproduce, used the hand-crafted gait below. A learned policy is another `Controller`
registered in `CONTROLLERS`; its name enters the evaluation settings hash, so its results are cached apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robocompose.io.errors import InputError, shown
from robocompose.modular.robot import LEFT_SIDE, ModularRobot


@dataclass(frozen=True)
class RobotState:
    """What a controller observes at one control step."""

    t: float  # s since the episode started
    position: np.ndarray  # (3,) chassis centre, world frame
    orientation: np.ndarray  # (4,) chassis quaternion (x, y, z, w)
    linear_velocity: np.ndarray  # (3,)
    angular_velocity: np.ndarray  # (3,)
    joint_positions: np.ndarray  # (J,) in the order of robot.joints
    joint_velocities: np.ndarray  # (J,)


class Controller(Protocol):
    """A modular-robot controller: `reset` once per episode with the built robot, then `act` every control step."""

    def reset(self, robot: ModularRobot) -> None: ...

    def act(self, state: RobotState) -> np.ndarray:
        """(J,) joint targets for the robot given at reset."""
        ...


@dataclass(frozen=True)
class TripodGait:
    """Parameters of the hand-crafted controller (thesis "effect of the controller"; the original's values)."""

    amplitude: float = math.pi / 12  # rad, swing of base and lift of shoulder
    period: float = 1.0  # s
    lift_phase: tuple[float, ...] = (math.pi, 0.0, math.pi, 0.0, math.pi, 0.0)  # per port: two alternating tripods
    # Corner legs turned pi/8 towards the middle legs (a positive base angle turns a leg counter-clockwise seen
    # from above, as the original's base joint about the mount's +z; its offsets carry the same signs).
    base_offset: tuple[float, ...] = tuple(k * math.pi / 8 for k in (1, 0, -1, 1, 0, -1))
    steer: tuple[float, ...] = (-math.pi / 3, 0.0, math.pi / 3, -math.pi / 3, 0.0, math.pi / 3)  # wheels roll along x
    elbow: float = math.pi / 2  # rad, lower link vertical


class TripodController:
    """Legs walk an alternating tripod under position control; wheels steer to roll along x and spin forward.

    Leg on port i, phase phi = 2 pi t / period + lift_phase[i]:
      shoulder = max(0, A sin(phi))                    (lifts during half the cycle)
      base     = pi/2 + base_offset[i] + A sin(phi +- pi/2)   (+ on the left, - on the right)
    so a leg swings forward (towards +x) while lifted and pushes back while down. Wheel: steering at steer[i],
    drive at +max speed on the left and -max speed on the right (both roll towards +x). Leg-wheel: its leg holds
    the wheel pose (base pi/2 - steer[i], which rolls the wheel along x; shoulder 0; elbow pi/2) and its wheel
    spins as a wheel's does.
    """

    def __init__(self, gait: TripodGait = TripodGait()):
        self.gait = gait
        self.robot: ModularRobot | None = None

    def reset(self, robot: ModularRobot) -> None:
        self.robot = robot

    def act(self, state: RobotState) -> np.ndarray:
        assert self.robot is not None, "call reset(robot) first"
        g = self.gait
        targets = np.zeros(len(self.robot.joints))
        for k, joint in enumerate(self.robot.joints):
            i = joint.port
            side = 1.0 if LEFT_SIDE[i] else -1.0
            phi = 2 * math.pi * state.t / g.period + g.lift_phase[i]
            walking = joint.module == "l"
            if joint.role == "base":
                targets[k] = (math.pi / 2 + g.base_offset[i] + g.amplitude * math.sin(phi + side * math.pi / 2)
                              if walking else math.pi / 2 - g.steer[i])
            elif joint.role == "shoulder":
                targets[k] = max(0.0, g.amplitude * math.sin(phi)) if walking else 0.0
            elif joint.role == "elbow":
                targets[k] = g.elbow
            elif joint.role == "steer":
                targets[k] = g.steer[i]
            else:  # drive
                targets[k] = side * joint.actuator.speed
        return targets


class ReversedWheels(TripodController):
    """The tripod controller with every wheel spinning backwards (a physics check: the robot should back up)."""

    def act(self, state: RobotState) -> np.ndarray:
        targets = super().act(state)
        drives = np.array([j.role == "drive" for j in self.robot.joints], dtype=bool)
        targets[drives] *= -1
        return targets


CONTROLLERS: dict[str, type] = {"tripod": TripodController, "tripod_reversed_wheels": ReversedWheels}


def make_controller(name: str) -> Controller:
    if name not in CONTROLLERS:
        raise InputError(f"controller {shown(name)}: unknown; expected one of {sorted(CONTROLLERS)}")
    return CONTROLLERS[name]()
