"""The converter's MJCF writer (step 7): deterministic XML text from the filled body layout.

:func:`_write_xml` emits compiler/option/visual/default/asset sections, the floor, the body tree
(joints with armature and damping, capsule and box geoms with masses, sites, a tracking camera on
the root), a disabled root weld, the actuators and the JSON joint map (``ModelInfo``) in
``<custom><text name="mjchar">``. Numbers are written with 6 significant digits (:func:`_f`),
angles in radians. Part of :func:`mjchar.bvh.mjcf.convert`.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf import tables as T
from mjchar.bvh.mjcf.info import ModelInfo
from mjchar.bvh.mjcf.layout import _Body

AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


# ------------------------------------------------------------------------------------------------
# 7. XML
# ------------------------------------------------------------------------------------------------
def _f(x: float) -> str:
    x = float(x)
    if abs(x) < 1e-9:
        return "0"
    s = f"{x:.6g}"
    return "0" if s in ("-0", "0") else s


def _v(v) -> str:
    return " ".join(_f(x) for x in v)


def _yaw_quat(yaw: float) -> np.ndarray:
    return np.array([math.cos(0.5 * yaw), 0.0, 0.0, math.sin(0.5 * yaw)])


def _write_xml(name: str, bodies: dict[int, _Body], actuators: list[dict], info: ModelInfo,
               offset: np.ndarray, timestep: float, sk: Skeleton) -> str:
    """The MJCF text: the model's settings, the floor and the body tree, the root weld, the
    actuators and the joint map (see the module docstring)."""
    root_el = ET.Element("mujoco", {"model": name})
    world = _write_settings(root_el, timestep)
    root_j = next(iter(bodies))
    _emit_body(world, bodies, root_j, np.zeros(3), offset)
    eq = ET.SubElement(root_el, "equality")
    ET.SubElement(eq, "weld", {"name": "root_weld", "body1": bodies[root_j].name,
                               "active": "false"})
    _write_actuators(ET.SubElement(root_el, "actuator"), actuators)
    custom = ET.SubElement(root_el, "custom")
    ET.SubElement(custom, "text", {"name": "mjchar",
                                   "data": json.dumps(info.to_dict(), separators=(", ", ": "))})
    ET.indent(root_el, space="  ")
    return ET.tostring(root_el, encoding="unicode") + "\n"


def _write_settings(root_el: ET.Element, timestep: float) -> ET.Element:
    """Compiler, option, visual, default and asset sections, and the world with its light and
    floor; returns the ``<worldbody>`` element."""
    ET.SubElement(root_el, "compiler", {"angle": "radian", "autolimits": "true"})
    ET.SubElement(root_el, "option", {"timestep": _f(timestep), "integrator": "implicitfast"})
    vis = ET.SubElement(root_el, "visual")
    ET.SubElement(vis, "global", {"offwidth": "1280", "offheight": "720"})
    default = ET.SubElement(root_el, "default")
    ET.SubElement(default, "geom", {"contype": "2", "conaffinity": "1", "condim": "3",
                                    "friction": _v(T.FRICTION), "solref": _v(T.SOLREF),
                                    "material": "body"})
    ET.SubElement(default, "site", {"size": "0.02", "rgba": "1 0.3 0.3 0.5", "group": "4"})
    asset = ET.SubElement(root_el, "asset")
    ET.SubElement(asset, "texture", {"name": "grid", "type": "2d", "builtin": "checker",
                                     "width": "512", "height": "512", "rgb1": "0.2 0.3 0.4",
                                     "rgb2": "0.3 0.4 0.5"})
    ET.SubElement(asset, "material", {"name": "grid", "texture": "grid", "texrepeat": "1 1",
                                      "texuniform": "true", "reflectance": "0.1"})
    ET.SubElement(asset, "material", {"name": "body", "rgba": "0.8 0.6 0.45 1"})
    world = ET.SubElement(root_el, "worldbody")
    ET.SubElement(world, "light", {"name": "sun", "pos": "0 0 4", "dir": "0 0 -1",
                                   "directional": "true"})
    ET.SubElement(world, "geom", {"name": "floor", "type": "plane", "size": "0 0 0.05",
                                  "contype": "1", "conaffinity": "1", "friction": _v(T.FRICTION),
                                  "solref": _v(T.SOLREF), "material": "grid"})
    return world


def _emit_body(parent_el: ET.Element, bodies: dict[int, _Body], j: int, parent_pos: np.ndarray,
               offset: np.ndarray) -> None:
    """The ``<body>`` of joint ``j`` under ``parent_el`` (placed relative to ``parent_pos``,
    world), with its joints, geoms and sites, then its children's, depth first."""
    b = bodies[j]
    world_pos = b.pos + offset
    rel = world_pos - parent_pos
    el = ET.SubElement(parent_el, "body", {"name": b.name, "pos": _v(rel)})
    _emit_joints(el, b)
    if b.parent < 0:
        ET.SubElement(el, "camera", {"name": "track", "mode": "trackcom", "pos": "0 -3.5 0.2",
                                     "xyaxes": "1 0 0 0 0 1"})
    _emit_geoms(el, b)
    for sname in sorted(b.sites):
        ET.SubElement(el, "site", {"name": sname, "pos": _v(b.sites[sname] - b.pos)})
    for c in b.children:
        _emit_body(el, bodies, c, world_pos, offset)


