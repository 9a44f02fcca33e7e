"""Headless MP4 rendering of a simulated character (``mujoco.Renderer``, a camera following it).

Needs an OpenGL backend: ``MUJOCO_GL=egl`` works headless (set here as the default before MuJoCo
loads one, if the caller has not chosen). Writing MP4 needs ``imageio`` and ``imageio-ffmpeg``
(``pip install mjchar[video]``). Shadows and reflections are off: about 4x faster in software.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from mjchar.bvh.errors import MjcharError  # noqa: E402
from mjchar.bvh.io.files import PendingFile, check_output  # noqa: E402
from mjchar.controllers.core.character import Character  # noqa: E402


class RenderError(MjcharError):
    """Video output is unavailable (missing package, no OpenGL) or the path is unusable."""


def _renderer(m: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """An offscreen renderer of at most the model's buffer size, shadows and reflections off;
    :class:`RenderError` naming ``MUJOCO_GL`` when there is no OpenGL context."""
    width = min(int(width), int(m.vis.global_.offwidth))
    height = min(int(height), int(m.vis.global_.offheight))
    try:
        renderer = mujoco.Renderer(m, height, width)
    except Exception as e:  # no OpenGL context available
        raise RenderError(f"cannot create an OpenGL renderer (MUJOCO_GL="
                          f"{os.environ.get('MUJOCO_GL')}; set it before MuJoCo is first "
                          f"imported): {str(e).splitlines()[0]}") from None
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
    return renderer


def render_poses(model: mujoco.MjModel, qpos, *, width: int = 200, height: int = 320,
                 azimuth: float = 90.0, elevation: float = -5.0,
                 distance: float | None = None) -> list[np.ndarray]:
    """``(height, width, 3)`` images of ``model`` in each pose of ``qpos (F, nq)``, the camera
    looking at the root body from ``azimuth`` degrees (world frame) at ``distance`` m (default:
    2.6 x the root's height over the lowest body in the model's rest pose, so every body size
    fills the frame alike and a crouched pose looks crouched)."""
    qpos = np.atleast_2d(np.asarray(qpos, dtype=float))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # the rest pose (qpos0)
    root = int(model.jnt_bodyid[0]) if model.njnt else 0
    h = max(float(data.xpos[root][2] - data.xpos[1:, 2].min()), 0.3)
    renderer = _renderer(model, width, height)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.azimuth, camera.elevation = azimuth, elevation
    camera.distance = 2.6 * h if distance is None else distance
    images = []
    try:
        for q in qpos:
            data.qpos[:] = q
            mujoco.mj_forward(model, data)
            camera.lookat[:] = (data.xpos[root][0], data.xpos[root][1], 0.95 * h)
            renderer.update_scene(data, camera)
            images.append(np.asarray(renderer.render()).copy())
    finally:
        renderer.close()
    return images


class VideoRecorder:
    """Write frames of a character to an MP4 file at a fixed frame rate.

    Call :meth:`capture` after every control step (it only renders when a frame is due) and
    :meth:`close` at the end (or use it as a context manager). The video is written beside
    ``path`` and moved into place by a successful :meth:`close`: a run that fails part-way
    (``close(keep=False)``, or an exception in the ``with`` block) leaves an existing file at
    ``path`` as it was.

    Args:
        character: the character to film; the camera tracks its root body.
        path: output ``.mp4`` path.
        fps: frames per simulated second.
        width, height: pixels (at most the model's offscreen buffer, 1280 x 720 for converted
            models).
        distance, azimuth, elevation: tracking-camera placement (m, degrees).
    """

    def __init__(self, character: Character, path: str | os.PathLike, *, fps: float = 30.0,
                 width: int = 640, height: int = 360, distance: float = 3.5,
                 azimuth: float = 90.0, elevation: float = -10.0):
        try:
            import imageio.v2 as imageio
            import imageio_ffmpeg  # noqa: F401  (the MP4 backend)
        except ImportError:
            raise RenderError("writing video needs imageio and imageio-ffmpeg: "
                              "pip install 'mjchar[video]'") from None
        path = os.fspath(path)
        check_output(path, flag="--render", suffixes=(".mp4",))
        if not (fps > 0):
            raise RenderError(f"fps must be positive, got {fps}")
        self.renderer = _renderer(character.model, width, height)
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        self.camera.trackbodyid = character.root_body
        self.camera.distance = distance
        self.camera.azimuth = azimuth
        self.camera.elevation = elevation
        self.path = path
        self.fps = float(fps)
        self.frames = 0
        self._next = 0.0
        self._file = PendingFile(path)
        try:
            self._writer = imageio.get_writer(self._file.tmp, fps=self.fps, codec="libx264",
                                              quality=7, macro_block_size=8)
        except Exception as e:
            self._file.discard()
            self.renderer.close()
            raise RenderError(f"--render {path}: cannot start the video writer "
                              f"({str(e).splitlines()[0] if str(e) else type(e).__name__})"
                              ) from None

    def capture(self, character: Character) -> None:
        """Render and append a frame if one is due at the character's current time."""
        if character.time + 1e-9 < self._next:
            return
        self.renderer.update_scene(character.data, self.camera)
        frame = self.renderer.render()
        self._writer.append_data(np.asarray(frame))
        self.frames += 1
        self._next += 1.0 / self.fps

    def close(self, keep: bool = True) -> None:
        """Finish the video and move it into place (``keep``), or throw it away (a run that
        failed: an existing file at the path stays as it was); free the renderer."""
        if self._writer is not None:
            try:
                self._writer.close()
            finally:
                self._writer = None
                if keep and self.frames:
                    self._file.commit()
                else:
                    self._file.discard()
        self.renderer.close()

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(keep=exc_type is None)
