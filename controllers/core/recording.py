"""Recording a simulated run and writing it as BVH on the skeleton the model came from.

:class:`MotionRecorder` is a frame callback (every scenario, :func:`~mjchar.controllers.sampling.
trajectory.replay` and the push protocol take one) that keeps the simulated ``qpos`` at the start
and after every control step; :meth:`MotionRecorder.save_bvh` resamples it to the source clip's
frame rate and writes it with the source skeleton's joint names, channel orders, units and up
axis (:mod:`mjchar.bvh.reference.export`)::

    from mjchar.controllers.core.recording import MotionRecorder

    recorder = MotionRecorder()
    result = scenarios.run_scenario("walk", character, controller, frame_callback=recorder)
    recorder.save_bvh("simbicon.bvh")                     # or recorder.to_motion(fps=30)
"""

from __future__ import annotations

import os

import numpy as np

from mjchar.bvh.io import save
from mjchar.bvh.reference.export import ExportError, qpos_to_motion

__all__ = ["MotionRecorder", "chain_callbacks"]


class MotionRecorder:
    """Collects ``(time, qpos)`` of a run, one sample per call (a repeated time is skipped).

    It keeps the character's ``model`` for the export: the kinematic layer
    (:func:`mjchar.bvh.reference.export.qpos_to_motion`) maps qpos back to the skeleton with the
    model's joint map.
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


def chain_callbacks(*callbacks):
    """One frame callback calling each of ``callbacks`` that is not ``None`` (``None`` if
    there are none)."""
    live = [c for c in callbacks if c is not None]
    if not live:
        return None
    if len(live) == 1:
        return live[0]

    def call(character) -> None:
        for c in live:
            c(character)

    return call