def _emit_joints(el: ET.Element, b: _Body) -> None:
    """The body's joints: the root's freejoint, hinges (axis, range) and balls, with their
    armature and damping."""
    for jt in b.joints:
        if jt["type"] == "free":
            ET.SubElement(el, "freejoint", {"name": "root"})
            continue
        attrs = {"name": jt["name"], "type": jt["type"]}
        if jt["type"] == "hinge":
            axis = [0, 0, 0]
            axis[AXIS_INDEX[jt["axis"]]] = 1
            if jt.get("vector") is not None:  # a flexion hinge off the world axes
                axis = jt["vector"]
            attrs["axis"] = _v(axis)
        if jt.get("range") is not None:
            attrs["range"] = _v(np.radians(jt["range"]))
        attrs["armature"] = _f(jt.get("armature", 0.0))
        attrs["damping"] = _f(jt.get("damping", 0.0))
        ET.SubElement(el, "joint", attrs)


def _emit_geoms(el: ET.Element, b: _Body) -> None:
    """The body's capsules and boxes with their masses (a small inertial for a body without
    geoms)."""
    if not b.geoms:
        m = b.mass
        i = m * 0.02 ** 2
        ET.SubElement(el, "inertial", {"pos": "0 0 0", "mass": _f(m),
                                       "diaginertia": _v([i] * 3)})
    for g in b.geoms:
        if g.kind == "capsule":
            ET.SubElement(el, "geom", {"name": g.name, "type": "capsule",
                                       "fromto": _v(np.concatenate([g.a - b.pos, g.b - b.pos])),
                                       "size": _f(g.radius), "mass": _f(g.mass)})
        else:
            attrs = {"name": g.name, "type": "box", "pos": _v(g.center - b.pos),
                     "size": _v(g.half), "mass": _f(g.mass)}
            if abs(g.yaw) > 1e-9:
                attrs["quat"] = _v(_yaw_quat(g.yaw))
            ET.SubElement(el, "geom", attrs)


def _write_actuators(act: ET.Element, actuators: list[dict]) -> None:
    """A ``<position>`` per hinge actuator, a ``<motor>`` per ball axis, under ``act``."""
    for a in actuators:
        if a["type"] == "position":
            ET.SubElement(act, "position", {"name": a["name"], "joint": a["joint"],
                                            "kp": _f(a["kp"]), "kv": _f(a["kv"]),
                                            "forcerange": _v([-a["torque"], a["torque"]])})
        else:
            ET.SubElement(act, "motor", {"name": a["name"], "joint": a["joint"],
                                         "gear": _v(a["gear"]),
                                         "forcerange": _v([-a["torque"], a["torque"]])})
