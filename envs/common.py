"""Shared pieces of the mjchar Gymnasium environments.

Both environments (:mod:`mjchar.envs.imitation`, :mod:`mjchar.envs.stand`) drive one
:class:`~mjchar.controllers.core.character.Character` with MuJoCo's native PD (``<position>``
actuators, :class:`~mjchar.controllers.core.pd.NativePDController`); the policy's action is an
offset added to the PD set-points the controller computes. This module holds what they share:

- :class:`BodyObserver`: DeepMimic-style body features in the character's *heading frame* (the
  world rotated about z by the root's yaw, origin at the root): root height, body positions,
  6-D tangent-normal rotations, linear and angular velocities.
- :class:`CharacterEnv`: the ``gymnasium.Env`` skeleton: control timing (several physics steps per
  action), the normalised action box and its per-joint scale, seeding through ``np_random`` only,
  fall detection (:class:`~mjchar.controllers.core.metrics.FallDetector`), metrics
  (:class:`~mjchar.controllers.core.metrics.Recorder`), clean handling of a
  :class:`~mjchar.controllers.core.character.SimulationDiverged`, and rendering (``"rgb_array"``
  with a headless ``mujoco.Renderer``, ``"human"`` with ``mujoco.viewer``).

Subclasses provide the start state, the PD controller and the reward.
"""

from __future__ import annotations

import math
import os
import sys
import time
import warnings

if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                             or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering (read when MuJoCo loads)

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from gymnasium import spaces  # noqa: E402

from mjchar.bvh.errors import MjcharError  # noqa: E402
from mjchar.controllers.core.base import Action  # noqa: E402
from mjchar.controllers.core.character import Character  # noqa: E402
from mjchar.controllers.core.errors import SimulationDiverged  # noqa: E402
from mjchar.controllers.core.metrics import STEP_DISTANCE, FallDetector, Recorder  # noqa: E402
from mjchar.controllers.core.observation import (  # noqa: E402  (the policy's features)
    OBS_POSITION_LIMIT,
    OBS_VELOCITY_LIMIT,
    BodyObserver,
    heading_rotation,
)
from mjchar.controllers.core.registry import make_controller  # noqa: E402

__all__ = [
    "EnvError",
    "BodyObserver",
    "CharacterEnv",
    "display_available",
    "as_range",
    "merge_terms",
    "heading_rotation",
    "OBS_POSITION_LIMIT",
    "OBS_VELOCITY_LIMIT",
]

RENDER_MODES = ("human", "rgb_array")


class EnvError(MjcharError):
    """An environment was configured or used in a way it cannot support (bad option, bad action,
    a render mode that needs a display that is absent, stepping a diverged episode)."""


