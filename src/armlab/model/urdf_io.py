"""URDF out (``to_urdf``, ``save_urdf``) and in (``load_urdf``, through ``yourdfpy``).

Export.  The URDF written for a :class:`Robot` has one link per frame of the description:

* ``base`` — Σ_base, the root; a fixed joint ``base_to_sigma_0`` places ``sigma_0`` (Σ_0) at
  the robot's base transform T_base0;
* one link per joint frame J_i, named after the robot's link i, moved by a joint named after
  the robot's joint i.  Its origin is the constant part of (K2) with the joint offset folded in,

      T_{J_{i−1} J_i}(q_i) = X_i · M_i(q_i + offset_i) = [X_i · M_i(offset_i)] · M_i(q_i)   (U1)

  (M_i is a rotation about or a translation along z, so M(a + b) = M(a) M(b)); the axis is z;
* the link's inertial (mass, centre of mass and inertia about it, in J_i — the values of
  ``robot.arrays``, motor masses lumped) on the J_i link;
* massless fixed child frames ``sigma_1`` … ``sigma_n`` (Σ_i = J_i · S_i, the DH frames of a
  DH robot) and ``sigma_e`` (Σ_e = Σ_n · T_tool, a child of ``sigma_n``), so every frame of
  :func:`armlab.link_frames` has a URDF link of its own.

Motor rotor inertias and gear ratios have no URDF element and are not written; friction is
written as ``<dynamics damping friction>`` (F_v, F_s).

Import.  :func:`load_urdf` reads the serial chain from the root link to a tip link.  Fixed
joints are merged: their child's inertial is lumped into the moving body that carries it
(parallel-axis theorem), and the fixed transforms fold into the next joint's placement
P_i = (fixed transforms) · origin · R_axis with S_i = R_axisᵀ, exactly as a TOML
``origin``/``axis`` joint.  Σ_0 is the link that carries the first moving joint; the fixed
transforms from the root up to it form the base transform T_base0.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from armlab.model.robot import Robot
from armlab.spatial import rpy_from_matrix, transform


def _fmt(values) -> str:
    # repr() of a float is the shortest string that round-trips exactly.
    return " ".join(repr(float(v)) for v in np.atleast_1d(values))


def _origin(parent: ET.Element, T: np.ndarray) -> None:
    ET.SubElement(parent, "origin", xyz=_fmt(T[:3, 3]), rpy=_fmt(rpy_from_matrix(T[:3, :3])))


def _fixed(root: ET.Element, name: str, parent: str, child: str, T: np.ndarray) -> None:
    joint = ET.SubElement(root, "joint", name=name, type="fixed")
    _origin(joint, T)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)


def urdf_names(robot: Robot) -> tuple[list[str], list[str]]:
    """URDF names of the links (bodies in J_i) and joints of ``robot``, made unique
    against each other and the frame links ``base``, ``sigma_0`` … ``sigma_e``."""
    reserved = {"base", "sigma_0", "sigma_e", "base_to_sigma_0", "sigma_n_to_sigma_e"}
    reserved |= {f"sigma_{i + 1}" for i in range(robot.n)}
    reserved |= {f"to_sigma_{i + 1}" for i in range(robot.n)}
    used = set(reserved)
    out = []
    for names in ([lk.name for lk in robot.links], robot.joint_names):
        result = []
        for name in names:
            candidate, k = name, 1
            while candidate in used:
                k += 1
                candidate = f"{name}_{k}"
            used.add(candidate)
            result.append(candidate)
        out.append(result)
    return out[0], out[1]


def to_urdf(robot: Robot) -> str:
    """The URDF text of ``robot`` (see the module docstring for the frames it contains).

    Parameters
    ----------
    robot : Robot
        Any armlab robot; its links become URDF links in the joint frames J_i.

    Returns
    -------
    str
        A URDF document; Pinocchio's ``buildModelFromXML`` and ``yourdfpy`` read it.
    """
    m = robot.arrays
    link_names, joint_names = urdf_names(robot)
    root = ET.Element("robot", name=robot.name)
    ET.SubElement(root, "link", name="base")
    ET.SubElement(root, "link", name="sigma_0")
    _fixed(root, "base_to_sigma_0", "base", "sigma_0", robot.base)
    parent = "sigma_0"
    for i, joint in enumerate(robot.joints):
        revolute = joint.kind == "revolute"
        unlimited = not (np.isfinite(joint.limits[0]) and np.isfinite(joint.limits[1]))
        kind = ("continuous" if unlimited else "revolute") if revolute else "prismatic"
        element = ET.SubElement(root, "joint", name=joint_names[i], type=kind)
        # (U1): the constant part of the joint transform, offset folded in.
        _origin(element, transform(m.tree_R[i], m.tree_p[i]) @ joint.motion(0.0))
        ET.SubElement(element, "parent", link=parent)
        ET.SubElement(element, "child", link=link_names[i])
        ET.SubElement(element, "axis", xyz="0 0 1")
        if unlimited and not revolute:
            # URDF requires finite limits on a prismatic joint: an unbounded one gets ±1 km.
            lower, upper = -1e3, 1e3
        else:
            lower, upper = joint.limits
        if kind != "continuous":
            ET.SubElement(element, "limit", lower=_fmt(lower),
                          upper=_fmt(upper), effort="0", velocity="0")
        else:
            ET.SubElement(element, "limit", effort="0", velocity="0")
        ET.SubElement(element, "dynamics", damping=_fmt(joint.friction.viscous),
                      friction=_fmt(joint.friction.coulomb))
        link = ET.SubElement(root, "link", name=link_names[i])
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz=_fmt(m.com[i]), rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=_fmt(m.mass[i]))
        I = m.inertia[i]
        ET.SubElement(inertial, "inertia", ixx=_fmt(I[0, 0]), ixy=_fmt(I[0, 1]), ixz=_fmt(I[0, 2]),
                      iyy=_fmt(I[1, 1]), iyz=_fmt(I[1, 2]), izz=_fmt(I[2, 2]))
        ET.SubElement(root, "link", name=f"sigma_{i + 1}")
        _fixed(root, f"to_sigma_{i + 1}", link_names[i], f"sigma_{i + 1}", joint.after)
        parent = link_names[i]
    ET.SubElement(root, "link", name="sigma_e")
    _fixed(root, "sigma_n_to_sigma_e", f"sigma_{robot.n}", "sigma_e", robot.tool)
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def save_urdf(robot: Robot, path: str | Path) -> Path:
    """Write :func:`to_urdf` of ``robot`` to ``path``; returns the path."""
    path = Path(path)
    path.write_text(to_urdf(robot), encoding="utf-8")
    return path
