"""A design on a task in its own pybullet client: step with joint targets, collect reward, save/restore.

Reward (RoboGrammar's DotProductObjective, per sim step): in RoboGrammar's Y-up frame
    dot(base x-axis, (-2, 0, 0)) + dot(base up-axis, (0, 2, 0)) + dot(base linear velocity, (2, 0, 0)).
Our world is Z-up (RoboGrammar x -> X, y -> Z). The base link frame keeps RoboGrammar's robot-local
axes (x along the body, y up) and `BASE_ORIENTATION` turns the robot so that its local x points to
world -X (head forward) and its local y to world +Z. With R the base rotation (world from base):
    reward = -2 R[0, 0] + 2 R[2, 1] + 2 v_X,
which is 2 + 2 = 4 for an upright robot at rest facing +x, and grows by 2 per m/s of forward speed.

Summed over consecutive steps, the velocity term is 2 (x_end - x_start) / dt exactly: Bullet integrates
the base position with the base velocity of the same step (semi-implicit Euler). `RobotWorld.run` uses
that identity, reading one pose per step instead of a pose and a velocity (the reward is ~15 % of the
cost of a physics step otherwise).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import pybullet as pb

from robocompose.grammar.tree import DesignTree
from robocompose.sim.builder import KD, KP, MAX_TORQUE, BuiltRobot, build_at_rest
from robocompose.sim.physics import PhysicsSettings, connect
from robocompose.tasks.terrains import START_X, Task, build_terrain


def upright_reward(orientation: Sequence[float]) -> float:
    """The orientation terms -2 R[0, 0] + 2 R[2, 1] of the reward, from the base orientation (x, y, z, w)."""
    x, y, z, w = orientation
    heading = 1.0 - 2.0 * (y * y + z * z)  # R[0, 0]: world-x part of the base x-axis (-1 when facing +x)
    up = 2.0 * (y * z + x * w)  # R[2, 1]: world-z part of the base y-axis (1 when upright)
    return -2.0 * heading + 2.0 * up


def forward_reward(orientation: Sequence[float], velocity: Sequence[float]) -> float:
    """Per-step reward from the base orientation (x, y, z, w) and linear velocity (world, Z-up)."""
    return upright_reward(orientation) + 2.0 * velocity[0]


class RobotWorld:
    """One pybullet client holding a task's terrain and a design resting at the start line."""

    def __init__(self, tree: DesignTree, task: Task, physics: PhysicsSettings | None = None,
                 visual: bool = False):
        self.tree, self.task = tree, task
        self.client = connect(physics or PhysicsSettings())
        try:
            self.terrain = build_terrain(task, self.client)
            self.robot: BuiltRobot = build_at_rest(tree, self.client, floor_top=0.0, front_x=START_X, visual=visual)
        except BaseException:
            pb.disconnect(physicsClientId=self.client)
            raise
        self.tree = self.robot.tree  # canonical order: the tree whose nodes pb_link and hinges index
        self.body = self.robot.body
        self.hinges = list(self.robot.hinges)
        self.dof = len(self.hinges)
        self.time_step = (physics or PhysicsSettings()).time_step
        self.sim_steps = 0  # every physics step taken in this client, rollouts included
        n = self.dof
        self._motor = dict(controlMode=pb.POSITION_CONTROL, targetVelocities=[0.0] * n, positionGains=[KP] * n,
                           velocityGains=[KD] * n, forces=[MAX_TORQUE] * n, physicsClientId=self.client)

    def run(self, targets: Sequence[float], steps: int) -> float:
        """Hold joint targets (rad) for `steps` sim steps; the sum of their rewards (NaN once non-finite)."""
        client, body = self.client, self.body
        if self.dof:
            pb.setJointMotorControlArray(body, self.hinges, targetPositions=list(targets), **self._motor)
        start, _ = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        position, total = start, 0.0
        for _ in range(steps):
            pb.stepSimulation(physicsClientId=client)
            position, orientation = pb.getBasePositionAndOrientation(body, physicsClientId=client)
            total += upright_reward(orientation)
        total += 2.0 * (position[0] - start[0]) / self.time_step  # the velocity terms of all steps (see above)
        self.sim_steps += steps
        return total if math.isfinite(total) else math.nan

    def save(self) -> int:
        return pb.saveState(physicsClientId=self.client)

    def restore(self, state: int) -> None:
        pb.restoreState(stateId=state, physicsClientId=self.client)

    def forget(self, state: int) -> None:
        pb.removeState(state, physicsClientId=self.client)

    def reward_now(self) -> float:
        """The reward of the current state (no step taken)."""
        _, orientation = pb.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        velocity, _ = pb.getBaseVelocity(self.body, physicsClientId=self.client)
        return forward_reward(orientation, velocity)

    def close(self) -> None:
        pb.disconnect(physicsClientId=self.client)

    def __enter__(self) -> RobotWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
