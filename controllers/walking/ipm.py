"""IPM stepping: generalised biped walking control (Coros, Beaudoin, van de Panne, SIGGRAPH 2010).

No force is ever applied to the root: the character starts from standing, walks, stops, turns
and recovers from pushes with joint torques only (torque actuation; the PD terms are computed
here every physics step, their damping evaluated implicitly, see below).

Per step (stance foot on the ground, swing foot in the air, nominal step time ``T``; the step
ends when the swing foot touches the ground after half the step):

1. **Foot placement** from an inverted pendulum that comes to rest over the foot. With the COM
   velocity ``v`` in the heading frame (the pelvis's yaw) and ``h`` the COM height over the
   stance foot (:func:`ipm_step_offset`, :meth:`IPMController.foot_placement`)::

       d(v) = v * sqrt(h / g + v^2 / (4 g^2))
       d_sagittal = s_s d(v_s) - k_v v_d - b        b: integral speed bias, updated every step
       d_coronal  = s_c d(v_c) +- w                 w towards the swing side

   relative to the COM, at least ``placement.min_width`` beside the stance foot (no crossed
   legs; the hip width when coming to a stop with the COM's sideways speed under
   ``standing.stop_speed``: a step widened across a sideways drift puts the COM outside the new
   stance foot), each axis clamped to +-0.4 leg length (``placement.clamp``).
2. **Swing foot** (:class:`~mjchar.controllers.walking.swing.SwingTrajectory`): sole height through
   ``swing.heights`` at phases 0, 0.5, 1 (then sinking until contact); the horizontal offset from
   the COM blends from the lift-off offset to the IPM point. Hip and knee come from analytic
   two-link IK (:func:`~mjchar.controllers.walking.swing.two_link_ik`) for the ankle; the foot is
   kept flat at the desired heading.
3. **Tracking**: the swing thigh, both feet and the pelvis are PD-controlled in the world frame
   (a world torque ``T = kp log(R_bar R^T) + kd (omega_bar - omega)`` mapped to a joint's hinges
   by their world axes, ``tau = A^T T``); the swing thigh and knee follow the IK targets'
   velocities (finite differences). Knees, spine, arms, head and toes are PD-controlled in joint
   space. The stance hip takes what the pelvis needs (SIMBICON's rule, extended to every joint
   acting on the pelvis)::

       T_stance_hip = -T_pelvis - T_swing_hip - T_spine

   Its vertical component is limited to what the stance foot's contact patch can hold
   (``stance.yaw_friction m g r``), and the stance ankle's moment to what keeps the centre of
   pressure inside the foot (``stance.ankle_limit``), so the stance foot neither spins nor rolls;
   in a turning step that pressure stays ahead of the ankle and nearer the foot's middle
   (``turning.ankle_limit``): a foot rocked back onto its heel edge holds half the yaw moment, on
   one heel corner none.
4. **Gravity compensation**: an upward ``m_i g`` at the COM of every link that is not part of the
   stance leg, mapped by the Jacobian transpose to the joints between the link and the pelvis;
   for dof ``j`` (axis ``a_j`` at ``p_j``) with subtree mass ``M_j`` and subtree COM ``C_j``
   this is ``tau_j = a_j . ((C_j - p_j) x M_j g z)``.
5. **Speed control**: a virtual force on the COM::

       F = m [30 (v_d - v_s),  c_p (-d_c) + c_v (v_dc - v_c)]     (clamped to 60 N / 100 N)

   with ``d_c`` the coronal COM offset from the stance foot, realised by the stance leg
   (hip, knee, ankle) as ``tau = -J_x^T F``, ``J_x`` the Jacobian of the COM point attached to the
   stance foot (as in :mod:`mjchar.controllers.balance.static_balance`).

The damping of all these PD terms is linear in ``qdot``: ``tau = tau0 - D qdot``. Explicitly the
pelvis term, applied through the stance hip to the light pelvis body, oscillates at the model's
2 ms step (it needs about 0.5 ms); with ``tracking.implicit_damping`` it is evaluated at the next
step's velocity as stable PD does (Tan, Liu, Turk 2011), generalised to the non-diagonal ``D``::

    (M + dt D) qddot = tau0 - D qdot - C + tau_ext,    tau = tau0 - D (qdot + dt qddot)

solved without forming ``M + dt D`` (:class:`~.ipm_torques.Damping`: MuJoCo's sparse
factorisation of ``M`` plus the diagonal and the stance foot's twist block, the hips' full rows
by the Woodbury identity).

Commands: a desired forward speed (m/s) and a desired heading (degrees, world yaw: 0 = +X,
counter-clockwise), each a number or a function of time. The speed target follows the command at
``speed.acceleration``; the heading target turns at ``turning.rate`` (less when fast); swing
feet land turned with it. Steps that start while it turns, or within ``turning.hold`` after, are
turning steps (the stance ankle's ``turning.ankle_limit``); a walk whose heading command stays
at its start heading never takes one.

Standing: the controller starts standing and stands whenever nothing is commanded, with
:class:`~mjchar.controllers.balance.static_balance.StaticBalance` on a standing pose fitted to where
the feet are (feet flat, the pelvis low enough that each leg reaches its foot with the knee bent
``stance.knee``). A speed or heading command starts a walk with a short first step (the COM,
centred between the feet, falls a little towards the swing side, which starts the lateral sway);
a push starts stepping when the capture point ``c + v sqrt(h/g)`` leaves the support polygon. A
zero command brings the character to a stop: a step ends in standing once the sagittal speed is
low and the capture point is over both feet.

Defaults differ from the paper where this humanoid and MuJoCo's contacts needed it (measured in
docs/ipm.md): step time 0.5 s (paper ~0.6), scales ``s_s = s_c = 1.0`` (1.1 / 1.3), ``k_v = 0.1``
(0.05) plus the integral bias, ``w = 0.03`` m (~0.1), final swing height 0.02 m (0.05), a smooth
blend (``(1 - phase)^2`` is available), swing hip 600/60 (300/35), pelvis yaw 300/60 (1000/200)
and no coronal virtual force (20 / 9): the stance ankle cannot apply the roll moment it asks for.

Speed dependence (:meth:`IPMParams.at_speed` and the weights beside it, taken at every step
start from the ramped speed target; the groups ``speed``, ``human`` and ``feet`` of
:class:`IPMParams`): up to 1.0 m/s 0.5 s steps and a plain PD stance knee (kp 300) on
``stance.knee``; from 1.1 m/s 0.4 s steps whose rate keeps growing with speed
(``timing.cadence_gain``) and a soft stance knee (kp 200) easing from its landing flexion (at
most 0.9 rad), so long steps that land on a bent knee are not pulled straight at once (that
saturated the knee: 1.2 m/s fell at 16.5 s). Between them, from 1.1 to 1.35 m/s and giving way
by 1.6, a human-like band (``human.*``): ~0.47 s steps, a stiff stance knee from landing,
narrower lateral steps, a 5 cm swing. The feet's measures (``feet.*``: the swing target 0.12 m
up at lift-off, toes up, push-off late in stance so the heel lifts, a toe-up ankle limit of
0.01 m x body weight so the foot stays flat, harder twist damping over the planted foot) blend
in with the band and hold above it, the toe-up limit from 0.7-0.9 m/s: stance slip 0.46-0.95 cm
per step at 0.6, 0.8-1.4 m/s (docs/ipm.md).

Use :func:`make_ipm` or :class:`IPMController` directly::

    ch = Character()
    ctrl = make_ipm(ch, speed=1.0, heading=0.0)
    result = scenarios.walk(ch, ctrl, duration=20.0)
"""

