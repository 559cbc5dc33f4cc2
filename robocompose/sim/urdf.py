"""URDF export of a design tree (users of RoboGrammar asked for it).

Standard URDF has no capsule, so each link's collision and visual geometry is a cylinder with a sphere
at each end. The robot is Z-up like the simulator and like URDF viewers (RViz, Foxglove, pybullet): the
root link's frame is the world's orientation of the built robot (`builder.ROBOT_TO_WORLD` applied to
RoboGrammar's Y-up link frame), so loaded with the identity orientation it stands upright, head towards
+x. The other links keep RoboGrammar's frames (x along the link), as in the simulator. Joints are
`continuous` (RoboGrammar sets no joint limits) or `fixed`; motor gains are not part of URDF and are
listed in a comment.
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pybullet as pb

from robocompose.grammar.tree import DesignTree
from robocompose.io import atomic_write_text
from robocompose.sim.builder import KD, KP, MAX_TORQUE, ROBOT_TO_WORLD, _child_orientation

_CYLINDER_ALONG_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # Ry(90 deg): URDF's are along z


def _rpy(m: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (fixed axes X, Y, Z: m = Rz(yaw) Ry(pitch) Rx(roll)) of a rotation matrix."""
    across = math.hypot(m[0, 0], m[1, 0])
    if across > 1e-9:
        return math.atan2(m[2, 1], m[2, 2]), math.atan2(-m[2, 0], across), math.atan2(m[1, 0], m[0, 0])
    return math.atan2(-m[1, 2], m[1, 1]), math.atan2(-m[2, 0], across), 0.0  # pitch +-90 deg: yaw folded in roll


def _origin(xyz, m: np.ndarray) -> str:
    x, y, z = (float(v) for v in xyz)
    r, p, yaw = _rpy(m)
    return f'<origin xyz="{x:.6g} {y:.6g} {z:.6g}" rpy="{r:.9f} {p:.9f} {yaw:.9f}"/>'


def _capsule_inertia(mass: float, length: float, radius: float) -> tuple[float, float, float]:
    """Principal moments (about the axis x, and across it) of a solid capsule along x, about its centre."""
    vol_cyl, vol_sph = math.pi * radius**2 * length, 4 / 3 * math.pi * radius**3
    m_cyl, m_sph = mass * vol_cyl / (vol_cyl + vol_sph), mass * vol_sph / (vol_cyl + vol_sph)
    axial = m_cyl * radius**2 / 2 + m_sph * 2 * radius**2 / 5
    across = (m_cyl * (3 * radius**2 + length**2) / 12
              + m_sph * (2 * radius**2 / 5 + length**2 / 4 + 3 * length * radius / 8))
    return axial, across, across


def _geometry(tag: str, length: float, radius: float, frame: np.ndarray) -> str:
    """A capsule along the x axis of RoboGrammar's link frame, which is `frame` in the URDF link's frame."""
    cyl = (f"  <{tag}>{_origin(frame @ [length / 2, 0, 0], frame @ _CYLINDER_ALONG_X)}"
           f'<geometry><cylinder radius="{radius:.6g}" length="{length:.6g}"/></geometry></{tag}>')
    spheres = [f'  <{tag}>{_origin(frame @ [x, 0, 0], frame)}<geometry><sphere radius="{radius:.6g}"/></geometry>'
               f"</{tag}>" for x in (0.0, length)]
    return "\n".join([cyl, *spheres])


def design_urdf(tree: DesignTree, name: str) -> str:
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(name)}>",
             f"<!-- robocompose design {tree.design_id}; motors: position servo kp={KP} kd={KD} "
             f"max torque {MAX_TORQUE} N m; Z-up, head towards +x. -->"]
    tree = tree.canonical_order()  # the build order of the simulator
    links = tree.links()
    # RoboGrammar's frame of each link in its URDF link frame: turned to Z-up for the root, as built.
    frames = [ROBOT_TO_WORLD] + [np.eye(3)] * (len(links) - 1)
    for i, (lk, frame) in enumerate(zip(links, frames, strict=True)):
        ixx, iyy, izz = _capsule_inertia(lk.mass, lk.length, lk.radius)
        lines += [f'<link name="link{i}">',
                  f'  <inertial>{_origin(frame @ [lk.length / 2, 0, 0], frame)}<mass value="{lk.mass:.6g}"/>'
                  f'<inertia ixx="{ixx:.6g}" iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="0" ixz="0" iyz="0"/></inertial>',
                  _geometry("visual", lk.length, lk.radius, frame),
                  _geometry("collision", lk.length, lk.radius, frame), "</link>"]
    for i, lk in enumerate(links[1:], start=1):
        kind = "continuous" if lk.joint_kind == "hinge" else "fixed"
        frame = frames[lk.parent]
        child = np.array(pb.getMatrixFromQuaternion(_child_orientation(lk.joint_rot))).reshape(3, 3)
        axis = " ".join(f"{a:g}" for a in lk.joint_axis)
        lines += [f'<joint name="joint{i}" type="{kind}">', f'  <parent link="link{lk.parent}"/>',
                  f'  <child link="link{i}"/>',
                  f"  {_origin(frame @ [lk.joint_pos * links[lk.parent].length, 0, 0], frame @ child)}"]
        if kind == "continuous":
            lines += [f'  <axis xyz="{axis}"/>', f'  <limit effort="{MAX_TORQUE}" velocity="100"/>']
        lines.append("</joint>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def export_urdf(tree: DesignTree, path: str | Path, name: str | None = None) -> Path:
    return atomic_write_text(path, design_urdf(tree, name or f"design_{tree.design_id}"))
