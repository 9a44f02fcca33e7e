"""Watching a run live: MuJoCo's passive viewer (``mujoco.viewer.launch_passive``) following
the simulated character in real time (``mjchar run --view``; the envs' ``render_mode="human"``).

The viewer needs a display (X11 or Wayland; under a virtual one, ``Xvfb``, it runs too);
without one :func:`check_display` raises a one-line :class:`ViewerError`. Closing the window
ends the run as Ctrl-C does.
"""

from __future__ import annotations

import os
import sys
import threading
import time

from mjchar.bvh.errors import MjcharError

#: at most this many viewer updates per second of wall time
VIEW_FPS = 60.0


class ViewerError(MjcharError):
    """The live viewer cannot open (no display, no OpenGL)."""


def check_display() -> None:
    """Raise :class:`ViewerError` when there is no display to open a window on."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                                 or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerError("--view needs a display (DISPLAY is not set): run it on a desktop, "
                          "under `xvfb-run`, or write a video with --render OUT.mp4")
    if (os.environ.get("MUJOCO_GL") or "glfw") != "glfw":
        raise ViewerError(f"--view needs MUJOCO_GL=glfw or unset (it is "
                          f"{os.environ['MUJOCO_GL']}): MuJoCo's viewer draws with GLFW")


class LiveViewer:
    """A passive viewer on a character's model and data, kept in step with the simulation.

    Use it as a run's frame callback: each call draws the current state when a frame is due
    (``VIEW_FPS``) and waits so that simulated time passes at ``speed`` x wall time. The
    camera tracks the character's root body."""

    def __init__(self, character, *, speed: float = 1.0):
        check_display()
        import mujoco
        import mujoco.viewer

        self.speed = float(speed)
        before = set(threading.enumerate())
        try:
            self.handle = mujoco.viewer.launch_passive(
                character.model, character.data, show_left_ui=False, show_right_ui=False)
        except Exception as e:  # no OpenGL, a display that refuses the window
            raise ViewerError(f"cannot open MuJoCo's viewer: {str(e).splitlines()[0]}") \
                from None
        self._threads = [t for t in threading.enumerate() if t not in before]  # its UI thread
        with self.handle.lock():
            cam = self.handle.cam
            cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            cam.trackbodyid = int(character.root_body)
            cam.distance, cam.elevation, cam.azimuth = 4.0, -15.0, 135.0
        self._origin: tuple[float, float] | None = None  # (wall, simulated) at the first frame
        self._next_wall = 0.0
        self.frames = 0

    def __call__(self, character) -> None:
        if not self.handle.is_running():
            raise KeyboardInterrupt  # the window was closed: end the run as Ctrl-C does
        now = time.perf_counter()
        if self._origin is None:
            self._origin = (now, character.time)
        due = self._origin[0] + (character.time - self._origin[1]) / self.speed
        if due > now:
            time.sleep(due - now)
            now = due
        if now >= self._next_wall:
            self.handle.sync()
            self.frames += 1
            self._next_wall = now + 1.0 / VIEW_FPS

    def close(self) -> None:
        """Close the window and wait for the viewer's thread to end (a thread still drawing
        while Python exits can crash it)."""
        self.handle.close()
        for t in self._threads:
            t.join(timeout=10.0)
