"""``mjchar/Imitation-v0``: imitate a reference motion (DeepMimic, Peng et al. 2018).

The policy acts at ``control_freq`` (30 Hz) on MuJoCo's native PD: the set-points are the
reference pose sampled by :class:`~mjchar.controllers.core.pd.NativePDController` (``u = q_bar +
(kd/kp) qdot_bar``, with the reference taken at the *end* of the step, where the character should be
when the next action comes) plus the action times a per-joint scale (see
:class:`~mjchar.envs.common.CharacterEnv`). A zero action is therefore plain PD tracking.

Reward (weights ``w`` and scales ``k`` configurable), after each step at reference time ``t``::

    r = w_p exp(-k_p sum_j |q_err_j|^2) + w_v exp(-k_v sum_j |qdot_err_j|^2)
      + w_e exp(-k_e sum_e |p_err_e|^2) + w_c exp(-k_c |c_err|^2)

with (w, k) = pose (0.65, 2), velocity (0.1, 0.1), end_effector (0.15, 40), com (0.1, 10):

- ``q_err``: ``mj_differentiatePos`` between the simulated and reference qpos over every dof but
  the root translation (joint angles in rad, the root rotation as a rotation vector);
- ``qdot_err``: the difference of the generalised velocities over the same dofs;
- ``p_err``: end effectors (wrists and ankles) relative to the root in each character's own
  heading frame, heights absolute (DeepMimic's convention), m;
- ``c_err``: world centre-of-mass position difference, m.

Episodes start at a random phase of the clip (reference state initialisation, pose and velocity
of the reference there) unless ``random_start=False`` or ``reset(options={"phase": p})``; they
terminate on a fall (a body other than the feet on the floor, or the root below the fall height),
when the mean joint position error exceeds ``max_tracking_error`` m, or on a simulation
divergence; they are truncated after ``episode_seconds`` or at the end of a non-cyclic clip.

Observation: :class:`~mjchar.envs.common.BodyObserver`'s body features, then the phase ``phi`` as
``(cos 2 pi phi, sin 2 pi phi)`` (cyclic clip; ``(cos pi phi, sin pi phi)`` otherwise), then for
each ``k`` in ``future_steps`` the reference pose ``k`` control steps ahead
(:meth:`BodyObserver.pose <mjchar.envs.common.BodyObserver.pose>`): every body's position relative
to the *simulated* root, then every body's x axis, then its z axis, in the simulated character's
heading frame.
"""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np

from mjchar import bvh
from mjchar.bvh.bundled.assets import motion_path
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core.base import ReferenceTarget
from mjchar.controllers.learned.observation import TrackingObserver, clip_phase

from .common import CharacterEnv, EnvError, heading_rotation, merge_terms

__all__ = ["ImitationEnv", "DEFAULT_REWARD_WEIGHTS", "DEFAULT_REWARD_SCALES"]

#: DeepMimic's weights of the pose, velocity, end-effector and centre-of-mass terms
DEFAULT_REWARD_WEIGHTS = {"pose": 0.65, "velocity": 0.1, "end_effector": 0.15, "com": 0.1}
#: DeepMimic's scales k of exp(-k err^2) for the same terms
DEFAULT_REWARD_SCALES = {"pose": 2.0, "velocity": 0.1, "end_effector": 40.0, "com": 10.0}
#: roles whose bodies are the end effectors of the reward
END_EFFECTOR_ROLES = ("left_wrist", "right_wrist", "left_ankle", "right_ankle")


