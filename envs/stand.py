"""``mjchar/Stand-v0``: stand, and recover from random pushes.

The policy acts at ``control_freq`` (30 Hz) on MuJoCo's native PD: the set-points are the
standing pose (:func:`mjchar.controllers.core.scenarios.standing_pose`, held by
the registered ``native_pd`` controller,
:class:`~mjchar.controllers.core.pd.NativePDController`) plus the action times a per-joint scale
(see :class:`~mjchar.envs.common.CharacterEnv`). A zero action is plain PD holding the pose.

Pushes: horizontal forces on ``push_body`` (default the pelvis), applied through
:meth:`Character.push <mjchar.controllers.core.character.Character.push>`. The first comes after a
random interval, then one after each further interval; magnitude, duration and interval are drawn
uniformly from their ranges, the direction uniformly from ``push_directions`` (degrees in the
character's heading frame at the push: 0 forward, 90 left) or from the whole circle. All draws
use ``np_random``.

Reward (weights configurable, each term in [0, 1], so the reward lies in [0, 1])::

    r = w_u exp(-k_u [(1 - cos tilt_pelvis) + (1 - cos tilt_torso)])     upright
      + w_p exp(-k_p sum_j |q_err_j|^2)                                   near the standing pose
      + w_c exp(-k_c |c_xy - f_xy|^2)                                     COM over the feet
      + w_e exp(-k_e mean_a (tau_a / tau_max_a)^2)                        small effort

with (w, k) = upright (0.4, 5), pose (0.2, 1), com (0.2, 50), effort (0.2, 10); ``q_err`` over
the actuated joints (rad), ``c_xy`` the horizontal centre of mass, ``f_xy`` the midpoint of the
two foot soles (m), ``tau_a`` the actuator torques and ``tau_max_a`` their limits.
Episodes terminate on a fall or a divergence and are truncated after ``episode_seconds``.
Observation: :class:`~mjchar.envs.common.BodyObserver`'s body features only.
"""

from __future__ import annotations

import math

import numpy as np

from mjchar.controllers.core.scenarios import heading_frame_direction, standing_pose

from .common import CharacterEnv, EnvError, as_range, merge_terms

__all__ = ["StandEnv", "DEFAULT_REWARD_WEIGHTS", "DEFAULT_REWARD_SCALES"]

DEFAULT_REWARD_WEIGHTS = {"upright": 0.4, "pose": 0.2, "com": 0.2, "effort": 0.2}
DEFAULT_REWARD_SCALES = {"upright": 5.0, "pose": 1.0, "com": 50.0, "effort": 10.0}


