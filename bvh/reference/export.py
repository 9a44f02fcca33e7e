"""Simulated motion back to BVH, on the skeleton the model was converted from.

A converted model keeps its source skeleton in its metadata
(:meth:`mjchar.bvh.mjcf.ModelInfo.source`: every joint's name, offset and channel order, in the
file's units and axes, and the clip's frame time). :func:`qpos_to_motion` turns a simulated ``qpos``
trajectory into a :class:`~bvh.Motion` on that skeleton, so the file opens in the animation tool the
clip came from::

    motion = qpos_to_motion(model, times, qpos)      # resampled to the source clip's rate
    bvh.save(motion, "simulated.bvh")

How each BVH joint's rotation is found: the converter maps the file's axes to MuJoCo's by a
rotation ``B`` and its units to metres by a scale ``s``. A joint is carried rigidly by its body
(or, for fused and dropped joints, by the body they were merged into), so if that body turned by
``D = R_body(t) R_body(rest)^T`` in MuJoCo's world, the joint's global rotation in the file's
axes is ``G = B^T D B``, and its channel rotation is ``G_parent^T G``. The root's translation
channels are ``B^T x_root / s``: the simulation's floor (``z = 0``) becomes the file's ground
plane (height 0 along its up axis), where mocap files usually have it, and a clip that was
tracked comes back where it was in the file, up to the floor placement of the reference. Every
other joint keeps its offset (bones are rigid in the simulation). Forward kinematics of the
written clip therefore puts every joint where the simulation had it (``s B p = x``), to the
precision of the written decimals.

Resampling interpolates between recorded states on the configuration manifold with MuJoCo's
``mj_differentiatePos`` / ``mj_integratePos`` (quaternions of free and ball joints stay unit).

:class:`MotionRecorder` records a simulated run for it: a frame callback (every scenario,
:func:`~mjchar.controllers.sampling.trajectory.replay` and the push protocol take one) that
keeps the simulated ``qpos`` at the start and after every control step; its
:meth:`~MotionRecorder.save_bvh` resamples and writes it::

    recorder = MotionRecorder()
    result = RunSpec("simbicon", "walk").build(frame_callback=recorder).execute()
    recorder.save_bvh("simbicon.bvh")                     # or recorder.to_motion(fps=30)
"""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np

from mjchar.bvh.errors import MjcharError
from mjchar.bvh.io import save
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.rigs.layouts import undo_record
from mjchar.bvh.rotations import quat_conj, quat_mul, quat_normalize

__all__ = ["ExportError", "DEFAULT_FPS", "MotionRecorder", "export_rate", "resample_qpos",
           "qpos_to_motion"]

#: frame rate used when neither the caller nor the model's source clip gives one
DEFAULT_FPS = 60.0


class ExportError(MjcharError):
    """A simulated motion cannot be written as BVH (no source skeleton, bad times, bad rate)."""


def export_rate(info, fps: float | None = None) -> float:
    """Frames per second of an export: ``fps`` when given, else the source clip's rate, else
    :data:`DEFAULT_FPS`."""
    if fps is not None:
        if not (math.isfinite(fps) and fps > 0):
            raise ExportError(f"the export frame rate must be a positive number, got {fps}")
        return float(fps)
    _, frame_time = info.source()
    return DEFAULT_FPS if frame_time is None else 1.0 / frame_time


def resample_qpos(model: mujoco.MjModel, times: np.ndarray, qpos: np.ndarray,
                  fps: float) -> tuple[np.ndarray, np.ndarray]:
    """``(t, q)``: the recorded ``qpos (T, nq)`` at ``times (T,)`` (increasing) resampled at
    ``times[0] + k / fps`` up to the last recorded time, interpolated on the manifold."""
    times = np.asarray(times, dtype=float)
    qpos = np.asarray(qpos, dtype=float)
    if qpos.ndim != 2 or qpos.shape[1] != model.nq or len(times) != len(qpos) or not len(times):
        raise ExportError(f"expected times (T,) and qpos (T, {model.nq}), got {times.shape} and "
                          f"{qpos.shape}")
    if np.any(np.diff(times) <= 0):
        raise ExportError("recorded times must increase")
    n = int(math.floor((times[-1] - times[0]) * fps + 1e-6)) + 1
    out_t = times[0] + np.arange(n) / fps
    out_q = np.empty((n, model.nq))
    v = np.empty(model.nv)
    idx = np.clip(np.searchsorted(times, out_t, side="right") - 1, 0, len(times) - 1)
    for k, (t, i) in enumerate(zip(out_t, idx, strict=True)):
        if i + 1 >= len(times) or abs(t - times[i]) < 1e-12:
            out_q[k] = qpos[i]
            continue
        dt = times[i + 1] - times[i]
        mujoco.mj_differentiatePos(model, v, dt, qpos[i], qpos[i + 1])
        q = qpos[i].copy()
        mujoco.mj_integratePos(model, q, v, t - times[i])
        out_q[k] = q
    return out_t, out_q