class _EpisodeReference:
    """The reference as one episode samples it: at ``t0 + k dt`` for whole control steps ``k``.

    ``qpos(t)``/``qvel(t)`` look such times up in tables filled :data:`CHUNK` steps at a time by
    one vectorised :class:`ReferenceMotion` call each (a scalar call costs about as much as a
    chunk's row); any other time is sampled directly. It has what
    :class:`~mjchar.controllers.core.base.ReferenceTarget` needs (``qpos``, ``qvel``, ``duration``,
    ``model``).
    """

    CHUNK = 32

    def __init__(self, reference: ReferenceMotion, t0: float, dt: float):
        self.reference = reference
        self.model = reference.model
        self.duration = reference.duration
        self.t0, self.dt = float(t0), float(dt)
        self._q = np.zeros((0, reference.model.nq))
        self._v = np.zeros((0, reference.model.nv))
        self._last_t, self._last_row = None, -1

    def _row(self, t: float) -> int:
        if t == self._last_t:  # a step asks for the same time several times
            return self._last_row
        s = (t - self.t0) / self.dt
        k = round(s)
        if k < 0 or abs(s - k) > 1e-6:
            return -1
        while k >= len(self._q):
            n = len(self._q)
            times = self.t0 + self.dt * np.arange(n, n + self.CHUNK)
            self._q = np.concatenate([self._q, self.reference.qpos(times)])
            self._v = np.concatenate([self._v, self.reference.qvel(times)])
        self._last_t, self._last_row = t, k
        return k

    def qpos(self, t: float) -> np.ndarray:
        """``(nq,)`` reference pose at time ``t`` (s); ``(n, nq)`` at times ``t (n,)``."""
        if type(t) is not float and np.ndim(t):  # (np.ndim costs a microsecond)
            return self.reference.qpos(t)
        k = self._row(t)
        return self._q[k] if k >= 0 else self.reference.qpos(t)

    def qvel(self, t: float) -> np.ndarray:
        """``(nv,)`` reference velocity at time ``t`` (s); ``(n, nv)`` at times ``t (n,)``."""
        if type(t) is not float and np.ndim(t):  # (np.ndim costs a microsecond)
            return self.reference.qvel(t)
        k = self._row(t)
        return self._v[k] if k >= 0 else self.reference.qvel(t)


