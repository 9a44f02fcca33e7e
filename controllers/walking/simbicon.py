"""SIMBICON: simple biped locomotion control (Yin, Loken and van de Panne, SIGGRAPH 2007).

A four-state finite-state machine per gait (:mod:`mjchar.controllers.walking.gaits`): for each
stance leg a lift-off state (0 or 2, timed) and a swing state (1 or 3, ended when the swing foot
lands: phase > 0.5 and swing-foot normal force > 20 N, or a timeout). In every state each joint has
a target angle and explicit PD torques ``tau = kp (theta_d - theta) - kd theta_dot`` drive it,
computed in Python and applied as joint torques (the Character in ``"torque"`` actuation). Three
things make it balance and walk:

- **Torso and swing hip in the world (heading) frame.** The pelvis is driven to a world target
  (the desired heading, a forward lean ``torso_pitch``) by a virtual torque
  ``tau_torso = kp log(R_d R^T) - kd omega``; the swing thigh to a target orientation in the
  heading frame by ``tau_swing = kp log(R_d R^T) - kd omega_thigh``. World torques become hinge
  torques by the Jacobian transpose ``tau_i = a_i . tau`` (``a_i`` the hinge's world axis).
- **Stance hip** ``tau_stance_hip = -tau_torso - tau_swing_hip`` (minus the torques of the
  pelvis's other child joints, the spine), so the net torque on the pelvis is ``tau_torso``:
  the stance leg, pushing on the ground, rotates the torso.
- **Balance feedback** on the swing hip's target in the sagittal and coronal planes of the
  heading frame: ``theta_d = theta_d0 + cd d + cv v``, ``d`` the horizontal offset of the centre
  of mass from the stance ankle, ``v`` the centre-of-mass velocity (sagittal: forward; coronal:
  towards the swing side).

No force is ever applied to the root.

Angles in a :class:`~mjchar.controllers.walking.gaits.Gait` are anatomical (flexion ``+``); the sign
of each hinge is measured on the model at :meth:`Simbicon.reset` (e.g. on the bundled humanoid hip
flexion is a negative rotation about the lateral axis and knee flexion a positive one).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.base import Action, ControllerError
from ..core.character import Character
from ..core.geometry import cross_rows, heading_yaw
from ..core.registry import ControllerSpec, register
from .calibration import overrides_for
from .frames import (
    angle_between,
    log,
    rot_x,
    rot_y,
    rot_z,
    world_torque,
)
from .gaits import BUNDLED_LEG_LENGTH, GAITS, GRAVITY, Gait, GaitError, gait_tunables, get_gait
from .rig_map import (
    SimbiconLeg,
    SimbiconModelError,  # noqa: F401  (public: the error reset raises; walking imports it here)
    child_hinges,
    knee_angle,
    map_actuators,
    map_leg,
    map_upper_body,
    rest_body,
)

#: default physics time step for SIMBICON (explicit PD torques from Python), s
DEFAULT_TIMESTEP = 1.0 / 1000.0
_SIDES = ("left", "right")
#: gain groups of the stance ankle's hinges nearest the world x (forward at rest, as every hinge
#: key here) and z axes at rest: its roll and twist; a gait without them uses its ``ankle`` gains
_STANCE_ANKLE_GROUPS = {"x": "stance_ankle_roll", "z": "stance_ankle_twist"}
#: world-frame gains ``(kp N m/rad, kd N m s/rad)`` of a gait that leaves them out, for the gait's
#: own body (scaled with it, :meth:`~mjchar.controllers.walking.gaits.Gait.scaled`)
DEFAULT_GAINS = {
    "torso": (1000.0, 100.0),
    "stance_twist": (300.0, 30.0),
    "swing_hip": (600.0, 60.0),
    "swing_ankle_world": (100.0, 10.0),
}


def _selector(idx: np.ndarray) -> slice | np.ndarray:
    """Integer indices as a slice when they are a contiguous ascending run, else as they are."""
    idx = np.asarray(idx, dtype=int)
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


class Simbicon:
    """SIMBICON walking controller (see the module docstring).

    Args:
        gait: a gait name (``"walk"``, ``"crouch"``), a
        :class:`~mjchar.controllers.walking.gaits.Gait` or
            its dict.
        heading: desired heading (rad, world yaw); ``None`` = the pelvis's heading at reset.
        first_stance: ``"left"`` or ``"right"``: the stance leg of state 0.
        speed: commanded forward speed (m/s); ``None``: the gait's own speed. A command is a
            feed-forward (:meth:`~mjchar.controllers.walking.gaits.Gait.for_speed`: the gait's
            ``speed_anchors`` interpolated at the command's Froude speed ``v / sqrt(g L)``, ``L``
            the body's leg length) plus the gait's step-to-step speed regulation towards it
            (``speed_target``); both follow :attr:`command`, which ramps from the gait's own
            speed to ``speed`` (a fast gait from a standstill falls).
        overrides: gait parameters to change
            (:meth:`~mjchar.controllers.walking.gaits.Gait.with_overrides`, e.g. ``cd=0, cv=0``).

    The gait is scaled to the body at :meth:`reset`
    (:meth:`~mjchar.controllers.walking.gaits.Gait.scaled`: times, gains and feedback by the body's
    leg length and mass against the gait's own body); :attr:`gait` is the gait in use from then on.

    Attributes (read by scenarios):
        state: FSM state 0-3 (0/1: ``first_stance`` leg on the ground; 0/2 lift-off, 1/3 swing).
        state_start: simulated time (s) the state began.
        stance: ``"left"`` or ``"right"``.
        transitions: list of ``(time s, new state)``.
        last_swing_target: ``(2,)`` swing-hip (sagittal, coronal) targets of the last step (rad).
        step_speed: mean forward speed of the centre of mass over the last step (m/s).
        speed_offset: the speed regulation's swing-hip offset (rad; 0 unless the gait has a
            ``speed_target``).
        leg_length: the body's leg length (m; hips' height over the soles at rest), after reset.
        command: with a speed command, the command in use (m/s): it starts at the gait's own
            speed and ramps to ``speed`` at the gait's ``speed_acceleration``, updated at every
            lift-off.
    """

    name = "simbicon"
    actuation = "torque"

    def __init__(
        self,
        gait: str | Gait | dict = "walk",
        *,
        heading: float | None = None,
        first_stance: str = "left",
        speed: float | None = None,
        **overrides,
    ):
        self.gait = self.base_gait = get_gait(gait, **overrides)
        if speed is not None:
            if not math.isfinite(speed) or speed <= 0.0:
                raise ControllerError(f"simbicon: the speed command must be > 0 m/s, got {speed}")
            self.base_gait.for_speed(1.0)  # a gait that takes no command fails here
        self.speed = speed
        self.command: float | None = None
        self.leg_length: float | None = None
        if first_stance not in _SIDES:
            raise ControllerError(f"first_stance must be 'left' or 'right', got {first_stance!r}")
        self.heading = heading
        self.first_stance = first_stance
        self.state = 0
        self.state_start = 0.0
        self.transitions: list[tuple[float, int]] = []
        self.last_swing_target = np.zeros(2)
        self.speed_offset = 0.0
        self.step_speed: float | None = None
        self._step_start: tuple[float, np.ndarray] | None = None
        self._targets_world: dict[str, tuple[float, float, np.ndarray]] = {}
        self._ready = False

    # -- set-up ---------------------------------------------------------------------------------
    def reset(self, character: Character) -> None:
        """Switch to torque actuation, map the model (hinges, signs, gains) and start state 0."""
        character.actuation.set_mode("torque")
        self._map(character)
        R = character.state.body_rotations[self._pelvis]
        self.desired_heading = heading_yaw(R) if self.heading is None else float(self.heading)
        self.state = 0
        self.state_start = character.time
        self.transitions = [(character.time, 0)]
        self.speed_offset = 0.0
        self.step_speed: float | None = None
        self._step_start = (character.time, character.state.com())
        self._command_time = character.time
        self._limits = character.actuation.torque_limits()[self._act_dof]
        # the clamps the step applies, as (low, high) per group (read per step, fixed here)
        lim = self._limits
        self._neg_limits = -lim
        for leg in self._legs:
            leg.hip_limits = (-lim[leg.hip_acts], lim[leg.hip_acts])
        self._pelvis_limits = [(-lim[a], lim[a]) for _, a in self._pelvis_children]
        self._ready = True

    def _body_gait(self, ch: Character) -> Gait:
        """The gait for this body (see the class docstring); with a speed command, the gait at
        the command's start (the gait's own speed)."""
        self.leg_length = ch.poses.leg_length()
        self._mass = ch.dynamics.mass
        g = self.base_gait
        missing = {f"gain_{k}": v for k, v in DEFAULT_GAINS.items() if k not in g.gains}
        if missing:
            g = g.with_overrides(**missing)
        self._full_gait = g
        if self.speed is None:
            return g.scaled(self.leg_length, ch.dynamics.mass)
        self._froude_unit = math.sqrt(GRAVITY * self.leg_length)  # m/s per Froude unit
        self.command = g.froude * self._froude_unit
        return self._command_gait(self.command)

    def _command_gait(self, v: float) -> Gait:
        """The body's gait for a commanded speed ``v`` (m/s): feed-forward and regulation."""
        g = self._full_gait.for_speed(v / self._froude_unit).scaled(self.leg_length, self._mass)
        return g.with_overrides(speed_target=float(v))

    def _ramp_command(self, t: float) -> None:
        """At a lift-off: move the command towards :attr:`speed` by at most
        ``speed_acceleration`` g since the last update, and take the gait for it."""
        t0, v0 = self._command_time, self.command
        dv = self.base_gait.speed_acceleration * GRAVITY * (t - t0)
        v = v0 + min(max(self.speed - v0, -dv), dv)
        self._command_time = t
        if v != v0:
            self.command = v
            self.gait = self._command_gait(v)
            self._targets = [self._state_targets(s) for s in range(4)]

    def _map(self, ch: Character) -> None:
        """Read the body at rest (:mod:`~mjchar.controllers.walking.rig_map`): an actuator per
        dof, the legs' hinges and signs (:func:`~mjchar.controllers.walking.rig_map.map_leg`),
        the upper body's base targets and gain groups
        (:func:`~mjchar.controllers.walking.rig_map.map_upper_body`), the gains
        (:meth:`_set_gains`) and the pelvis's other children, whose torques react on it."""
        acts = map_actuators(ch)
        self._act_dof, self._act_qpos = acts.act_dof, acts.act_qpos
        # the same as slices when contiguous (a view to read per step, not a gathered copy)
        self._act_dof_sel = _selector(self._act_dof)
        self._act_qpos_sel = _selector(self._act_qpos)
        self.gait = self._body_gait(ch)
        self._pelvis = ch.body_id(ch.role("pelvis"))
        # the body at rest: hinge axes and body positions with every joint at zero
        body = rest_body(ch, self._pelvis, acts.dof2act)
        self._legs = [map_leg(body, side) for side in _SIDES]
        self._jac = np.zeros((3, ch.nv))
        upper = map_upper_body(body, self._legs, self.gait.shoulder_down, self.gait.elbow_flexion)
        self._set_gains(ch, upper.group)
        self._base, self._spine_pitch, self._arm_swing = (upper.base, upper.spine_pitch,
                                                          upper.arm_swing)
        # hinges (other than the hips') of bodies attached to the pelvis: their torques react on
        # it; per body, (MuJoCo joints, actuators)
        hip_bodies = {leg.hip_body for leg in self._legs}
        self._pelvis_children = [(ch.dof_joint[dofs], acts.dof2act[dofs])
                                 for dofs in child_hinges(ch, self._pelvis, hip_bodies)]
        self._targets = [self._state_targets(s) for s in range(4)]

    def _set_gains(self, ch: Character, group: np.ndarray) -> None:
        """The joint-space gains per actuator (the model's defaults, the gait's per group) and
        the world-frame gains of the torso, swing hip and ankles."""
        g = self.gait
        kp, kd = ch.actuation.default_gains()
        kp, kd = kp[self._act_dof].copy(), kd[self._act_dof].copy()
        for grp, (gkp, gkd) in g.gains.items():
            sel = group == grp
            if grp in ("hip",):
                sel = group == "hip"
            kp[sel], kd[sel] = gkp, gkd
        self._kp, self._kd = kp, kd
        kpt, kdt = g.gains["torso"]
        kpy, kdy = g.gains.get("torso_yaw", (kpt, kdt))
        self._twist_kp, self._twist_kd = g.gains["stance_twist"]
        self._torso_kp = np.array([kpt, kpt, kpy])
        self._torso_kd = np.array([kdt, kdt, kdy])
        self._swing_gains = g.gains["swing_hip"]
        self._ankle_world_gains = g.gains["swing_ankle_world"]
        # the stance ankle's roll and twist hinges with gains of their own, if the gait has them
        self._stance_ankle_gains = {
            axis: g.gains[grp] for axis, grp in _STANCE_ANKLE_GROUPS.items() if grp in g.gains
        }
        self._swing_level_gains = g.gains.get("swing_ankle_level")

    def _stance_leg(self, state: int) -> int:
        first = _SIDES.index(self.first_stance)
        return first if state < 2 else 1 - first

    def _state_targets(self, state: int) -> np.ndarray:
        """``(nu,)`` local hinge targets of ``state`` (the hips are overwritten by the world-frame
        control every step)."""
        p = self.gait.states[state % 2]
        q = self._base.copy()
        st = self._legs[self._stance_leg(state)]
        sw = self._legs[1 - self._stance_leg(state)]
        q[st.knee.act] = st.knee_flex * knee_angle(p.stance_knee, st.knee_across)
        q[sw.knee.act] = sw.knee_flex * knee_angle(p.swing_knee, sw.knee_across)
        q[st.ankle["y"].act] = st.ankle_dorsi * p.stance_ankle
        q[sw.ankle["y"].act] = sw.ankle_dorsi * p.swing_ankle
        for a, s in self._spine_pitch:  # a speed command may move it (ANCHOR_FIELDS)
            q[a] = self.gait.spine_pitch * s
        # arms swing against the legs: the stance side's arm forward, the swing side's back
        for leg, sgn in ((st, 1.0), (sw, -1.0)):
            if leg.side in self._arm_swing:
                a, s = self._arm_swing[leg.side]
                q[a] = self._base[a] + s * sgn * self.gait.arm_swing
        return q

    # -- the finite-state machine ---------------------------------------------------------------
    @property
    def stance(self) -> str:
        """The stance leg now (``"left"``/``"right"``)."""
        return _SIDES[self._stance_leg(self.state)]

    def phase(self, t: float) -> float:
        """Fraction of the current state's duration elapsed at ``t`` (s)."""
        return (t - self.state_start) / self.gait.states[self.state % 2].duration

    def _advance(self, character: Character, t: float) -> None:
        p = self.gait.states[self.state % 2]
        phase = self.phase(t)
        if p.ends_on_contact:
            done = t - self.state_start >= p.timeout
        else:
            done = phase >= 1.0
        if not done and p.ends_on_contact and phase > self.gait.contact_phase:
            sw = 1 - self._stance_leg(self.state)
            if character.contacts.feet()[sw]:
                done = character.contacts.foot_forces()[sw] > self.gait.contact_force
        if done:
            self.state = (self.state + 1) % 4
            self.state_start = t
            self.transitions.append((t, self.state))
            if self.state % 2 == 0:
                if self.speed is not None:
                    self._ramp_command(t)
                self._step_update(character, t)

    def _step_update(self, character: Character, t: float) -> None:
        """At lift-off: the last step's mean forward speed and the speed regulation."""
        g = self.gait
        c = character.state.com()
        if self._step_start is not None:
            t0, c0 = self._step_start
            if t > t0:
                H = rot_z(self.desired_heading)
                self.step_speed = float((c - c0) @ H[:, 0]) / (t - t0)
                if g.speed_target is not None:
                    self.speed_offset = float(
                        np.clip(
                            self.speed_offset + g.speed_gain * (self.step_speed - g.speed_target),
                            -g.speed_limit,
                            g.speed_limit,
                        )
                    )
        self._step_start = (t, c)

    # -- control --------------------------------------------------------------------------------
    def torques(self, character: Character, t: float) -> np.ndarray:
        """``(nu,)`` actuator torques (N m) for this control step (advances the FSM first): local
        PD on every joint (the upper body's own control; the legs' base), the stance foot's and
        the swing sole's own terms, the torso in the world frame, the swing hip in the world frame
        with balance feedback, the torso through the stance hip, the virtual forces and the swing
        foot in the world frame."""
        if not self._ready:
            raise ControllerError("simbicon: act() called before reset()")
        self._advance(character, t)
        s = character.state
        g = self.gait
        q = s.qpos[self._act_qpos_sel]
        qd = s.qvel[self._act_dof_sel]
        com, com_vel = s.com(), s.com_velocity()  # (read once per step)
        si = self._stance_leg(self.state)
        st, sw = self._legs[si], self._legs[1 - si]
        tau = self._joint_pd(q, qd)
        self._stance_ankle(st, q, qd, tau)
        self._swing_sole_level(character, sw, tau)
        Rp = s.body_rotations[self._pelvis]
        heading = heading_yaw(Rp)
        H = rot_z(heading)
        tau_torso = self._torso(character, Rp)
        tau_sw = self._swing_hip(character, st, sw, H, heading, com, com_vel, q, qd, tau)
        self._stance_hip(character, st, tau_torso, tau_sw, q, qd, tau)
        if g.stance_support or g.velocity_force or g.velocity_force_coronal:
            tau[st.support_acts] += self._virtual_force(character, st, H, com, com_vel)
        if g.swing_ankle_world:
            self._swing_foot(character, sw, tau)
        return np.minimum(np.maximum(tau, self._neg_limits), self._limits)

    def act(self, character: Character, t: float) -> Action:
        """The :class:`~mjchar.controllers.core.base.Action` for simulated time ``t``: joint torques
        only (the root rows are zero: no hand of god)."""
        full = np.zeros(character.nv)
        full[self._act_dof_sel] = self.torques(character, t)
        return Action(torque=full)

    # -- upper body -----------------------------------------------------------------------------
    def _joint_pd(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """``(nu,)`` local PD towards the state's pose (:meth:`_state_targets`) on every joint:
        the whole control of the spine, head and arms (the arms swinging against the legs), and
        the legs' base that the stance and swing terms then overwrite."""
        return self._kp * (self._targets[self.state] - q) - self._kd * qd

    def _torso(self, character: Character, Rp: np.ndarray) -> np.ndarray:
        """``(3,)`` world torque that drives the torso (pelvis, rotation ``Rp``) towards the
        desired heading and the gait's forward lean: ``kp log(R_d R^T) - kd omega``; the stance
        hip applies it (:meth:`_stance_hip`)."""
        Rpd = self._world_target("torso", self.desired_heading, self.gait.torso_pitch)
        return (self._torso_kp * log(Rpd @ Rp.T)
                - self._torso_kd * character.state.body_angular_velocities[self._pelvis])

    # -- stance leg -----------------------------------------------------------------------------
    def _stance_ankle(self, st: SimbiconLeg, q: np.ndarray, qd: np.ndarray,
                      tau: np.ndarray) -> None:
        """The stance ankle's roll and twist hinges in ``tau`` with their own gains, if the gait
        has them (the swing ankle keeps ``ankle``'s)."""
        for axis, (kpa, kda) in self._stance_ankle_gains.items():
            h = st.ankle.get(axis)
            if h is not None:
                a = h.act
                tau[a] = kpa * (self._targets[self.state][a] - q[a]) - kda * qd[a]

    def _stance_hip(self, character: Character, st: SimbiconLeg, tau_torso: np.ndarray,
                    tau_sw: np.ndarray, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> None:
        """The torso's world torque ``tau_torso`` (:meth:`_torso`) through the stance hip:
        whatever makes the net torque of the joints on the pelvis the torso's (SIMBICON's rule,
        less the swing hip's ``tau_sw`` and the spine's clamped torques in ``tau``); its twist a
        local PD towards the desired heading."""
        s = character.state
        g = self.gait
        react = np.zeros(3)
        for (js, a), (lo, hi) in zip(self._pelvis_children, self._pelvis_limits, strict=True):
            clamped = np.minimum(np.maximum(tau[a], lo), hi)
            tau[a] = clamped
            react += world_torque(s.joint_axes[js], clamped)
        tau_st = -tau_torso - tau_sw - react
        acts = st.hip_acts
        if "z" in st.hip:
            # Its vertical part turns the pelvis only as far as the stance foot's friction holds
            # (and spins a lightly loaded leg), so the heading is a local PD on the hip twist
            # towards the twist that points the pelvis at the desired heading.
            tau_st[2] = 0.0
            hz = st.hip["z"]
            tau[acts] = s.joint_axes[st.hip_joints] @ tau_st
            thigh_yaw = heading_yaw(s.body_rotations[st.hip_body])
            err = math.remainder(thigh_yaw + st.knee_yaw - self.desired_heading, 2 * math.pi)
            want = st.twist_sign * (min(max(err, -g.max_twist), g.max_twist) - st.knee_yaw)
            tau[hz.act] = self._twist_kp * (want - q[hz.act]) - self._twist_kd * qd[hz.act]
        else:
            tau[acts] = s.joint_axes[st.hip_joints] @ tau_st

    def _virtual_force(self, character: Character, st: SimbiconLeg, H: np.ndarray,
                       com: np.ndarray | None = None, com_vel: np.ndarray | None = None
                       ) -> np.ndarray:
        """Torques of the stance ankle and knee that put a virtual force on the centre of mass
        with the stance foot fixed (``tau_j = -a_j . ((c - x_j) x F)``): a share of the weight
        (``stance_support``) and Coros 2010's velocity tuning (``velocity_force``)."""
        g, s = self.gait, character.state
        weight = self._mass * GRAVITY
        unit = math.sqrt(GRAVITY * self.leg_length)  # m/s per Froude unit
        v = s.com_velocity() if com_vel is None else com_vel
        lat = -st.out[1] * H[:, 1]
        F = np.array([0.0, 0.0, g.stance_support * weight])
        if g.velocity_force and g.speed_target is not None:
            F += g.velocity_force * weight * (g.speed_target - v @ H[:, 0]) / unit * H[:, 0]
        if g.velocity_force_coronal:
            F -= g.velocity_force_coronal * weight * (v @ lat) / unit * lat
        js = st.support_joints
        r = (s.com() if com is None else com) - s.joint_anchors[js]
        return -np.einsum("ij,ij->i", s.joint_axes[js], cross_rows(r, F))

    # -- swing leg ------------------------------------------------------------------------------
    def _swing_sole_level(self, character: Character, sw: SimbiconLeg, tau: np.ndarray) -> None:
        """In a swing state, with the gait's ``swing_ankle_level`` gains: the swing foot's roll
        in ``tau`` levels its sole in the world (its left axis horizontal), so the heel lands on
        its whole width rather than on one corner."""
        if self._swing_level_gains and self.state % 2 == 1 and "x" in sw.ankle:
            s = character.state
            kpl, kdl = self._swing_level_gains
            f, lat = (s.body_rotations[sw.ankle_body] @ sw.foot_axes).T
            f = f / np.linalg.norm(f)
            w = s.body_angular_velocities[sw.ankle_body] @ f
            tau_l = (-kpl * lat[2] / np.linalg.norm(lat) - kdl * w) * f
            h = sw.ankle["x"]
            tau[h.act] = s.joint_axes[h.jnt] @ tau_l

    def _swing_hip(self, character: Character, st: SimbiconLeg, sw: SimbiconLeg, H: np.ndarray,
                   heading: float, com: np.ndarray, com_vel: np.ndarray, q: np.ndarray,
                   qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """The swing hip towards the balance feedback's target, ``theta_d = theta_d0 + cd d +
        cv v`` (sagittal and coronal), in the heading frame; its twist local; the swing leg's
        weight compensated; clamped. Sets ``tau``'s swing hip; returns its world torque."""
        s = character.state
        g = self.gait
        p = g.states[self.state % 2]
        dd, vv = self._feedback_terms(character, st, H, com, com_vel)
        sag = p.swing_hip + p.cd * dd[0] + p.cv * vv[0] + self.speed_offset
        cor = p.swing_hip_coronal + p.cd_coronal * dd[1] + p.cv_coronal * vv[1]
        self.last_swing_target = np.array([sag, cor])

        # the thigh's direction u -> u_d
        u_d = H @ (rot_x(sw.abd_sign * cor) @ (rot_y(sw.flex_sign * sag) @ sw.thigh_dir))
        u = s.body_rotations[sw.hip_body] @ sw.thigh_dir
        w = s.body_angular_velocities[sw.hip_body]
        kps, kds = self._swing_gains
        tau_w = kps * angle_between(u, u_d) - kds * (w - (w @ u) * u)
        acts = sw.hip_acts
        axes_sw = s.joint_axes[sw.hip_joints]
        tau[acts] = axes_sw @ tau_w
        if "z" in sw.hip:
            # its twist stays local, towards the twist that points the foot at the desired
            # heading (thigh yaw = pelvis yaw + s q_twist)
            hz = sw.hip["z"]
            err = math.remainder(self.desired_heading - heading, 2 * math.pi)
            want = sw.twist_sign * (min(max(err, -g.max_twist), g.max_twist) - sw.knee_yaw)
            tau[hz.act] = self._kp[hz.act] * (want - q[hz.act]) - self._kd[hz.act] * qd[hz.act]
        if g.swing_gravity:
            # the swing leg's weight by Jacobian transpose (Coros et al. 2010)
            character.dynamics.com_jacobian(sw.hip_body, out=self._jac)
            tau[sw.leg_acts] += (g.swing_gravity * GRAVITY * sw.leg_mass
                                    * self._jac[2, sw.leg_dofs])
        lo, hi = sw.hip_limits
        clamped = np.minimum(np.maximum(tau[acts], lo), hi)
        tau[acts] = clamped
        return world_torque(axes_sw, clamped)

    def _feedback_terms(
        self, character: Character, st: SimbiconLeg, H: np.ndarray,
        com: np.ndarray | None = None, com_vel: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The balance feedback's ``(d, v)``, each ``(2,)`` (sagittal, coronal) in the heading
        frame ``H``: the centre of mass's offset from the stance ankle (m) and its velocity
        (m/s); coronal: towards the swing leg's side."""
        s = character.state
        fwd, lat = H[:, 0], -st.out[1] * H[:, 1]  # lateral: towards the swing leg's side
        off = (s.com() if com is None else com) - s.body_positions[st.ankle_body]
        v = s.com_velocity() if com_vel is None else com_vel
        return (np.array([off @ fwd, off @ lat]), np.array([v @ fwd, v @ lat]))

    def _swing_foot(self, character: Character, sw: SimbiconLeg, tau: np.ndarray) -> None:
        """The swing foot pitched by ``swing_ankle`` (toes up) in the desired-heading frame,
        PD in the world frame."""
        s = character.state
        p = self.gait.states[self.state % 2]
        Rfd = self._world_target("foot", self.desired_heading,
                                 sw.foot_pitch_sign * p.swing_ankle)
        Rf = s.body_rotations[sw.ankle_body]
        kpa, kda = self._ankle_world_gains
        tau_f = kpa * log(Rfd @ Rf.T) - kda * s.body_angular_velocities[sw.ankle_body]
        tau[sw.ankle_acts] = s.joint_axes[sw.ankle_joints] @ tau_f

    # -- world-frame targets --------------------------------------------------------------------
    def _world_target(self, key: str, yaw: float, pitch: float) -> np.ndarray:
        """``(3, 3)`` ``R_z(yaw) R_y(pitch)``: a world target orientation (torso, swing foot),
        kept while its angles stay the same (they change at a new heading or gait)."""
        cache = self._targets_world
        hit = cache.get(key)
        if hit is None or hit[0] != yaw or hit[1] != pitch:
            hit = (yaw, pitch, rot_z(yaw) @ rot_y(pitch))
            cache[key] = hit
        return hit[2]

    # -- start states --------------------------------------------------------------------------
    def start_state(
        self,
        character: Character,
        rng: np.random.Generator | None = None,
        *,
        joint_noise: float = 0.02,
        velocity_noise: float = 0.05,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(qpos (nq,), qvel (nv,))``: the gait's standing start (arms down, lean, knees) on the
        floor, moving forward at ``start_speed`` m/s, with small random perturbations from
        ``rng`` (joint angles ~N(0, ``joint_noise``) rad, root velocity ~N(0, ``velocity_noise``)
        m/s per horizontal axis) when given. Call after :meth:`reset` or it resets the mapping
        itself without touching the state."""
        if not self._ready:
            self._map(character)
            self._ready = True
        q = character.poses.rest()
        targets = self._state_targets(3)  # both legs nearly straight, stance-knee flexion
        q[self._act_qpos] = targets
        for leg in self._legs:
            q[leg.knee.qadr] = leg.knee_flex * knee_angle(
                self.gait.states[1].stance_knee, leg.knee_across)
            q[leg.ankle["y"].qadr] = leg.ankle_dorsi * self.gait.states[1].stance_ankle
        if self.gait.torso_pitch:
            # lean the pelvis and give it back at the hips so the legs stay vertical
            qw = math.cos(0.5 * self.gait.torso_pitch)
            qy = math.sin(0.5 * self.gait.torso_pitch)
            root_quat = character.root_qpos[3:7]
            q[root_quat] = [qw, 0.0, qy, 0.0]
            for leg in self._legs:
                h = leg.hip["y"]
                q[h.qadr] = leg.hip_flex * self.gait.torso_pitch
        qv = np.zeros(character.nv)
        if rng is not None:
            q[self._act_qpos] += rng.normal(0.0, joint_noise, size=len(self._act_qpos))
            lo, hi = character.poses.dof_limits(self._act_dof).T
            q[self._act_qpos] = np.clip(q[self._act_qpos], lo, hi)
            qv[character.root_dofs[:2]] = rng.normal(0.0, velocity_noise, size=2)
        qv[character.root_dofs[0]] += self.gait.start_speed
        q = character.poses.on_floor(q, clearance=0.0)
        return q, qv


def make_simbicon(
    character: Character | None = None, gait: str | Gait | dict = "walk", *, calibration=None,
    **overrides
) -> Simbicon:
    """The SIMBICON controller for ``character`` (its body's calibration; the controller binds
    to a character at ``reset``) with ``gait`` and parameter ``overrides``.

    ``calibration`` (the ``walk`` gait's only): ``None`` (the body's stored calibration, made
    first if missing, :func:`~mjchar.controllers.walking.calibration.overrides_for`),
    ``"none"`` (the gait as it is) or a calibration file; ``overrides`` override it.

    Besides gait parameters, ``heading`` (rad), ``first_stance`` and ``speed`` (m/s; ``None``:
    the gait's own) go to :class:`Simbicon`.
    """
    if isinstance(gait, str) and gait == "walk":
        overrides = {**overrides_for(character, "simbicon", calibration), **overrides}
    kw = {k: overrides.pop(k) for k in ("heading", "first_stance", "speed") if k in overrides}
    return Simbicon(gait, **kw, **overrides)


def simbicon_tunables(gait: str = "walk") -> list:
    """What ``--param`` takes (``mjchar params simbicon``), with the defaults of ``gait`` (gain
    groups the gait leaves out: :data:`DEFAULT_GAINS`, else the model's gains table)."""
    if not isinstance(gait, str) or gait not in GAITS:
        raise GaitError(f"unknown gait {gait!r}; choose from {', '.join(GAITS)}")
    rows = []
    for t in gait_tunables(GAITS[gait]):
        group = t.name[5:] if t.name.startswith("gain_") else None
        if group is not None and t.default is None:
            t = (t._replace(default=DEFAULT_GAINS[group]) if group in DEFAULT_GAINS
                 else t._replace(meaning=t.meaning + "; default: the model's gains table"))
        rows.append(t)
    return rows


register(ControllerSpec(
    name="simbicon", label="SIMBICON walk", kind="walker",
    factory=lambda character, target=None, **options: make_simbicon(character, **options),
    abilities=("walk",), default_scenario="walk",
    options=("gait", "speed", "params", "calibration"),
    # the speed command (0.6-1.6 m/s): 60 s with no fall and a steady speed within
    # 0.15 m/s of the command at 0.6-1.6 m/s, seeds 0-2, on the bundled humanoid (walk; natural
    # 30 s), at the same Froude speeds on its skeleton scaled to 1.5 m / 50 kg and 1.95 m /
    # 100 kg (walk and natural, seeds 0-2), and at 0.7, 1.1 and 1.5 m/s on every rig of the
    # skeleton zoo (docs/simbicon.md); no --speed: the gait's own
    limits=(("speed", 0.6, 1.6),), speed_leg_length=BUNDLED_LEG_LENGTH,
    speed_every_body=(0.7, 1.5),
    timestep=DEFAULT_TIMESTEP, push="walking", tunables=simbicon_tunables,
    bench=("walk", "push-search", "slopes"), expected=("walk",)))