class StandEnv(CharacterEnv):
    """Stand and recover from random pushes (``mjchar/Stand-v0``).

    Args:
        push_force: N, a number or a ``(low, high)`` range (``0`` disables pushes).
        push_duration: s, a number or a range.
        push_interval: s between pushes (and before the first), a number or a range.
        push_directions: ``None`` (uniform on the circle) or a sequence of degrees in the
            heading frame to choose from.
        push_body: body pushed (default: the pelvis role's body).
        init_noise: rad, uniform noise on every actuated joint of the start pose (the feet are
            then put back on the floor).
        reward_weights, reward_scales: dicts overriding :data:`DEFAULT_REWARD_WEIGHTS` /
            :data:`DEFAULT_REWARD_SCALES` (keys ``upright``, ``pose``, ``com``, ``effort``).
        **kwargs: :class:`~mjchar.envs.common.CharacterEnv`'s options.
    """

    def __init__(self, *, push_force=(20.0, 120.0), push_duration=0.2,
                 push_interval=(1.5, 3.0), push_directions=None, push_body: str | None = None,
                 init_noise: float = 0.05, reward_weights: dict | None = None,
                 reward_scales: dict | None = None, **kwargs):
        super().__init__(**kwargs)
        ch = self.character
        self.push_force = as_range(push_force, "push_force")
        self.push_duration = as_range(push_duration, "push_duration")
        self.push_interval = as_range(push_interval, "push_interval")
        if self.push_force[1] > 0 and (self.push_duration[0] <= 0 or self.push_interval[0] <= 0):
            raise EnvError("push_duration and push_interval must be positive when pushes are on")
        if push_directions is not None:
            dirs = np.asarray(push_directions, dtype=float).ravel()
            if dirs.size == 0 or not np.all(np.isfinite(dirs)):
                raise EnvError(f"push_directions must be None or finite degrees, got "
                               f"{push_directions!r}")
            push_directions = dirs
        self.push_directions = push_directions
        self.push_body = push_body or ch.role("pelvis")
        ch.body_id(self.push_body)  # CharacterError if unknown
        if not (isinstance(init_noise, int | float) and 0 <= init_noise < math.pi):
            raise EnvError(f"init_noise must be radians in [0, pi), got {init_noise!r}")
        self.init_noise = float(init_noise)
        self.reward_weights = merge_terms(reward_weights, DEFAULT_REWARD_WEIGHTS, "reward_weights")
        self.reward_scales = merge_terms(reward_scales, DEFAULT_REWARD_SCALES, "reward_scales")

        self.pose = standing_pose(ch)
        self._actuated = np.flatnonzero(ch.actuated)
        spine = ch.roles("spine")
        self._torso = ch.body_id(spine[-1]) if spine else ch.root_body
        self._feet = (ch.site_id("left_foot"), ch.site_id("right_foot"))
        self._tau_max = np.where(np.isfinite(ch.actuation.torque_limits()[ch.actuator_dof]),
                                 ch.actuation.torque_limits()[ch.actuator_dof], 1.0)
        self.observation_space = self._observation_space(np.zeros(0), np.zeros(0))

    # -- episode -----------------------------------------------------------------------------
    def _start(self, options: dict):
        ch = self.character
        q = self.pose.copy()
        if self.init_noise > 0:
            v = np.zeros(ch.nv)
            v[self._actuated] = self.np_random.uniform(-self.init_noise, self.init_noise,
                                                       len(self._actuated))
            q = ch.poses.on_floor(ch.dynamics.integrate(q, v, 1.0))
        self._next_push = self._draw(self.push_interval)
        self._push = None
        self._n_pushes = 0
        self._max_push = 0.0
        return q, np.zeros(ch.nv)

    def _pd_target(self):
        return self.pose

    def _draw(self, rng: tuple[float, float]) -> float:
        lo, hi = rng
        return lo if lo == hi else float(self.np_random.uniform(lo, hi))

    def _before_step(self) -> None:
        ch = self.character
        if self.push_force[1] <= 0 or ch.time + 1e-9 < self._next_push:
            return
        f = self._draw(self.push_force)
        dur = self._draw(self.push_duration)
        if self.push_directions is None:
            deg = float(self.np_random.uniform(0.0, 360.0))
        else:
            deg = float(self.push_directions[self.np_random.integers(len(self.push_directions))])
        ch.pushes.add(self.push_body, f * heading_frame_direction(ch, deg), dur, start=ch.time)
        self._push = (f, deg)
        self._n_pushes += 1
        self._max_push = max(self._max_push, f)
        self._next_push = ch.time + dur + self._draw(self.push_interval)

    # -- reward --------------------------------------------------------------------------------
    def current_reward(self) -> tuple[float, dict]:
        """``(reward, terms)`` of the current state (see the module docstring)."""
        ch = self.character
        d = ch.data
        tilt = (1.0 - d.xmat[ch.root_body, 8]) + (1.0 - d.xmat[self._torso, 8])  # R_zz = cos
        e_q = ch.dynamics.difference(d.qpos, self.pose)[self._actuated]
        feet = 0.5 * (d.site_xpos[self._feet[0], :2] + d.site_xpos[self._feet[1], :2])
        e_c = d.subtree_com[ch.root_body, :2] - feet
        effort = float(np.mean((d.actuator_force / self._tau_max) ** 2))
        sq = {"upright": float(tilt), "pose": float(e_q @ e_q), "com": float(e_c @ e_c),
              "effort": effort}
        terms = {k: math.exp(-self.reward_scales[k] * sq[k]) for k in sq}
        return sum(self.reward_weights[k] * terms[k] for k in terms), terms

    def _task_info(self) -> dict:
        f, deg = self._push if self._push is not None else (None, None)
        return {
            "push_N": f,
            "push_direction_deg": deg,
            "pushes": self._n_pushes,
            "largest_push_N": self._max_push,
            "push_active": bool(np.any(self.character.pushes.active_force() != 0)),
        }