def display_available() -> bool:
    """Whether a window can be opened (``render_mode="human"``): on Linux a ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` must be set; other platforms are assumed to have one."""
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def as_range(value, name: str, low: float = 0.0) -> tuple[float, float]:
    """A number or a ``(low, high)`` pair -> ``(low, high)`` floats with ``low <= low_out <=
    high_out``; :class:`EnvError` (naming the option ``name``) otherwise."""
    if np.ndim(value) == 0:
        lo = hi = value
    else:
        v = np.asarray(value, dtype=float).ravel()
        if v.shape != (2,):
            raise EnvError(f"{name} must be a number or a (low, high) pair, got {value!r}")
        lo, hi = v
    try:
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError):
        raise EnvError(f"{name} must be a number or a (low, high) pair, got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and low <= lo <= hi):
        raise EnvError(f"{name} must satisfy {low:g} <= low <= high (finite), got {value!r}")
    return lo, hi


def merge_terms(given: dict | None, default: dict, name: str) -> dict:
    """``default`` (term -> number) updated by ``given``; unknown keys or negative/non-finite
    values raise :class:`EnvError` naming the option ``name``."""
    out = dict(default)
    if given is None:
        return out
    if not isinstance(given, dict):
        raise EnvError(f"{name} must be a dict with keys among {sorted(default)}, got "
                       f"{type(given).__name__}")
    unknown = set(given) - set(default)
    if unknown:
        raise EnvError(f"unknown {name} key(s) {sorted(unknown)}; expected {sorted(default)}")
    for k, v in given.items():
        if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
            raise EnvError(f"{name}[{k!r}] must be a non-negative number, got {v!r}")
        out[k] = float(v)
    return out


class CharacterEnv(gym.Env):
    """Base class of the mjchar environments (not registered itself).

    Args:
        model: ``None`` (the bundled humanoid), an MJCF path or an ``MjModel`` written by the
            converter.
        control_freq: policy steps per simulated second (Hz).
        timestep: physics time step (s). ``None``: the largest step not above the model's own
            that divides the control period exactly (1/30 s over 17 steps = 1.96 ms for the
            bundled 2 ms model). Given: used as is, with ``round(1 / (control_freq timestep))``
            physics steps per action.
        action_scale: PD-target offset per unit action. A number: that fraction of each
            actuated joint's half range (``(hi - lo) / 2``; pi/2 for an unlimited joint). An
            array ``(nu,)``: radians per actuator.
        episode_seconds: simulated seconds after which an episode is truncated.
        early_termination: end the episode on a fall (root below ``fall_height`` or a body
            other than the feet touching the floor); a divergence always ends it.
        fall_height: root height (m) of a fall (default: :class:`FallDetector`'s, 0.55 x the
            standing root height).
        max_velocity: a generalised velocity above this (rad/s, m/s) counts as a divergence.
        render_mode: ``None``, ``"rgb_array"`` or ``"human"`` (the viewer window opens at the
            first :meth:`render`, which ``step`` calls; with no display it warns once and shows
            nothing, so a script written for a desktop still runs headless).
        width, height: ``rgb_array`` image size (pixels).
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 30}

    def __init__(self, *, model=None, control_freq: float = 30.0, timestep: float | None = None,
                 action_scale=0.5, episode_seconds: float = 10.0, early_termination: bool = True,
                 fall_height: float | None = None, max_velocity: float = 200.0,
                 render_mode: str | None = None, width: int = 480, height: int = 360):
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise EnvError(f"render_mode must be None or one of {RENDER_MODES}, got "
                           f"{render_mode!r}")
        if not (isinstance(control_freq, int | float) and math.isfinite(control_freq)
                and control_freq > 0):
            raise EnvError(f"control_freq must be a positive number of Hz, got {control_freq!r}")
        if not (isinstance(episode_seconds, int | float) and episode_seconds > 0):
            raise EnvError(f"episode_seconds must be positive, got {episode_seconds!r}")
        self.render_mode = render_mode
        self.character = Character(model, max_velocity=max_velocity)
        ch = self.character
        control_dt = 1.0 / float(control_freq)
        if timestep is None:
            self.n_substeps = max(1, math.ceil(control_dt / ch.timestep - 1e-9))
            ch.set_timestep(control_dt / self.n_substeps)
        else:
            if not (isinstance(timestep, int | float) and math.isfinite(timestep)
                    and timestep > 0):
                raise EnvError(f"timestep must be a positive number of seconds, got {timestep!r}")
            ch.set_timestep(float(timestep))
            self.n_substeps = max(1, round(control_dt / float(timestep)))
        #: seconds per policy step (``n_substeps`` physics steps)
        self.control_dt = self.n_substeps * ch.timestep
        self.episode_seconds = float(episode_seconds)
        self.early_termination = bool(early_termination)
        #: the scenarios' fall test (its standing height is computed once, here)
        self.fall_detector = FallDetector(ch, fall_height)
        self.metadata = dict(self.metadata, render_fps=1.0 / self.control_dt)

        self.action_scale_rad = self._action_scale(action_scale)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(ch.nu,), dtype=np.float32)
        self.observer = BodyObserver(ch)

        self._width, self._height = int(width), int(height)
        self._renderer = None
        self._viewer = None
        self._camera = None
        self._last_frame_wall = None
        self._controller = None
        self._recorder = None
        self._last_obs = None
        self._frame = None
        self._diverged = False
        self._diverged_at = 0.0

    # -- configuration -----------------------------------------------------------------------
    def _action_scale(self, action_scale) -> np.ndarray:
        ch = self.character
        m = ch.model
        if np.ndim(action_scale) == 0:
            f = float(action_scale)
            if not (math.isfinite(f) and f > 0):
                raise EnvError(f"action_scale must be positive, got {action_scale!r}")
            half = np.full(ch.nu, math.pi / 2)
            for a in range(ch.nu):
                j = int(m.actuator_trnid[a, 0])
                if m.jnt_limited[j]:
                    lo, hi = m.jnt_range[j]
                    half[a] = 0.5 * (hi - lo)
            return f * half
        s = np.asarray(action_scale, dtype=float)
        if s.shape != (ch.nu,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise EnvError(f"action_scale must be a positive number or {ch.nu} positive radians "
                           f"(one per actuator), got shape {s.shape}")
        return s.copy()

    def _observation_space(self, extra_low: np.ndarray, extra_high: np.ndarray) -> spaces.Box:
        lo, hi = self.observer.bounds()
        self._obs_low = np.concatenate([lo, extra_low])
        self._obs_high = np.concatenate([hi, extra_high])
        return spaces.Box(self._obs_low.astype(np.float32), self._obs_high.astype(np.float32),
                          dtype=np.float32)

    # -- hooks for subclasses ----------------------------------------------------------------
    def _start(self, options: dict) -> tuple[np.ndarray, np.ndarray]:
        """``(qpos (nq,), qvel (nv,))`` of a new episode, drawn with ``self.np_random``."""
        raise NotImplementedError

    #: the registered controller whose set-points the actions offset (native PD: its targets
    #: are the ``Action.target`` the policy's offsets are added to)
    BASE_CONTROLLER = "native_pd"

    def _pd_target(self):
        """What the base controller tracks: a pose ``(nq,)`` or a target ``t -> (q, qdot)``."""
        raise NotImplementedError

    def _make_controller(self):
        """The base controller (from the controller registry), reset by the base class."""
        return make_controller(self.BASE_CONTROLLER, self.character, self._pd_target())

    def _reuse_controller(self) -> bool:
        """Whether :meth:`reset` keeps the last episode's controller and gives it the new
        target: the default :meth:`_make_controller` built it (a subclass that builds its own
        gets a new one every episode) and it can take a new target."""
        return (self._controller is not None
                and type(self)._make_controller is CharacterEnv._make_controller
                and hasattr(self._controller, "set_target"))

    def _extra_observation(self) -> np.ndarray:
        """Task features appended to the body features."""
        return np.zeros(0)

    def _before_step(self) -> None:
        """Called before the physics steps of every env step (schedule pushes, ...)."""

    def current_reward(self) -> tuple[float, dict]:
        """``(reward, terms)`` of the current state (what :meth:`step` returns after the
        physics steps); ``terms`` maps each reward term to its value in [0, 1]."""
        raise NotImplementedError

    def _after_step(self) -> None:
        """Called after the reward of every env step (accumulate metrics, ...)."""

    def _task_termination(self) -> str | None:
        """A reason to end the episode other than a fall (``None``: keep going)."""
        return None

    def _task_truncation(self) -> bool:
        """Whether the task has run out (e.g. a non-cyclic clip ended)."""
        return False

    def _task_info(self) -> dict:
        return {}

    # -- gymnasium API -----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode; all randomness comes from ``self.np_random`` (seeded by ``seed``)."""
        super().reset(seed=seed)
        options = {} if options is None else dict(options)
        ch = self.character
        qpos, qvel = self._start(options)
        ch.reset(qpos, qvel)
        self._frame = None
        if self._reuse_controller():
            # the registered base controller of the last episode: only its target changes
            # (gains, actuation and its bookkeeping are what a fresh one would set up)
            self._controller.set_target(self._pd_target(), ch)
        else:
            self._controller = self._make_controller()
            self._controller.reset(ch)
        self._recorder = Recorder(ch)
        self._diverged = False
        self._fell, self._fall_time, self._fall_reason = False, None, None
        self._end_reason = None
        self._n_steps = 0
        self._reward_terms = {}
        obs = self._observe()
        self._last_obs = obs
        if self.render_mode == "human":
            self.render()
        return obs.copy(), self._info()

    def step(self, action):
        """Apply ``action`` (``(nu,)`` in [-1, 1], clipped) as PD-target offsets for
        ``n_substeps`` physics steps; returns ``(obs, reward, terminated, truncated, info)``."""
        act = self._step_begin(action)
        try:
            self.character.step(act, self.n_substeps)
        except SimulationDiverged as e:
            return self._step_diverged(e)
        return self._step_end()

    # :meth:`step` in parts, for a vector env that runs the physics of many envs in threads:
    # ``_step_begin`` (the character's ``begin_step``, ``advance`` and ``end_step``)
    # ``_step_end``, with ``_step_diverged`` when ``end_step`` raises.
    def _step_begin(self, action) -> Action:
        """Check ``action`` and return the PD set-points and torques the physics steps hold."""
        if self._controller is None:
            raise EnvError("step() called before reset()")
        if self._diverged:
            raise EnvError("the simulation diverged in this episode; call reset() before step()")
        a = np.asarray(action, dtype=float)
        if a.shape != self.action_space.shape:
            raise EnvError(f"action must have shape {self.action_space.shape}, got {a.shape}")
        if not (math.isfinite(np.add.reduce(a)) or np.isfinite(a).all()):  # (a sum is finite
            raise EnvError("action contains NaN or infinity")  # unless one is not, or overflow)
        ch = self.character
        self._before_step()
        base = self._controller.act(ch, ch.time)
        target = base.target + self.action_scale_rad * np.minimum(np.maximum(a, -1.0), 1.0)
        self._frame = None  # the state changes: the heading frame is computed anew
        return Action(torque=base.torque, target=target)

    def _step_diverged(self, e: SimulationDiverged):
        """The step's result when the simulation diverged (the episode ends)."""
        self._diverged, self._diverged_at = True, e.time
        self._fell, self._fall_time = True, e.time
        self._fall_reason = self._end_reason = str(e)
        self._reward_terms = {}
        return self._last_obs.copy(), 0.0, True, False, self._info()

    def _step_end(self):
        """After the physics steps: reward, observation, termination; the step's result."""
        ch = self.character
        try:
            self._n_steps += self.n_substeps
            self._recorder.record(ch)
            reward, self._reward_terms = self.current_reward()
            if not math.isfinite(reward):
                raise SimulationDiverged("non-finite reward", ch.time)
            self._after_step()
            obs = self._observe()
        except SimulationDiverged as e:
            return self._step_diverged(e)
        terminated = False
        if not self._fell:
            why = self.fall_detector.check(ch)
            if why is not None:
                self._fell, self._fall_time, self._fall_reason = True, ch.time, why
        if self.early_termination and self._fell:
            terminated, self._end_reason = True, self._fall_reason
        if not terminated:
            why = self._task_termination()
            if why is not None:
                terminated, self._end_reason = True, why
        truncated = not terminated and (ch.time >= self.episode_seconds - 1e-9
                                        or self._task_truncation())
        self._last_obs = obs
        if self.render_mode == "human":
            self.render()
        return obs.copy(), float(reward), terminated, truncated, self._info()

    def base_action(self) -> Action:
        """The base controller's action for the coming step (what :meth:`step` offsets by the
        scaled action): ``Action.target`` are the PD set-points ``base`` (rad, ``(nu,)``) of
        ``u = base + s * action``. Reads the state only."""
        if self._controller is None:
            raise EnvError("base_action() called before reset()")
        return self._controller.act(self.character, self.character.time)

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the episode began (the time of the divergence after one:
        MuJoCo may have reset the data)."""
        return self._diverged_at if self._diverged else self.character.time

    def _frame_now(self) -> tuple[np.ndarray, np.ndarray]:
        """The observer's heading frame ``(H (3, 3), r (3,))`` of the current state, computed
        once per step (the observation and a reward share it)."""
        if self._frame is None:
            self._frame = self.observer.frame(self.character.data)
        return self._frame

    def _observe(self) -> np.ndarray:
        extra = self._extra_observation()
        x = self.observer.observe(self.character.data, extra=len(extra), frame=self._frame_now())
        if len(extra):
            x[self.observer.size:] = extra
        np.maximum(x, self._obs_low, out=x)  # (np.clip's result, without its wrapper)
        np.minimum(x, self._obs_high, out=x)
        if not math.isfinite(x.sum()):  # clipped values sum finitely: only a NaN survives
            raise SimulationDiverged("non-finite observation", self.character.time)
        return x.astype(np.float32)

    def _info(self) -> dict:
        """Metrics named like the fields of :class:`~mjchar.controllers.core.metrics.Result`, plus
        extras."""
        ch = self.character
        rec = self._recorder
        # Recorder.aggregates() rebuilds arrays over the whole episode; its two fields needed
        # here are read directly (same definitions) to keep a step O(1)
        (x, y, _), (x0, y0, _) = rec.root.tolist(), rec.start_root.tolist()
        dist = math.hypot(x - x0, y - y0)
        travel = float(rec.foot_travel)
        t = self.sim_time
        info = {
            "sim_time_s": t,
            "fell": self._fell,
            "fall_time_s": self._fall_time,
            "fall_reason": self._fall_reason,
            "diverged": self._diverged,
            "distance_m": dist,
            "mean_speed_mps": dist / t if t > 0 else 0.0,
            "foot_travel_m": travel,
            "stepped": travel > STEP_DISTANCE,
            "n_steps": self._n_steps,
            "timestep_s": ch.timestep,
            "control_dt_s": self.control_dt,
            "termination_reason": self._end_reason,
            "reward_terms": dict(self._reward_terms),
        }
        info.update(self._task_info())
        return info

    # -- rendering ---------------------------------------------------------------------------
    def _tracking_camera(self) -> mujoco.MjvCamera:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        cam.trackbodyid = self.character.root_body
        cam.distance = 3.5
        cam.azimuth = 90.0
        cam.elevation = -10.0
        return cam

    def render(self):
        """``rgb_array``: an ``(height, width, 3)`` uint8 image from a camera tracking the root;
        ``human``: update the viewer window (real-time paced); ``None`` render mode: nothing."""
        if self.render_mode is None:
            return None
        if self._controller is None:
            raise EnvError("render() called before reset()")
        if self.render_mode == "rgb_array":
            return self._render_rgb()
        self._render_human()
        return None

    def _render_rgb(self) -> np.ndarray:
        ch = self.character
        if self._renderer is None:
            m = ch.model
            w = min(self._width, int(m.vis.global_.offwidth))
            h = min(self._height, int(m.vis.global_.offheight))
            try:
                self._renderer = mujoco.Renderer(m, h, w)
            except Exception as e:  # no OpenGL context
                raise EnvError(
                    f"cannot create an OpenGL renderer (MUJOCO_GL={os.environ.get('MUJOCO_GL')}; "
                    f"headless machines need MUJOCO_GL=egl set before MuJoCo is first imported): "
                    f"{str(e).splitlines()[0] if str(e) else type(e).__name__}") from None
            self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            self._camera = self._tracking_camera()
        self._renderer.update_scene(ch.data, self._camera)
        return np.asarray(self._renderer.render()).copy()

    def _render_human(self) -> None:
        ch = self.character
        if self._viewer is False:  # no window could be opened: nothing to show
            return
        if self._viewer is None:
            why = None
            if not display_available():
                why = "no display is set (DISPLAY / WAYLAND_DISPLAY are empty)"
            else:
                try:
                    import mujoco.viewer

                    self._viewer = mujoco.viewer.launch_passive(ch.model, ch.data,
                                                                show_left_ui=False,
                                                                show_right_ui=False)
                except Exception as e:
                    why = f"the MuJoCo viewer did not open ({type(e).__name__}: {e})"
            if why is not None:
                self._viewer = False
                warnings.warn(f"render_mode='human': {why}; nothing is shown (render "
                              "headless with render_mode='rgb_array')", RuntimeWarning,
                              stacklevel=3)
                return
            cam = self._viewer.cam
            cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            cam.trackbodyid = ch.root_body
            cam.distance = 3.5
        if self._viewer.is_running():
            self._viewer.sync()
        now = time.perf_counter()
        if self._last_frame_wall is not None:
            wait = self.control_dt - (now - self._last_frame_wall)
            if wait > 0:
                time.sleep(wait)
        self._last_frame_wall = time.perf_counter()

    def close(self) -> None:
        """Free the renderer and close the viewer (safe to call twice)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._viewer:
            self._viewer.close()
        self._viewer = None