from __future__ import annotations

import math

import numpy as np

from ..balance.static_balance import StaticBalance
from ..core.base import Action
from ..core.character import Character
from ..core.geometry import heading_yaw, point_in_polygon_margin, smoothstep
from ..core.registry import ControllerSpec, register
from .calibration import overrides_for
from .ipm_params import GRAVITY, TUNED_LEG_LENGTH, IPMError, IPMParams, ipm_step_offset, schedule
from .ipm_torques import Damping, GravityCompensation, limit_stance_ankle, limit_stance_yaw
from .leg import (
    Leg,
    index_selector,
    inverse3,
    mat_quat,
    matvec3,
    quat_about,
    quat_error,
    quat_mul,
    solve3,
    wrap_angle,
)
from .rig_map import child_hinges
from .standing import arms_down_pose, standing_pose
from .swing import (
    SwingTrajectory,
    frame_from_axes3,
    hinge_leg_ik,
    rotation_z,
    two_link_ik3,
)

_LEFT, _RIGHT = 0, 1
_Y = (0.0, 1.0, 0.0)
_Z = (0.0, 0.0, 1.0)


class IPMController:
    """IPM stepping with no root force; see the module docstring.

    Args:
        speed: desired forward speed (m/s) in the heading frame, a number or ``t -> m/s``.
        heading: desired heading (degrees, world yaw, 0 = +X, counter-clockwise), a number,
            ``t -> degrees`` or ``None`` (keep the heading the character starts with).
        lateral_speed: desired coronal speed (m/s, + = left), a number or ``t -> m/s``.
        params: an :class:`IPMParams` (default: the defaults).
        overrides: parameters by dotted name, ``**{"timing.step_time": 0.45}`` (what
            ``mjchar run ipm --param timing.step_time=0.45`` passes), applied to ``params`` by
            :meth:`IPMParams.updated`: an unknown name or a value the parameter does not accept
            raises :class:`IPMError`.

    Attributes (readable during a run):
        mode: ``"step"`` or ``"stand"``.
        stance: ``"left"`` or ``"right"`` (the stance foot while stepping, else ``None``).
        phase: step phase (0 at lift-off, 1 at the nominal step time).
        steps: number of completed steps.
        last_offset: ``(2,)`` last IPM step offset (sagittal, coronal) from the COM (m).
        last_force: ``(3,)`` last virtual COM force (N, world).
        speed_target: the ramped desired speed (m/s) in use.
        heading_target: the rate-limited desired heading (rad) in use.
        stand_switches: times (s) the controller switched to standing; ``step_switches`` when
            each step started.
        transitions: ``(time, state)`` at every step start, SIMBICON-style: state 0 when a
            left-stance step starts, 2 for a right-stance one (a stride runs from one 0 to the
            next), so :func:`mjchar.controllers.core.terrain.push_walk` can push IPM at a stride
            phase.
    """

    name = "ipm"
    actuation = "torque"

    def __init__(self, speed=0.0, heading=None, *, lateral_speed=0.0,
                 params: IPMParams | None = None, **overrides):
        base = params if params is not None else IPMParams()
        #: the parameters as given (for the tuned body, see ``ipm_params.TUNED_LEG_LENGTH``);
        #: ``params`` is them carried to the driven body at :meth:`reset`
        self.body_params = base.updated(overrides)
        self.params = self.body_params
        self.speed = schedule(speed, "speed")
        self.heading = schedule(heading, "heading", math.pi / 180.0)
        self.lateral_speed = schedule(lateral_speed, "lateral_speed")
        sw = self.params.swing
        self.trajectory = SwingTrajectory(sw.heights, sw.descent_speed, blend=sw.blend)
        self._ready = False

    # -- set-up -------------------------------------------------------------------------------
    def reset(self, character: Character) -> None:
        """Switch to torque actuation, index the legs and the pelvis, and pick the first mode
        from the commands at time 0."""
        ch = character
        ch.actuation.set_mode("torque")
        rest = ch.poses.kinematics(ch.poses.rest())
        self._rest_axes = rest.joint_axes  # the joints' world axes at rest
        self._legs = (Leg(ch, "left", rest), Leg(ch, "right", rest))
        self._pelvis = ch.root_body
        self.leg_length = self._legs[0].l1 + self._legs[0].l2 + float(-self._legs[0].site_offset[2])
        self.mass = ch.dynamics.mass
        self.params = self.body_params.for_body(self.leg_length, self.mass)
        sw = self.params.swing
        self.trajectory = SwingTrajectory(sw.heights, sw.descent_speed, blend=sw.blend)
        self._trajectory = self.trajectory
        # the ball of each foot (its toe joint) ahead of the ankle (m): how far forward the
        # pressure can go once the heel is up in push-off (the forward ankle limit without toes)
        # (horizontal, in the rest pose: a rig's foot frame need not be level)
        fwd = self.params.stance.ankle_limit[0] if self.params.stance.ankle_limit else 0.0
        self._ball = {lg.side: float(np.linalg.norm(
            (rest.body_positions[ch.body_id(lg.toe_name)] - rest.body_positions[lg.foot])[:2]))
            if lg.toe_name else fwd for lg in self._legs}
        self._human = self._foot = self._back = self._push_w = 0.0
        # hinges acting directly on the pelvis other than the hips (the spine), (joints, dofs)
        # per body; only 3-dof joints are mapped to a world torque
        thighs = {lg.thigh for lg in self._legs}
        self._pelvis_children = [(index_selector(ch.dof_joint[dofs]), index_selector(dofs))
                                 for dofs in child_hinges(ch, self._pelvis, thighs)
                                 if len(dofs) == 3]
        self._index_dofs(ch)
        standing = ch.poses.standing()
        soles = ch.poses.kinematics(standing).site_positions
        self._root_above_soles = float(standing[ch.root_qpos[2]] - np.mean(
            [soles[lg.site][2] for lg in self._legs]))
        anchors = ch.state.joint_anchors
        self.stand_width = float(np.linalg.norm(anchors[self._legs[0].hip_jnt[0]]
                                                - anchors[self._legs[1].hip_jnt[0]]))
        self._reset_commands(ch)

    def _index_dofs(self, ch: Character) -> None:
        """The per-dof data of the torques, looked up once: the upper body's dofs (every
        actuated dof off the legs, and the toes), its PD gains and pose, the gravity
        compensation and the damping per swing leg, scratch buffers."""
        self._act = np.flatnonzero(ch.actuated)
        legs = np.concatenate([lg.all for lg in self._legs])
        upper = np.setdiff1d(self._act, legs)
        toes = np.concatenate([lg.toe for lg in self._legs])
        self._upper = np.concatenate([upper, toes]).astype(int)
        if not ch.hinge_dofs[self._upper].all():
            body = ch.dof_body[self._upper[np.flatnonzero(~ch.hinge_dofs[self._upper])[0]]]
            joint = next(n for n, b in zip(ch.joint_names, ch.joint_bodies, strict=True)
                         if b == body)
            raise IPMError(f"IPM needs hinge joints in the upper body too (joint {joint} is a "
                           "ball joint): convert with --joint-model hinge (joint_model='hinge')")
        self._upper_q = ch.dof_qpos[self._upper]
        self._gravity = [GravityCompensation(ch, np.concatenate([self._upper, lg.all]))
                         for lg in self._legs]
        kp, kd = ch.actuation.default_gains()
        s = self.params.upper.gain_scale
        self._upper_kp = kp[self._upper] * s
        self._upper_kd = kd[self._upper] * s
        self._limits = ch.actuation.torque_limits()
        self._neg_limits = -self._limits
        self.upper_pose = arms_down_pose(ch, self.params.upper.arm_abduction)
        self._q_upper = self.upper_pose[self._upper_q]
        # the same over every dof (zero gain elsewhere): the upper body's PD in three products
        self._upper_kp_nv = np.zeros(ch.nv)
        self._upper_kp_nv[self._upper] = self._upper_kp
        self._upper_qadr_nv = np.zeros(ch.nv, dtype=np.intp)
        self._upper_qadr_nv[self._upper] = self._upper_q
        self._q_upper_nv = self.upper_pose[self._upper_qadr_nv]
        # the damping of the PD terms per swing leg (ipm_torques.Damping): per dof the knees',
        # the feet's and the upper body's; full rows on both hips (swing hip, then stance hip);
        # the stance foot's twist block
        tr = self.params.tracking
        self._damping = []
        for i, sw in enumerate(self._legs):
            st = self._legs[1 - i]
            d = np.zeros(ch.nv)
            d[sw.knee_dof] = d[st.knee_dof] = tr.knee_kd
            d[sw.ankle] = tr.swing_ankle_kd
            d[st.ankle] = tr.ankle_kd
            d[self._upper] = self._upper_kd
            self._damping.append(Damping(ch, d, [sw.hip, st.hip], st.ankle))
        self._jac_buffers = [(np.zeros((3, ch.nv)), np.zeros((3, ch.nv))) for _ in range(3)]
        self._stance_leg_mask = [np.isin(np.arange(ch.nv), self._legs[1 - i].leg).astype(float)
                                 for i in range(2)]
        self._pelvis_kd = np.array([[-tr.pelvis_kd], [-tr.pelvis_kd], [-tr.pelvis_yaw_kd]])
        self._heading_cache = (None, None, None)
        # the inverse of each thigh's rest frame (R_thigh = F thigh_rest^T), as a quaternion
        self._thigh_rest_inv = {}
        for lg in self._legs:
            w, x, y, z = mat_quat(lg.thigh_rest)
            self._thigh_rest_inv[lg.side] = [w, -x, -y, -z]
        self._pelvis_cache = (None, None)

    def _reset_commands(self, ch: Character) -> None:
        """The commands and the state at the start: standing, at the current heading."""
        self._start_yaw = heading_yaw(ch.state.body_rotations[self._pelvis])
        self.heading_target = self._start_yaw
        self.speed_target = self.speed_bias = self._heading_rate = 0.0
        self._stopping = self._turning = False
        self._turned = -math.inf
        self._last_t = ch.time
        self.steps = 0
        self.stand_switches: list[float] = []
        self.step_switches: list[float] = []
        self.transitions: list[tuple[float, int]] = []
        self.last_offset = np.zeros(2)
        self.last_force = np.zeros(3)
        self.phase = 0.0
        self._stand: StaticBalance | None = None
        self._ready = True
        self._reset_time = ch.time
        self._walk_cache = (None, False)
        # always settle on both feet first (the start pose may not even touch the floor yet)
        self._start_standing(ch, ch.time)

    # -- commands -----------------------------------------------------------------------------
    def desired_speed(self, t: float) -> float:
        """Desired forward speed (m/s) at ``t``."""
        return float(self.speed(t) or 0.0)

    def desired_heading(self, t: float) -> float:
        """Desired heading (rad, world yaw) at ``t``."""
        h = self.heading(t)
        return self._start_yaw if h is None else h

    @property
    def stance(self) -> str | None:
        """``"left"`` or ``"right"``: the stance foot while stepping (``None`` when standing)."""
        if not self._ready or self.mode != "step":
            return None
        return "right" if self._swing == _LEFT else "left"

    def _update_commands(self, t: float) -> None:
        """Move the speed target towards the command at ``speed.acceleration`` m/s^2 and the heading
        target towards the commanded heading at the turn rate (sets ``_heading_rate``)."""
        p = self.params
        dt = max(t - self._last_t, 0.0)
        self._last_t = t
        err = self.desired_speed(t) - self.speed_target
        step = p.speed.acceleration * dt
        self.speed_target += max(-step, min(step, err))
        err = wrap_angle(self.desired_heading(t) - self.heading_target)
        rate = min(p.turning.rate, p.turning.acceleration / max(abs(self.speed_target), 1e-3))
        step = rate * dt
        self.heading_target = wrap_angle(self.heading_target + max(-step, min(step, err)))
        self._heading_rate = rate * (1.0 if err > step else -1.0 if err < -step else 0.0)
        if self._heading_rate != 0.0:
            self._turned = t

    def _wants_to_walk(self, ch: Character, t: float) -> bool:
        """Whether the commands at ``t`` ask for walking (a speed, or a heading away from the
        pelvis's); evaluated once per control step."""
        if self._walk_cache[0] == t:
            return self._walk_cache[1]
        R = ch.state.body_rotations[self._pelvis]
        turn = abs(wrap_angle(self.desired_heading(t) - heading_yaw(R)))
        walk = (abs(self.desired_speed(t)) > 0.05 or abs(float(self.lateral_speed(t) or 0)) > 0.05
                or turn > self.params.standing.heading_tolerance)
        self._walk_cache = (t, walk)
        return walk

    # -- mode switches ------------------------------------------------------------------------
    def _start_stepping(self, ch: Character, t: float, swing: int,
                        duration: float | None = None) -> None:
        self.mode = "step"
        self._stand = None
        self._swing = swing
        self._t0 = t
        p = self.params
        step_time, self._knee_kp, self._knee_ramp = p.at_speed(self.speed_target)
        self._human = w = p.human_weight(self.speed_target)
        # the feet's measures (lift-off, toes up, push-off, twist damping) hold above the band
        self._foot = fw = p.speed_blend(self.speed_target)
        self._back = p.ankle_back_weight(self.speed_target)
        self.trajectory = self._trajectory
        if w > 0 or fw > 0:  # a lower swing, lifted off at once, at human-like speeds
            h0, h1, h2 = p.swing.heights
            self.trajectory = SwingTrajectory((h0 + fw * (p.feet.liftoff_height - h0),
                                               h1 + w * (p.human.swing_height - h1), h2),
                                              p.swing.descent_speed, blend=p.swing.blend)
        self._T = step_time if duration is None else duration
        # a step that starts while the heading target turns keeps its centre of pressure ahead
        # of the ankle: rocked back onto its heel edge the foot holds little yaw moment
        self._turning = t - self._turned <= self.params.turning.hold
        self.phase = 0.0
        self._liftoff = self._foot_offset(ch, swing)
        self._liftoff_xy = tuple(self._liftoff.tolist())
        self._prev_swing = None
        self._step_com0 = ch.state.com()
        self._knee0 = min(float(ch.state.qpos[self._legs[1 - swing].knee_q]),
                          self.params.stance.knee_ramp_max)
        self.step_switches.append(t)
        # SIMBICON-style FSM log (state 0: a left-stance step starts, 2: a right-stance step), so
        # stride-phase tools (mjchar.controllers.core.terrain.push_walk) work with IPM too
        self.transitions.append((t, 2 if swing == _LEFT else 0))

    def _start_standing(self, ch: Character, t: float) -> None:
        self.mode = "stand"
        pose = self._standing_pose(ch)
        self._stand = StaticBalance(pose)
        self._stand.reset(ch)
        self.stand_switches.append(t)

    def _standing_pose(self, ch: Character) -> np.ndarray:
        """``(nq,)`` a standing pose for the feet where they are
        (:func:`~.standing.standing_pose`): upper body as :attr:`upper_pose`, knees bent as
        the stance knee while walking."""
        return standing_pose(ch, self._legs, self._upper_q, self.upper_pose, self._rest_axes,
                             self._root_above_soles, self.params.stance.knee)

    def _foot_offset(self, ch: Character, side: int) -> np.ndarray:
        """``(2,)`` (sagittal, coronal) offset of a foot sole from the COM, heading frame."""
        c = ch.state.com()
        p = ch.state.site_positions[self._legs[side].site]
        f, l = self._heading_axes(ch)
        d = p[:2] - c[:2]
        return np.array([d @ f[:2], d @ l[:2]])

    def _heading_axes(self, ch: Character) -> tuple[np.ndarray, np.ndarray]:
        yaw = heading_yaw(ch.state.body_rotations[self._pelvis])
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([c, s, 0.0]), np.array([-s, c, 0.0])

    # -- the step -----------------------------------------------------------------------------
    def foot_placement(self, v_heading: np.ndarray, h: float, swing: int, v_desired: float,
                       stance_lateral: float | None = None) -> np.ndarray:
        """``(2,)`` step offset (sagittal, coronal) from the COM in the heading frame (m).

        Args:
            v_heading: ``(2,)`` COM velocity (sagittal, coronal) in m/s.
            h: COM height over the stance foot (m).
            swing: 0 (left foot swings) or 1 (right).
            v_desired: desired forward speed (m/s).
            stance_lateral: coronal offset (m) of the stance foot from the COM; when given the
                swing foot lands at least ``placement.min_width`` beside it (no crossed legs),
                or the standing width when stopping with a sideways speed under
                ``standing.stop_speed``.
        """
        p = self.params
        vs, vc = (float(x) for x in v_heading)
        side = 1.0 if swing == _LEFT else -1.0
        w = self._human if self.mode == "step" else 0.0
        pl = p.placement
        cs = pl.coronal_scale + w * (p.human.coronal_scale - pl.coronal_scale)
        out = [pl.sagittal_scale * ipm_step_offset(vs, h) - pl.speed_offset * v_desired
               - self.speed_bias, cs * ipm_step_offset(vc, h) + side * pl.step_width]
        if stance_lateral is not None:
            stopping = self._stopping and abs(vc) < p.standing.stop_speed
            width = self.stand_width if stopping else pl.min_width
            out[1] = stance_lateral + side * max(side * (out[1] - stance_lateral), width)
        lim = pl.clamp * self.leg_length
        return np.array([min(max(x, -lim), lim) for x in out])

    def act(self, character: Character, t: float) -> Action:
        """Torques ``(nv,)`` for this physics step (root rows zero)."""
        if not self._ready:
            raise IPMError("ipm: act() called before reset()")
        ch = character
        self._update_commands(t)
        timing = self.params.timing
        if self.mode == "stand":
            trigger = self._should_step(ch, t)
            if trigger == "push":
                self._start_stepping(ch, t, swing=self._first_swing(ch),
                                     duration=timing.push_step_time)
            elif trigger == "walk":
                self._start_stepping(ch, t, swing=_LEFT, duration=timing.first_step_time)
            else:
                self.speed_target = 0.0
                return self._stand.act(ch, t)
        # step mode: end the step on swing-foot contact
        self.phase = (t - self._t0) / self._T
        contacts = ch.contacts.feet()
        if ((self.phase >= timing.min_phase and contacts[self._swing])
                or self.phase >= timing.max_phase):
            self.steps += 1
            self._adapt_speed_bias(ch, t)
            if self._should_stand(ch, t):
                self._start_standing(ch, t)
                return self._stand.act(ch, t)
            self._start_stepping(ch, t, swing=1 - self._swing)
            self.phase = 0.0
        return Action(torque=self._step_torques(ch, t))

    def _adapt_speed_bias(self, ch: Character, t: float) -> None:
        """Integral speed control: after each step, move the sagittal placement bias by
        ``placement.speed_integral`` x (desired - mean forward speed over the step)."""
        pl = self.params.placement
        if pl.speed_integral <= 0 or t <= self._t0:
            return
        f, _ = self._heading_axes(ch)
        mean = float((ch.state.com()[:2] - self._step_com0[:2]) @ f[:2]) / (t - self._t0)
        gain = pl.speed_integral + self._human * (self.params.human.speed_integral
                                                  - pl.speed_integral)
        self.speed_bias += gain * (self.speed_target - mean)
        self.speed_bias = min(max(self.speed_bias, -pl.max_speed_bias), pl.max_speed_bias)

    def _first_swing(self, ch: Character) -> int:
        """Swing the foot on the side the capture point moves to (left on a tie)."""
        c = ch.state.com()
        v = ch.state.com_velocity()
        h = max(c[2] - min(ch.state.site_positions[lg.site][2] for lg in self._legs), 0.3)
        cp = c[:2] + v[:2] * math.sqrt(h / GRAVITY)
        f, l = self._heading_axes(ch)
        soles = ch.state.site_positions
        mid = 0.5 * (soles[self._legs[0].site][:2] + soles[self._legs[1].site][:2])
        return _LEFT if (cp - mid) @ l[:2] >= 0 else _RIGHT

    def _should_step(self, ch: Character, t: float) -> str | None:
        """``"walk"`` (a command), ``"push"`` (capture point outside the feet) or ``None``."""
        settle = self.params.standing.settle_time
        if self._wants_to_walk(ch, t) and t - self.stand_switches[-1] >= settle:
            return "walk"
        c = ch.state.com()
        v = ch.state.com_velocity()
        h = max(c[2] - min(ch.state.site_positions[lg.site][2] for lg in self._legs), 0.3)
        cp = c[:2] + v[:2] * math.sqrt(h / GRAVITY)
        poly = ch.contacts.support_polygon()
        if len(poly) < 3 or t - self._reset_time < settle:
            return None  # not (yet) standing on the feet: nothing to measure against
        # just after a stop the landing foot's contact patch is still forming: be lenient
        margin = self.params.standing.capture_margin
        if t - self.stand_switches[-1] < settle:
            margin *= 3.0
        return "push" if point_in_polygon_margin(cp, poly) < -margin else None

    def _should_stand(self, ch: Character, t: float) -> bool:
        """At the end of a step: stand when no walk is commanded, the sagittal speed is below
        ``standing.stop_speed``, both feet are down and the capture point is over the feet."""
        if self._wants_to_walk(ch, t) or not all(ch.contacts.feet()):
            return False
        c = ch.state.com()
        v = ch.state.com_velocity()
        f, _ = self._heading_axes(ch)
        if abs(float(v @ f)) > self.params.standing.stop_speed:
            return False
        h = max(c[2] - min(ch.state.site_positions[lg.site][2] for lg in self._legs), 0.3)
        cp = c[:2] + v[:2] * math.sqrt(h / GRAVITY)
        return point_in_polygon_margin(cp, ch.contacts.support_polygon()) >= 0.0

    def _step_torques(self, ch: Character, t: float) -> np.ndarray:
        """``(nv,)`` stepping torques, in the steps of the module docstring. Every PD term is
        split into a part that depends on the position, ``tau``, and a linear damping
        ``-D qdot`` (:class:`~.ipm_torques.Damping`: with ``tracking.implicit_damping`` at the
        next step's velocity). Vectors of three are Python floats here (``c``, ``f`` and the
        like: the same arithmetic without numpy's cost per call)."""
        p = self.params
        s = ch.state
        sw = self._legs[self._swing]
        st = self._legs[1 - self._swing]
        D = self._damping[self._swing]
        D.clear()
        # 3. (in part) joint-space PD on the upper body and the toes: zero on every other dof
        tau = self._upper_kp_nv * (self._q_upper_nv - s.qpos[self._upper_qadr_nv])
        c = s.com()
        cx, cy, cz = c.tolist()
        vx, vy, _ = s.com_velocity().tolist()
        yaw = heading_yaw(s.body_rotations[self._pelvis])
        f = (math.cos(yaw), math.sin(yaw))  # heading axes: f = (f0, f1, 0), l = (-f1, f0, 0)
        vh = (vx * f[0] + vy * f[1], vy * f[0] - vx * f[1])
        sx, sy, ground = s.site_positions[st.site].tolist()
        vd = self.speed_target
        # coming to a stop: the next foot lands at standing width
        self._stopping = (not self._wants_to_walk(ch, t) and abs(vd) < 0.05
                          and abs(vh[0]) < 2 * p.standing.stop_speed)
        # 1. foot placement and 2. the swing foot's target, reached by the swing leg's IK
        q_thigh_des, flexion, q_sw_foot = self._swing_leg_targets(
            ch, sw, (cx, cy), f, vh, max(cz - ground, 0.3), (sx, sy), ground, vd)
        # 3. tracking: legs and upper body, then the pelvis through the stance hip
        jr_thigh = self._track_swing_leg(ch, t, sw, st, q_thigh_des, flexion, tau, D)
        self._track_feet(ch, sw, st, q_sw_foot, tau, D)
        # 4. gravity compensation on everything but the stance leg
        if p.tracking.gravity_compensation:
            self._gravity[self._swing].add_to(tau, s)
        self._track_pelvis(ch, sw, st, jr_thigh, vd, tau, D)
        # 5. virtual COM force through the stance leg
        self._virtual_force(ch, t, st, c, (cx, cy), f, vh, (sx, sy), vd, tau)
        tau = D.damped(ch, tau, p.tracking.implicit_damping)
        return self._stance_limits(ch, st, tau)

    def _heading_frame(self) -> tuple[list[float], list[float], dict]:
        """``(q, pole, offsets)`` for the heading target: ``q`` the quaternion of
        ``R = rotation_z(heading_target)``, its x axis ``pole`` and ``offsets[side]``, the leg's
        sole site offset turned by ``R`` (kept while the heading target stays)."""
        h = self.heading_target
        if self._heading_cache[0] != h:
            R = rotation_z(h)
            self._heading_cache = (h, quat_about(_Z, h), (R[:, 0].tolist(),
                                                         {lg.side: (R @ lg.site_offset).tolist()
                                                          for lg in self._legs}))
        return self._heading_cache[1], *self._heading_cache[2]

    def _swing_leg_targets(self, ch: Character, sw: Leg, c, f, vh, h: float, stance_xy,
                           ground: float, vd: float) -> tuple[list, float, list]:
        """Foot placement (step 1) and the swing foot's target (step 2): ``(q_thigh_des,
        flexion, q_sw_foot)``, the swing thigh's world orientation (a quaternion) and knee
        flexion that put its ankle at the target (analytic IK), and the swing foot's
        orientation. ``c``, ``f``, ``stance_xy``: the COM's, the heading's and the stance sole's
        horizontal (x, y)."""
        p = self.params
        s = ch.state
        lx, ly = -f[1], f[0]
        stance_lat = (stance_xy[0] - c[0]) * lx + (stance_xy[1] - c[1]) * ly
        offset = self.foot_placement(vh, h, self._swing, vd, stance_lat)
        self.last_offset = offset
        o0, o1 = offset.tolist()
        w = self.trajectory.liftoff_weight(self.phase)
        r0 = w * self._liftoff_xy[0] + (1.0 - w) * o0
        r1 = w * self._liftoff_xy[1] + (1.0 - w) * o1
        x = c[0] + r0 * f[0] + r1 * lx
        y = c[1] + r0 * f[1] + r1 * ly
        z = ground + self.trajectory.height(self.phase, self._T)
        self.swing_target = np.array([x, y, z])
        q_foot_des, pole, site_offsets = self._heading_frame()
        so = site_offsets[sw.side]
        ankle_target = [x - so[0], y - so[1], z - so[2]]
        q_sw_foot = q_foot_des
        if self._foot > 0 and p.feet.toe_up > 0 and self.phase < p.feet.toe_up_phase:
            # toes up early in the swing (easing to flat): the trailing toe leaves the floor
            xp = self.phase / p.feet.toe_up_phase
            toe_up = self._foot * p.feet.toe_up * (1.0 - smoothstep(xp))
            q_sw_foot = quat_mul(q_foot_des, quat_about(_Y, -toe_up))
        hip_pos = s.joint_anchors[sw.hip_jnt[0]].tolist()
        if sw.planar:
            thigh_dir, axis, flexion = two_link_ik3(hip_pos, ankle_target, sw.l1, sw.l2, pole)
            F = frame_from_axes3(thigh_dir, axis)
            # R_thigh_des = F thigh_rest^T
            q_thigh_des = quat_mul(mat_quat(F[0] + F[1] + F[2]), self._thigh_rest_inv[sw.side])
        else:
            R_thigh_des, flexion = hinge_leg_ik(np.array(hip_pos), np.array(ankle_target),
                                                sw.bone1, sw.bone2, sw.knee_axis,
                                                np.array(pole))
            q_thigh_des = mat_quat(R_thigh_des)
        return q_thigh_des, flexion, q_sw_foot

    def _track_swing_leg(self, ch: Character, t: float, sw: Leg, st: Leg,
                         q_thigh_des: list, flexion: float, tau: np.ndarray,
                         D: Damping) -> np.ndarray:
        """PD on the swing thigh (world frame) and knee towards the IK targets, with their
        velocities by finite differences (feed-forward: no lag from the damping), and on the
        stance knee; returns the swing thigh's rotational Jacobian ``(3, nv)``."""
        p = self.params
        tr = p.tracking
        s = ch.state
        qpos = s.qpos
        w_des, flex_rate = (0.0, 0.0, 0.0), 0.0
        if self._prev_swing is not None and tr.feedforward:
            q_prev, flex_prev, t_prev = self._prev_swing
            if t > t_prev:
                step = t - t_prev
                w_des = [x / step for x in quat_error(q_thigh_des, q_prev)]
                flex_rate = (flexion - flex_prev) / step
                n = math.sqrt(w_des[0] * w_des[0] + w_des[1] * w_des[1] + w_des[2] * w_des[2])
                if n > tr.max_target_rate:
                    w_des = [x * (tr.max_target_rate / n) for x in w_des]
                flex_rate = max(-tr.max_target_rate, min(tr.max_target_rate, flex_rate))
        self._prev_swing = (q_thigh_des, flexion, t)
        e = quat_error(q_thigh_des, s.body_quaternions[sw.thigh].tolist())
        kp, kd = tr.hip_kp, tr.hip_kd
        axes = s.joint_axes[sw.hip_jnt_sel]                  # (3, 3) rows = hinge axes
        tau[sw.hip_sel] = matvec3(axes.tolist(), [kp * e[i] + kd * w_des[i] for i in range(3)])
        _, jr_thigh = ch.dynamics.point_jacobian(sw.thigh, s.body_positions[sw.thigh],
                                                 self._jac_buffers[0])
        np.matmul(axes, jr_thigh, out=D.W[:3])               # the rows of sw.hip: kd A^T J_r
        D.W[:3] *= kd
        tau[sw.knee_dof] = (tr.knee_kp * (flexion - float(qpos[sw.knee_q]))
                            + tr.knee_kd * flex_rate)
        knee_target = p.stance.knee
        if self._knee_ramp > 0:  # from the landing flexion to stance.knee, no impulse
            x = min(self.phase / self._knee_ramp, 1.0)
            knee_target += (self._knee0 - p.stance.knee) * (1.0 - smoothstep(x))
        tau[st.knee_dof] = self._knee_kp * (knee_target - float(qpos[st.knee_q]))
        return jr_thigh

    def _track_feet(self, ch: Character, sw: Leg, st: Leg, q_sw_foot: list,
                    tau: np.ndarray, D: Damping) -> None:
        """PD on both feet in the world frame (the swing foot to ``q_sw_foot``, the stance foot
        flat at its own yaw) and the stance foot's push-off late in stance (the upper body's
        joint-space PD is in ``tau`` already)."""
        p = self.params
        tr = p.tracking
        s = ch.state
        for leg, q_des, kp in ((sw, q_sw_foot, tr.swing_ankle_kp), (st, None, tr.ankle_kp)):
            if q_des is None:  # stance foot: flat, keep its own yaw
                q_des = quat_about(_Z, heading_yaw(s.body_rotations[leg.foot]))
            A = s.joint_axes[leg.ankle_jnt_sel]              # rows = hinge axes
            e = quat_error(q_des, s.body_quaternions[leg.foot].tolist())
            tau[leg.ankle_sel] = matvec3(A.tolist(), [kp * e[0], kp * e[1], kp * e[2]])
            if leg is st and self._foot > 0:
                # the leg's twist over the planted foot: damped harder (no yaw stiffness there)
                n = A @ s.body_rotations[leg.foot][:, 2]     # the foot's vertical on the hinges
                extra = self._foot * (p.feet.ankle_yaw_kd - tr.ankle_kd)
                np.multiply.outer(extra * n, n, out=D.B)    # the block on st.ankle
                D.has_block = True
        # push-off: late in stance a toes-down moment on the stance foot lifts its heel, so the
        # trailing leg lengthens instead of the hip sinking over a flat foot
        self._push_w = 0.0
        if self._foot > 0 and p.feet.push_off > 0 and self.phase > p.feet.push_off_phase:
            x = min((self.phase - p.feet.push_off_phase) / (1.0 - p.feet.push_off_phase), 1.0)
            self._push_w = self._foot * smoothstep(x)
            R_foot = s.body_rotations[st.foot]
            moment = p.feet.push_off * self._push_w * self.mass * GRAVITY
            tau[st.ankle_sel] += s.joint_axes[st.ankle_jnt_sel] @ (R_foot[:, 1] * moment)

    def _track_pelvis(self, ch: Character, sw: Leg, st: Leg, jr_thigh: np.ndarray, vd: float,
                      tau: np.ndarray, D: Damping) -> None:
        """The pelvis PD-controlled in the world frame through the stance hip, which takes the
        difference: ``T_stance = -T_pelvis - T_swing_hip - T_spine``, each as its position part
        and its damping rows (the swing hip's world damping is ``hip_kd`` times its thigh's
        rotational Jacobian ``jr_thigh``)."""
        p = self.params
        tr = p.tracking
        s = ch.state
        lean = p.upper.lean * vd
        key = (self.heading_target, lean)
        if self._pelvis_cache[0] != key:  # R_p_des = rotation_z(heading) rotation_about(y, lean)
            self._pelvis_cache = (key, quat_mul(quat_about(_Z, self.heading_target),
                                                quat_about(_Y, lean)))
        _, jr_p = ch.dynamics.point_jacobian(self._pelvis, s.body_positions[self._pelvis],
                                             self._jac_buffers[1])
        # -(kp e + kd omega_des) per axis (kp, kd: horizontal, horizontal, yaw)
        e = quat_error(self._pelvis_cache[1], s.body_quaternions[self._pelvis].tolist())
        kp, ykp, ykd = tr.pelvis_kp, tr.pelvis_yaw_kp, tr.pelvis_yaw_kd
        # minus the swing hip's world torque
        t_sw = solve3(s.joint_axes[sw.hip_jnt_sel].tolist(), tau[sw.hip_sel].tolist())
        T0 = [-(kp * e[0]) - t_sw[0], -(kp * e[1]) - t_sw[1],
              -(ykp * e[2] + ykd * self._heading_rate) - t_sw[2]]
        DT = self._pelvis_kd * jr_p                           # world torque rows on qdot
        DT -= tr.hip_kd * jr_thigh
        for jnts, dofs in self._pelvis_children:  # their damping is per dof (D.d)
            inv = inverse3(s.joint_axes[jnts])
            t_c = (inv @ tau[dofs]).tolist()
            T0 = [T0[0] - t_c[0], T0[1] - t_c[1], T0[2] - t_c[2]]
            DT[:, dofs] -= inv * D.d[dofs]
        A_st = s.joint_axes[st.hip_jnt_sel]                   # rows = hinge axes
        tau[st.hip_sel] = matvec3(A_st.tolist(), T0)
        np.matmul(A_st, DT, out=D.W[3:])                      # the rows of st.hip

    def _virtual_force(self, ch: Character, t: float, st: Leg, c: np.ndarray, cxy, f, vh,
                       stance_xy, vd: float, tau: np.ndarray) -> None:
        """Speed control (step 5): a virtual force on the COM ``c`` realised by the stance leg,
        ``tau -= J^T F``."""
        p = self.params
        vcd = float(self.lateral_speed(t) or 0.0)
        dc = (cxy[0] - stance_xy[0]) * -f[1] + (cxy[1] - stance_xy[1]) * f[0]
        side = 1.0 if self._swing == _LEFT else -1.0
        fs = self.mass * p.force.sagittal * (vd - vh[0])
        fc = self.mass * (p.force.coronal_pos * (side * p.force.coronal_offset - dc)
                          + p.force.coronal_vel * (vcd - vh[1]))
        fs = max(-p.force.max_sagittal, min(p.force.max_sagittal, fs))
        fc = max(-p.force.max_coronal, min(p.force.max_coronal, fc))
        F = [fs * f[0] - fc * f[1], fs * f[1] + fc * f[0], 0.0]
        self.last_force = np.array(F)
        jacp, _ = ch.dynamics.point_jacobian(st.foot, c, self._jac_buffers[2])
        tau -= self._stance_leg_mask[self._swing] * (self.last_force @ jacp)

    def _stance_limits(self, ch: Character, st: Leg, tau: np.ndarray) -> np.ndarray:
        """What the stance foot holds (its yaw moment; its ankle moment, wider at push-off,
        narrower in a turning step), no root torque, the actuator limits."""
        p = self.params
        limit_stance_yaw(ch, st, tau, p.stance.yaw_friction, p.stance.yaw_limit, self.mass)
        if p.stance.ankle_limit is not None:
            if self._turning:
                fwd, back, roll = p.turning.ankle_limit
            else:
                fwd, back, roll = p.stance.ankle_limit
                back += self._back * (p.feet.ankle_back - back)
            if self._push_w > 0:  # heel lifting: the pressure may move up to the ball of the foot
                fwd += self._push_w * max(self._ball[st.side] - fwd, 0.0)
            limit_stance_ankle(ch, st, tau, fwd, back, roll, self.mass * GRAVITY)
        tau[ch.root_dofs] = 0.0
        np.minimum(tau, self._limits, out=tau)
        np.maximum(tau, self._neg_limits, out=tau)
        return tau