def _carrier_bodies(model: mujoco.MjModel, info, skeleton) -> np.ndarray:
    """The MuJoCo body id carrying each BVH joint (its own, or the one it was merged into)."""
    ids = np.empty(skeleton.n_joints, dtype=int)
    for j, name in enumerate(skeleton.names):
        kept = name
        seen = set()
        while kept not in info.joints:
            if kept in seen or kept not in info.fused_into:
                raise ExportError(f"joint {name!r} of the source skeleton has no body in the "
                                  "model (the metadata does not say where it went)")
            seen.add(kept)
            kept = info.fused_into[kept]
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, info.joints[kept].body)
        if body < 0:
            raise ExportError(f"the model has no body {info.joints[kept].body!r} for joint "
                              f"{name!r}")
        ids[j] = body
    return ids


def qpos_to_motion(model: mujoco.MjModel, times, qpos, *, fps: float | None = None,
                   info=None) -> Motion:
    """The simulated trajectory ``qpos (T, nq)`` at ``times (T,)`` as a :class:`Motion` on the
    model's source skeleton (names, channel orders, file units and axes), at ``fps`` frames per
    second (default: the source clip's rate, see :func:`export_rate`).

    Raises:
        ExportError: bad shapes or times, or a joint the metadata cannot place.
        mjchar.bvh.mjcf.ConversionError: the model has no mjchar metadata or no stored source
        skeleton.
    """
    if info is None:
        from mjchar.bvh.mjcf import ModelInfo

        info = ModelInfo.from_model(model)
    skeleton, _ = info.source()
    rate = export_rate(info, fps)
    _, frames = resample_qpos(model, times, qpos, rate)
    bodies = _carrier_bodies(model, info, skeleton)

    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    mujoco.mj_kinematics(model, data)
    rest = data.xquat[bodies].copy()
    basis = quat_normalize(np.asarray(info.basis, dtype=float))
    scale = float(info.unit_scale)
    R_basis = np.empty(9)
    mujoco.mju_quat2Mat(R_basis, basis)
    R_basis = R_basis.reshape(3, 3)

    n_f, n_j = len(frames), skeleton.n_joints
    glob = np.empty((n_f, n_j, 4))
    root_pos = np.empty((n_f, 3))
    root_body = bodies[0]
    for f, q in enumerate(frames):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        delta = quat_mul(data.xquat[bodies], quat_conj(rest))         # (J, 4) in MuJoCo axes
        glob[f] = quat_mul(quat_conj(basis), quat_mul(delta, basis))   # B^T D B
        root_pos[f] = R_basis.T @ data.xpos[root_body] / scale

    rotations = np.empty_like(glob)
    parents = skeleton.parents
    rotations[:, 0] = glob[:, 0]
    for j in range(1, n_j):
        rotations[:, j] = quat_mul(quat_conj(glob[:, parents[j]]), glob[:, j])
    local_positions = np.broadcast_to(skeleton.offsets, (n_f, n_j, 3)).copy()
    local_positions[:, 0] = root_pos
    motion = Motion(skeleton, 1.0 / rate, local_positions, quat_normalize(rotations))
    return undo_record(motion, info.extra.get("rig"), info.original_skeleton())


class MotionRecorder:
    """Collects ``(time, qpos)`` of a run, one sample per call (a repeated time is skipped).

    It reads only the character's ``model``, ``time`` and ``state.qpos``, and keeps the model
    for the export: :func:`qpos_to_motion` maps qpos back to the skeleton with the model's joint
    map.
    """

    def __init__(self) -> None:
        self.model = None
        self.times: list[float] = []
        self.qpos: list[np.ndarray] = []

    def __call__(self, character) -> None:
        if self.model is None:
            self.model = character.model
        elif character.model is not self.model:
            raise ExportError("one MotionRecorder records one character")
        t = float(character.time)
        if self.times and t <= self.times[-1] + 1e-12:
            return
        self.times.append(t)
        self.qpos.append(np.array(character.state.qpos))

    def __len__(self) -> int:
        return len(self.times)

    def to_motion(self, fps: float | None = None):
        """The recording as a :class:`bvh.Motion` on the model's source skeleton, at ``fps``
        frames per second (default: the source clip's rate; see
        :func:`mjchar.bvh.reference.export.export_rate`)."""
        if len(self) < 1:
            raise ExportError("nothing was recorded (was the recorder passed as the run's "
                              "frame_callback?)")
        return qpos_to_motion(self.model, np.array(self.times), np.array(self.qpos), fps=fps)

    def save_bvh(self, path: str | os.PathLike, fps: float | None = None):
        """Write :meth:`to_motion` to ``path``; returns the Motion written."""
        motion = self.to_motion(fps)
        try:
            save(motion, path)
        except OSError as e:
            raise ExportError(f"cannot write {os.fspath(path)}: {e.strerror or e}") from None
        return motion
