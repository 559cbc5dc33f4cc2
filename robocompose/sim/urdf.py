"""URDF export of a design tree (users of RoboGrammar asked for it).

Standard URDF has no capsule, so each link's collision and visual geometry is a cylinder with a sphere
at each end. The robot keeps RoboGrammar's Y-up link frames; in a Z-up world, load it with the
orientation `robocompose.sim.builder.BASE_ORIENTATION`. Joints are `continuous` (RoboGrammar sets no
joint limits) or `fixed`; motor gains are not part of URDF and are listed in a comment.
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

from robocompose.grammar.tree import DesignTree
from robocompose.io import atomic_write_text
from robocompose.sim.builder import KD, KP, MAX_TORQUE


def _rpy(q) -> tuple[float, float, float]:
    """Roll-pitch-yaw (fixed XYZ) of the child frame in its parent: the conjugate of RoboGrammar's rotation."""
    w, x, y, z = q[0], -q[1], -q[2], -q[3]
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def _capsule_inertia(mass: float, length: float, radius: float) -> tuple[float, float, float]:
    """Principal moments (about the axis x, and across it) of a solid capsule along x, about its centre."""
    vol_cyl, vol_sph = math.pi * radius**2 * length, 4 / 3 * math.pi * radius**3
    m_cyl, m_sph = mass * vol_cyl / (vol_cyl + vol_sph), mass * vol_sph / (vol_cyl + vol_sph)
    axial = m_cyl * radius**2 / 2 + m_sph * 2 * radius**2 / 5
    across = (m_cyl * (3 * radius**2 + length**2) / 12
              + m_sph * (2 * radius**2 / 5 + length**2 / 4 + 3 * length * radius / 8))
    return axial, across, across


def _geometry(tag: str, length: float, radius: float) -> str:
    half = length / 2
    cyl = (f'  <{tag}><origin xyz="{half:.6g} 0 0" rpy="0 {math.pi / 2:.9f} 0"/>'
           f'<geometry><cylinder radius="{radius:.6g}" length="{length:.6g}"/></geometry></{tag}>')
    spheres = [f'  <{tag}><origin xyz="{x:.6g} 0 0"/><geometry><sphere radius="{radius:.6g}"/></geometry></{tag}>'
               for x in (0.0, length)]
    return "\n".join([cyl, *spheres])


def design_urdf(tree: DesignTree, name: str) -> str:
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(name)}>",
             f"<!-- robocompose design {tree.design_id}; motors: position servo kp={KP} kd={KD} "
             f"max torque {MAX_TORQUE} N m; link frames are RoboGrammar's (x along the link, y up). -->"]
    tree = tree.canonical_order()  # the build order of the simulator
    links = tree.links()
    for i, lk in enumerate(links):
        ixx, iyy, izz = _capsule_inertia(lk.mass, lk.length, lk.radius)
        lines += [f'<link name="link{i}">',
                  f'  <inertial><origin xyz="{lk.length / 2:.6g} 0 0"/><mass value="{lk.mass:.6g}"/>'
                  f'<inertia ixx="{ixx:.6g}" iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="0" ixz="0" iyz="0"/></inertial>',
                  _geometry("visual", lk.length, lk.radius), _geometry("collision", lk.length, lk.radius),
                  "</link>"]
    for i, lk in enumerate(links[1:], start=1):
        kind = "continuous" if lk.joint_kind == "hinge" else "fixed"
        r, p, y = _rpy(lk.joint_rot)
        x = lk.joint_pos * links[lk.parent].length
        axis = " ".join(f"{a:g}" for a in lk.joint_axis)
        lines += [f'<joint name="joint{i}" type="{kind}">', f'  <parent link="link{lk.parent}"/>',
                  f'  <child link="link{i}"/>', f'  <origin xyz="{x:.6g} 0 0" rpy="{r:.9f} {p:.9f} {y:.9f}"/>']
        if kind == "continuous":
            lines += [f'  <axis xyz="{axis}"/>', f'  <limit effort="{MAX_TORQUE}" velocity="100"/>']
        lines.append("</joint>")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def export_urdf(tree: DesignTree, path: str | Path, name: str | None = None) -> Path:
    return atomic_write_text(path, design_urdf(tree, name or f"design_{tree.design_id}"))