class ImitationEnv(CharacterEnv):
    """Imitate a reference motion with PD-target offsets (``mjchar/Imitation-v0``).

    Args:
        motion: the clip to imitate: ``None`` (the bundled walk), a bundled motion name
            (``"walk"``, ``"idle"``), a BVH path, a ``bvh.Motion``, or a
            ``mjchar.bvh.reference.reference_motion.ReferenceMotion`` built for the same model.
        cyclic: loop the clip (``None``: detected by :class:`ReferenceMotion`).
        random_start: reference state initialisation (random start phase) at every reset.
        max_tracking_error: mean joint position error (m) that ends the episode (``None``: no
            limit).
        reward_weights, reward_scales: dicts overriding :data:`DEFAULT_REWARD_WEIGHTS` /
            :data:`DEFAULT_REWARD_SCALES` (keys ``pose``, ``velocity``, ``end_effector``,
            ``com``).
        future_steps: control steps ahead at which reference poses join the observation
            (e.g. ``(1, 2)``; default none, DeepMimic's phase-only observation).
        **kwargs: :class:`~mjchar.envs.common.CharacterEnv`'s options (``model``, ``control_freq``,
            ``timestep``, ``action_scale``, ``episode_seconds``, ``early_termination``,
            ``fall_height``, ``max_velocity``, ``render_mode``, ``width``, ``height``).
    """

    def __init__(self, motion=None, *, cyclic: bool | None = None, random_start: bool = True,
                 max_tracking_error: float | None = 0.3, reward_weights: dict | None = None,
                 reward_scales: dict | None = None, future_steps=(), **kwargs):
        super().__init__(**kwargs)
        ch = self.character
        self.reference = self._load_reference(motion, cyclic)
        self._ref = _EpisodeReference(self.reference, 0.0, self.control_dt)
        self.random_start = bool(random_start)
        if max_tracking_error is not None and not (
                isinstance(max_tracking_error, int | float) and max_tracking_error > 0):
            raise EnvError(f"max_tracking_error must be positive metres or None, got "
                           f"{max_tracking_error!r}")
        self.max_tracking_error = max_tracking_error
        self.reward_weights = merge_terms(reward_weights, DEFAULT_REWARD_WEIGHTS, "reward_weights")
        self.reward_scales = merge_terms(reward_scales, DEFAULT_REWARD_SCALES, "reward_scales")
        steps = tuple(future_steps)
        if not all(isinstance(k, int | np.integer) and k > 0 for k in steps):
            raise EnvError(f"future_steps must be positive integers (control steps), got "
                           f"{future_steps!r}")
        self.future_steps = tuple(int(k) for k in steps)

        # dofs of the pose and velocity terms: everything but the root translation
        self._pose_dofs = np.setdiff1d(np.arange(ch.nv), ch.root_dofs[:3])
        if np.array_equal(self._pose_dofs, np.arange(3, ch.nv)):  # root first: a view
            self._pose_dofs = slice(3, ch.nv)
        self._ee = np.array([ch.body_id(ch.role(r)) for r in END_EFFECTOR_ROLES
                             if ch.role(r, required=False)], dtype=int)
        self._joint_bodies = self.reference.joint_body_ids
        jb = self._joint_bodies  # a contiguous run of bodies (the converter's layout): a view
        if len(jb) and np.array_equal(jb, np.arange(jb[0], jb[0] + len(jb))):
            self._joint_bodies = slice(int(jb[0]), int(jb[0]) + len(jb))
        self._ref_data = mujoco.MjData(ch.model)
        self._ref_data_time = None

        #: the phase and future-pose features, shared with the ``policy`` controller
        self.tracking = TrackingObserver(ch, self.reference, self.future_steps,
                                         self.control_dt)
        extra_hi = self.tracking.extra_bounds()
        self.observation_space = self._observation_space(-extra_hi, extra_hi)
        self._t0 = 0.0

    def _load_reference(self, motion, cyclic) -> ReferenceMotion:
        ch = self.character
        if isinstance(motion, ReferenceMotion):
            if motion.model.nq != ch.nq or motion.model.nv != ch.nv:
                raise EnvError(f"the ReferenceMotion was built for another model (nq "
                               f"{motion.model.nq}, env model nq {ch.nq})")
            return motion
        if motion is None:
            motion = motion_path("walk")
        if isinstance(motion, str) and not os.path.exists(motion) and "." not in motion:
            motion = motion_path(motion)  # a bundled motion name (AssetError if unknown)
        if isinstance(motion, str | os.PathLike):
            path = os.fspath(motion)
            if not os.path.isfile(path):
                raise EnvError(f"{path}: no such BVH file")
            motion = bvh.load(path)
        if not isinstance(motion, bvh.Motion):
            raise EnvError(f"motion must be None, a bundled name, a BVH path, a bvh.Motion or a "
                           f"ReferenceMotion, got {type(motion).__name__}")
        return ReferenceMotion(ch.model, motion, info=ch.info, cyclic=cyclic)

    # -- episode -----------------------------------------------------------------------------
    @property
    def reference_time(self) -> float:
        """Seconds into the reference at the current simulated time."""
        return self._t0 + self.sim_time

    def phase(self, t: float | None = None) -> float:
        """Phase in ``[0, 1)`` (cyclic; ``[0, 1]`` otherwise) of reference time ``t``
        (default: now)."""
        t = self.reference_time if t is None else t
        return clip_phase(t, self.reference.duration, self.reference.cyclic)

    def _start(self, options: dict):
        T = self.reference.duration
        if "phase" in options:
            p = options["phase"]
            if not (isinstance(p, int | float) and 0.0 <= p <= 1.0):
                raise EnvError(f"options['phase'] must be a number in [0, 1], got {p!r}")
            phase = float(p)
        elif self.random_start:
            phase = float(self.np_random.uniform(0.0, 1.0))
        else:
            phase = 0.0
        self._t0 = phase * T
        self._ref = _EpisodeReference(self.reference, self._t0, self.control_dt)
        self._ref_data_time = None
        self.start_phase = phase
        self._err_sum = 0.0
        self._root_err_sum = 0.0
        self._err_n = 0
        self._joint_error = 0.0
        q, v = self._ref.qpos(self._t0).copy(), self._ref.qvel(self._t0).copy()
        noise = options.get("perturb")
        if noise is not None:  # a perturbed start, as the scenarios' (perturbed_start)
            from mjchar.controllers.core.scenarios.shared import perturbed_start

            ok = (np.shape(noise) == (2,) and all(isinstance(x, int | float) and x >= 0
                                                  for x in noise))
            if not ok:
                raise EnvError(f"options['perturb'] must be (joint_noise rad, root_velocity_noise "
                               f"m/s), both >= 0, got {noise!r}")
            seed = int(self.np_random.integers(2**31))
            q, v = perturbed_start(self.character, q, v, seed, joint_noise=float(noise[0]),
                                   root_velocity_noise=float(noise[1]))
        return q, v

    def _pd_target(self):
        # the set-point held over a step is the reference at the step's end
        return ReferenceTarget(self._ref, time_offset=self._t0 + self.control_dt)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start at a random phase (or ``options["phase"]`` in [0, 1]) in the reference's pose
        and velocity (``options["perturb"] = (joint_noise, root_velocity_noise)``: perturbed
        from it as the scenarios' perturbed starts, rad and m/s); returns ``(obs, info)``."""
        obs, info = super().reset(seed=seed, options=options)
        self._accumulate_errors()
        return obs, self._info()

    # -- reward and termination ----------------------------------------------------------------
    def _reference_kinematics(self, t: float) -> mujoco.MjData:
        """A scratch ``MjData`` with the reference pose at time ``t`` and its kinematics
        (``xpos``, ``xmat``, ``subtree_com``); recomputed only when ``t`` changes."""
        d = self._ref_data
        if self._ref_data_time is None or abs(self._ref_data_time - t) > 1e-12:
            d.qpos[:] = self._ref.qpos(t)
            mujoco.mj_kinematics(self.character.model, d)
            mujoco.mj_comPos(self.character.model, d)
            self._ref_data_time = t
        return d

    def _accumulate_errors(self) -> None:
        """Add the current mean joint (and root) position error to the episode's sums: the
        scenarios' tracking error, sampled once per control step."""
        sim = self.character.data.xpos[self._joint_bodies]
        ref = self._reference_kinematics(self.reference_time).xpos[self._joint_bodies]
        diff = sim - ref
        err = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        self._joint_error = float(np.add.reduce(err) / len(err))  # (= err.mean())
        self._err_sum += self._joint_error
        self._root_err_sum += float(err[0])
        self._err_n += 1

    def current_reward(self) -> tuple[float, dict]:
        """``(reward, terms)`` of the current state (see the module docstring)."""
        ch = self.character
        t = self.reference_time
        rd = self._reference_kinematics(t)
        d = ch.data
        pose, ee, rb = self._pose_dofs, self._ee, ch.root_body
        e_q = ch.dynamics.difference(d.qpos, self._ref.qpos(t))[pose]
        e_v = d.qvel[pose] - self._ref.qvel(t)[pose]
        H, r = self._frame_now()
        xe, rxe = d.xpos[ee], rd.xpos[ee]  # (gathered once each)
        ps = (xe - r) @ H
        ps[:, 2] = xe[:, 2]
        pr = (rxe - rd.xpos[rb]) @ heading_rotation(rd.xmat[rb])
        pr[:, 2] = rxe[:, 2]
        e_c = d.subtree_com[rb] - rd.subtree_com[rb]
        e_p = (ps - pr).ravel()
        scales, weights = self.reward_scales, self.reward_weights
        terms = {"pose": math.exp(-scales["pose"] * float(e_q @ e_q)),
                 "velocity": math.exp(-scales["velocity"] * float(e_v @ e_v)),
                 "end_effector": math.exp(-scales["end_effector"] * float(e_p @ e_p)),
                 "com": math.exp(-scales["com"] * float(e_c @ e_c))}
        return sum(weights[k] * terms[k] for k in terms), terms

    def _after_step(self) -> None:
        self._accumulate_errors()

    def _task_termination(self) -> str | None:
        if self.max_tracking_error is not None and self._joint_error > self.max_tracking_error:
            return (f"mean joint error {self._joint_error:.3f} m above "
                    f"{self.max_tracking_error:g} m")
        return None

    def _task_truncation(self) -> bool:
        return (not self.reference.cyclic
                and self.reference_time >= self.reference.duration - 1e-6)

    # -- observation and info ------------------------------------------------------------------
    def _extra_observation(self) -> np.ndarray:
        return self.tracking.extra(self.character.data, self.reference_time, self._ref.qpos)

    def _task_info(self) -> dict:
        n = max(self._err_n, 1)
        return {
            "tracking_error_m": self._err_sum / n,
            "root_error_m": self._root_err_sum / n,
            "joint_error_m": self._joint_error,
            "phase": self.phase(),
            "start_phase": self.start_phase,
            "reference_time_s": self.reference_time,
        }
