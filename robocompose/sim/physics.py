"""pybullet clients with every physics setting set explicitly (pybullet's defaults differ from Bullet's)."""

from __future__ import annotations

from dataclasses import dataclass

import pybullet as pb


@dataclass(frozen=True)
class PhysicsSettings:
    """Physics of RoboGrammar's simulator, written out so no pybullet default leaks in."""

    time_step: float = 1 / 240  # s per sim step
    solver_iterations: int = 10  # pybullet defaults to 50
    gravity: float = -9.81  # m/s^2 along world z
    link_damping: float = 0.0  # linear and angular; pybullet defaults to 0.04


def connect(settings: PhysicsSettings = PhysicsSettings()) -> int:
    """A headless pybullet client, configured."""
    client = pb.connect(pb.DIRECT)
    configure(client, settings)
    return client


def configure(client: int, settings: PhysicsSettings) -> None:
    pb.resetSimulation(physicsClientId=client)
    pb.setPhysicsEngineParameter(
        fixedTimeStep=settings.time_step,
        numSolverIterations=settings.solver_iterations,
        numSubSteps=0,
        deterministicOverlappingPairs=1,
        physicsClientId=client,
    )
    pb.setGravity(0, 0, settings.gravity, physicsClientId=client)


def add_floor(client: int, half_extents=(40.0, 10.0), friction: float = 0.5, top: float = 0.0) -> int:
    """A static box floor whose top face is at height `top`."""
    hx, hy = half_extents
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[hx, hy, 1.0], physicsClientId=client)
    visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[hx, hy, 1.0], rgbaColor=[0.75, 0.75, 0.72, 1],
                                  physicsClientId=client)
    floor = pb.createMultiBody(0, shape, visual, basePosition=[0, 0, top - 1.0], physicsClientId=client)
    pb.changeDynamics(floor, -1, lateralFriction=friction, physicsClientId=client)
    return floor
