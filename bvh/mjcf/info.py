"""The joint map kept with a converted model (``<custom><text name="mjchar">``) and its reader."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.errors import MjcharError

#: name of the custom text element that carries the metadata
TEXT_NAME = "mjchar"
METADATA_VERSION = 1


class ConversionError(MjcharError):
    """A skeleton cannot be converted with the given options (or a model has no mjchar metadata)."""


def source_record(skeleton, motion=None) -> dict:
    """The metadata entry ``source`` (read back by :meth:`ModelInfo.source`): the skeleton's
    BVH hierarchy text, offsets to 9 decimals, and the clip's frame time (``None`` without a
    clip)."""
    from mjchar.bvh.io import dumps
    from mjchar.bvh.io.motion import Motion

    frame_time = None if motion is None else float(motion.frame_time)
    text = dumps(Motion.rest(skeleton, 1, frame_time or 1.0), precision=9)
    return {"hierarchy": text[:text.index("MOTION")], "frame_time": frame_time}


@dataclass(frozen=True)
class JointInfo:
    """How one kept BVH joint appears in the model.

    Attributes:
        body: MuJoCo body name (equals the BVH joint name).
        mj_joints: MuJoCo joint names driven by this BVH joint, outer to inner: ``["root"]`` for the
            root (free joint), three hinges for a triplet, one hinge for knees/elbows in ``hinge``
            and ``ball`` models, ``[name]`` for a ball joint, ``[]`` for a joint without rotation
            channels (welded to its parent).
        order: hinge axes outer to inner, e.g. ``"yxz"`` means ``R = R_y(q0) R_x(q1) R_z(q2)`` in
            the body's (world-aligned) rest frame; ``"y"`` for one hinge, ``"ball"`` for a ball
            joint, ``"free"`` for the root, ``""`` when there are no joints.
        role: ``"left_knee"``, ``"spine"``, ``"pelvis"``, ``"unknown"``...
    """

    body: str
    mj_joints: tuple[str, ...]
    order: str
    role: str


@dataclass
class ModelInfo:
    """The metadata of a converted model (see docs/model-contract.md for the meaning of fields).

    Attributes:
        joint_model: ``"hinge"``, ``"full"`` or ``"ball"``.
        unit_scale: metres per BVH unit.
        up_axis: up axis of the source BVH (``"x"``, ``"y"`` or ``"z"``; ``"-y"`` etc. when it
            points down).
        basis: ``(4,)`` wxyz quaternion taking BVH world axes to MuJoCo world axes.
        offset: ``(3,)`` metres added after scaling and rotating, so that a BVH point ``p`` at rest
            is at ``unit_scale * R(basis) p + offset`` in the model's reference pose (feet on the
            floor, root above the origin).
        joints: BVH joint name -> :class:`JointInfo`, every kept joint in BVH order.
        roles: role -> joint name (``"spine"`` and ``"neck"`` -> lists of names).
        dropped: BVH joints with no body of their own (dropped subtrees and fused joints).
        fused_into: each joint of ``dropped`` -> the kept body that carries its position.
        extra: the other keys of the metadata (``height``, ``sites``, ``foot_geoms``...).
    """

    joint_model: str
    unit_scale: float
    up_axis: str
    basis: np.ndarray
    offset: np.ndarray
    joints: dict[str, JointInfo]
    roles: dict[str, object]
    dropped: list[str] = field(default_factory=list)
    fused_into: dict[str, str] = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    # -- (de)serialisation ------------------------------------------------------------------
    @classmethod
    def from_dict(cls, d: dict) -> ModelInfo:
        """Build from the decoded JSON metadata (raises :class:`ConversionError` when malformed)."""
        try:
            joints = {
                name: JointInfo(j["body"], tuple(j["mj_joints"]), j["order"], j["role"])
                for name, j in d["joints"].items()
            }
            known = {"version", "joint_model", "unit_scale", "up_axis", "basis", "offset",
                     "joints", "roles", "dropped", "fused_into"}
            return cls(
                joint_model=d["joint_model"],
                unit_scale=float(d["unit_scale"]),
                up_axis=d["up_axis"],
                basis=np.asarray(d["basis"], dtype=float),
                offset=np.asarray(d.get("offset", [0.0, 0.0, 0.0]), dtype=float),
                joints=joints,
                roles=dict(d["roles"]),
                dropped=list(d.get("dropped", [])),
                fused_into=dict(d.get("fused_into", {})),
                extra={k: v for k, v in d.items() if k not in known},
            )
        except (KeyError, TypeError, ValueError) as e:
            raise ConversionError(f"malformed mjchar metadata: {e!r}") from None

    @classmethod
    def from_json(cls, text: str) -> ModelInfo:
        """Parse the JSON text of the ``mjchar`` custom text element."""
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise ConversionError(f"mjchar metadata is not valid JSON: {e}") from None
        return cls.from_dict(d)

    @classmethod
    def from_model(cls, model) -> ModelInfo:
        """Read the metadata from a compiled ``mujoco.MjModel``.

        Raises :class:`ConversionError` when the model has no ``mjchar`` text element (it was not
        written by :func:`mjchar.bvh.mjcf.convert`).
        """
        import mujoco

        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, TEXT_NAME)
        if i < 0:
            raise ConversionError(
                "model has no <custom><text name=\"mjchar\"> metadata; convert it with "
                "`mjchar convert` or mjchar.bvh.mjcf.convert()")
        adr, size = int(model.text_adr[i]), int(model.text_size[i])
        raw = bytes(np.asarray(model.text_data[adr:adr + size]).tobytes()).rstrip(b"\x00")
        return cls.from_json(raw.decode("utf-8"))

    @classmethod
    def from_xml_path(cls, path: str | os.PathLike) -> ModelInfo:
        """Read the metadata of a model file (compiles it with MuJoCo)."""
        from mjchar.bvh.mjcf.model_file import load_mjcf

        return cls.from_model(load_mjcf(path, ConversionError))

    def to_dict(self) -> dict:
        """The JSON-ready metadata dictionary (inverse of :meth:`from_dict`)."""
        d = {
            "version": METADATA_VERSION,
            "joint_model": self.joint_model,
            "unit_scale": self.unit_scale,
            "up_axis": self.up_axis,
            "basis": [float(x) for x in self.basis],
            "offset": [float(x) for x in self.offset],
            "joints": {
                name: {"body": j.body, "mj_joints": list(j.mj_joints), "order": j.order,
                       "role": j.role}
                for name, j in self.joints.items()
            },
            "roles": self.roles,
            "dropped": list(self.dropped),
            "fused_into": dict(self.fused_into),
        }
        d.update(self.extra)
        return d

    # -- the source skeleton ---------------------------------------------------------------------
    def source(self):
        """``(skeleton, frame_time)``: the BVH skeleton the model was converted from (every joint
        with its name, offset and channel order, in file units and axes; end sites included)
        and the frame time of the clip it came with (``None`` when converted from a bare
        skeleton). Raises :class:`ConversionError` for a model converted before the source was
        stored (re-convert it)."""
        rec = self.extra.get("source")
        if not isinstance(rec, dict) or "hierarchy" not in rec:
            raise ConversionError("the model's metadata does not hold the skeleton it was "
                                  "converted from (converted by an older mjchar); convert the "
                                  "BVH again")
        from mjchar.bvh.io import loads

        motion = loads(rec["hierarchy"] + "MOTION\nFrames: 0\nFrame Time: 1\n")
        ft = rec.get("frame_time")
        return motion.skeleton, (None if ft is None else float(ft))

    def original_skeleton(self):
        """The file's own skeleton when the converter normalised the rig (a static root chain
        folded, translation-channel bones, a new rest pose: the ``rig`` record), else ``None``
        (the source skeleton is the file's)."""
        rig = self.extra.get("rig")
        if not isinstance(rig, dict) or "original" not in rig:
            return None
        from mjchar.bvh.io import loads

        return loads(rig["original"] + "MOTION\nFrames: 0\nFrame Time: 1\n").skeleton

    # -- conveniences --------------------------------------------------------------------------
    def role(self, role: str):
        """Joint name (or list for ``spine``/``neck``) with ``role``; ``None`` when absent."""
        return self.roles.get(role)