def make_ipm(character: Character | None = None, speed=0.0, heading=None, *,
             calibration=None, **opts) -> IPMController:
    """An :class:`IPMController` for ``character``'s body with its calibration
    (:func:`~.calibration.overrides_for`: ``None`` the stored one, made first if missing,
    ``"none"`` the defaults, or a file); ``speed`` (m/s) and ``heading`` (degrees, world yaw,
    0 = +X, CCW; ``None``: keep the start heading) are numbers or functions of time; ``opts``:
    ``lateral_speed``, ``params`` (an :class:`IPMParams`) and parameters by dotted name
    (``**{"timing.step_time": 0.5}``), over the calibration's."""
    opts = {**overrides_for(character, "ipm", calibration), **opts}
    return IPMController(speed=speed, heading=heading, **opts)


register(ControllerSpec(
    name="ipm", label="IPM stepping", kind="walker",
    # no speed given (`mjchar run ipm`, `mjchar gait ipm`): 1 m/s
    factory=lambda character, target=None, speed=1.0, **options: make_ipm(character, speed,
                                                                           **options),
    abilities=("walk", "stand"), default_scenario="walk",
    options=("speed", "heading", "params", "calibration"), steps=True, tunables=IPMParams.tunables,
    # 60 s, no fall, steady speed within 0.15 m/s at 0.3-1.6 m/s on the bundled humanoid (0:
    # stops and stands; docs/ipm.md), the same Froude speeds on other bodies (as its parameters)
    limits=(("speed", 0.0, 1.6),), speed_leg_length=TUNED_LEG_LENGTH,
    bench=("stand", "random-push", "push-search", "walk", "slopes"), expected=("stand", "walk")))
