"""IPM stepping's numbers: every tunable parameter (:class:`IPMParams`), the inverted-pendulum
step offset of Coros, Beaudoin and van de Panne 2010 (:func:`ipm_step_offset`) and speed or
heading commands as functions of time (:func:`schedule`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields, replace

import numpy as np

from ..core.base import ControllerError
from .similarity import similarity_factors

GRAVITY = 9.81

#: the body the default numbers were tuned on: leg length (m, hip to sole) and mass (kg). Every
#: dimensional parameter is carried to the driven body by dynamic similarity (:meth:`IPMParams.
#: for_body`): lengths x L/L_t, times x sqrt(L/L_t), speeds x sqrt(L/L_t), torque gains and
#: torques x (m/m_t)(L/L_t), damping gains x (m/m_t)(L/L_t)^1.5, forces x m/m_t, rates x
#: sqrt(L_t/L); dimensionless ones (phases, scales, angles) stay. So the defaults are in fact in
#: body-relative units, written in SI for a body of this size.
TUNED_LEG_LENGTH = 0.878
TUNED_MASS = 70.0
#: how each dimensional field scales (the rest are dimensionless)
_LENGTH = ("step_width", "min_width", "capture_margin", "max_speed_bias", "swing_heights",
           "coronal_offset", "stance_ankle_limit", "turn_ankle_limit", "human_swing_height",
           "human_push_off", "human_liftoff_height", "human_ankle_back")
_TIME = ("step_time", "fast_step_time", "first_step_time", "push_step_time", "settle_time",
         "speed_offset", "speed_integral", "human_step_time", "human_speed_integral", "turn_hold")
_SPEED = ("stop_speed", "descent_speed", "slow_speed", "fast_speed", "human_top", "human_end",
          "ankle_back_speeds")
_RATE = ("vf_sagittal", "vf_coronal_vel", "max_target_rate", "turn_rate", "lean")
#: per length: 1/s^2 gains and ``cadence_gain`` (steps/s per m/s = 1/m), both x L_t/L
_RATE2 = ("vf_coronal_pos", "cadence_gain")
_TORQUE_GAIN = ("hip_kp", "knee_kp", "stance_knee_kp", "fast_stance_knee_kp",
                "human_stance_knee_kp",
                "ankle_kp", "swing_ankle_kp", "pelvis_kp", "pelvis_yaw_kp")
_DAMPING_GAIN = ("hip_kd", "knee_kd", "ankle_kd", "swing_ankle_kd", "pelvis_kd",
                 "pelvis_yaw_kd", "human_ankle_yaw_kd")
_FORCE = ("vf_max_sagittal", "vf_max_coronal")
_TORQUE = ("stance_yaw_limit",)
#: parameters without a dimension (phases, scales, angles, switches), left as they are
_DIMENSIONLESS = ("min_phase", "max_phase", "sagittal_scale", "coronal_scale", "clamp",
                  "swing_blend", "stance_knee", "stance_knee_ramp", "fast_stance_knee_ramp",
                  "stance_knee_ramp_max", "human_stance_knee_ramp",
                  "human_coronal_scale", "push_off_phase", "human_toe_up", "toe_up_phase",
                  "upper_gain_scale", "acceleration",
                  "turn_acceleration", "gravity_compensation", "implicit_damping", "feedforward",
                  "heading_tolerance", "arm_abduction", "yaw_friction")


class IPMError(ControllerError):
    """The IPM controller was configured with impossible options or used on an unsuitable model."""


@dataclass(frozen=True)
class IPMParams:
    """Every tunable number of :class:`IPMController` (SI units, angles in rad).

    Attributes:
        step_time: nominal step duration ``T`` (s) up to ``slow_speed``.
        slow_speed, fast_speed: from ``slow_speed`` to ``fast_speed`` (m/s of desired speed)
            the ``fast_*`` values take over linearly from their slow counterparts
            (:meth:`IPMParams.at_speed`), and hold above ``fast_speed``.
        fast_step_time: step time (s) at ``fast_speed``: a faster walk takes quicker steps,
            as people do.
        fast_stance_knee_kp, fast_stance_knee_ramp: ``stance_knee_kp``, ``stance_knee_ramp``
            at ``fast_speed``.
        cadence_gain: above ``fast_speed`` the step rate keeps growing with the speed,
            ``1 / T = 1 / fast_step_time + cadence_gain (v - fast_speed)`` (steps/s per m/s, i.e.
            1/m), so both the cadence and the step length ``v T`` grow with speed, as in people.
            Measured: at 1.4 m/s 0.4 s steps sank into a deepening crouch (landing knee 1.20 rad
            at 60 s, still growing), at 1.5 m/s 0.39 s steps fell at 30 s, 0.36 s steps held a
            steady gait (docs/ipm.md, speed range).
        human_top, human_end: the human-like gait band (m/s of desired speed). The ``human_*``
            values take over from the slow ones between ``slow_speed`` and ``fast_speed``, hold up
            to ``human_top`` and give way to the fast ones (quick steps, soft knee) by ``human_end``
            (:meth:`IPMParams.human_weight`); the feet's ones (lift-off, toes up, push-off, twist
            damping, toe-up ankle limit) do not give way. Measured (60 s walks, issue 14): the
            human-like gait alone above 1.35 m/s settles too slow (1.6 m/s: steady 1.35 m/s; a
            larger speed bias or stepping closer fell at 5-13 s), while fading it out by 1.5 m/s
            (knee kp 400, swing 0.06 m) fell at 6.4-7.5 s at 1.4-1.6 m/s in the switch; kp 300 with
            this fade walked 1.4/1.5/1.6 m/s 60 s at 1.351/1.392/1.532 m/s (0.08 m swing), and the
            defaults pass the 60 s range 0.3-1.6 m/s (``test_speed_range_60s``).
        human_step_time: step time (s) at ``fast_speed`` in that band (the rate then grows by
            ``cadence_gain`` like the fast one's): 0.48 s, so 1.2 m/s takes 0.47 s nominal steps
            (~0.5 s as walked, 119 steps/min, 0.59 m; the fast band's 0.39 s gave 145 steps/min
            and 0.48 m; people at 1.2 m/s: 100-128 steps/min, 0.55-0.72 m).
        human_stance_knee_kp, human_stance_knee_ramp: the stance knee in that band: a plain PD
            to ``stance_knee`` from landing (kp 300, no ramp). The fast band's soft knee (kp 200
            easing from the landing flexion) sank into a crouch with longer steps (0.5 s steps
            at 1.2 m/s: stance knee 68-70 deg, COM 0.78 m; mean knee flexion 73-78 deg); a stiff
            knee from landing holds 23-27 deg with push-off (below). kp 400 gives 33-34 deg
            knee flexion at 1.2 m/s but fell at 1.5 m/s in the switch to the fast band.
        human_swing_height: mid-swing sole height (m) in that band (``swing_heights[1]``
            otherwise): 0.05 m, foot clearance 0.06 m (the 0.15 m swing: 0.14 m, mocap 0.07-0.08
            m) and 2-4 deg less mean knee flexion (34.0 at 0.05, 35.5 at 0.06, 37.5 at 0.08 m).
        human_liftoff_height: the swing target's sole height (m) at lift-off (phase 0,
            ``swing_heights[0]`` otherwise) from ``fast_speed`` on (it, ``human_toe_up``,
            ``human_push_off`` and ``human_ankle_yaw_kd`` blend in from ``slow_speed`` like the band
            but do not fade above ``human_top``: measured at 1.4 m/s, where the band has faded to
            0.8, 1.10 cm/step with them faded, 0.95 held; 1.6 m/s 2.64 -> 1.34 cm with
            ``ankle_back_speeds``; 60 s steady speeds 1.294, 1.392, 1.494 m/s at 1.4, 1.5, 1.6):
            0.12 m, so the trailing foot comes straight up instead of skimming the floor. Measured
            (issue 14's stance slip, 1.2 m/s, ``mjchar gait``): with 0.04 m the lifted foot slid on
            1-4 mm of air at up to 0.6 m/s before the probe's stance ended (0.8 of 1.8 cm/step with
            no contact left); 0.08 m: 1.06 cm, 0.12 m: 1.00 cm, 0.16 m: 1.02 cm.
        human_ankle_back: ``stance_ankle_limit``'s toe-up (``pitch_back``) moment in that band and,
            by ``ankle_back_speeds``, below it (m x body weight): 0.01 m. With 0.03 m the saturated
            forward virtual force kept the stance ankle at that limit from phase 0.1 to 0.45: the
            foot rocked onto its heel (toes up 9 deg, 2 of 8 corners down) and slapped flat again,
            0.9 cm of the 1.98 cm/step slip at 1.2 m/s; 0.01 m: the foot stays flat (1.2 m/s walks
            1.140 m/s instead of 1.167, 1.5 m/s 60 s steady 1.361 instead of 1.387); 0 m: 0.93 cm
            but a 60 s walk at 1.6 m/s fell (7.2 s, with a 0.10 m lift-off).
        human_ankle_yaw_kd: the stance ankle's damping (N m s/rad) about the foot's vertical axis
            from ``fast_speed`` on (``ankle_kd`` otherwise, and about the other two axes). The
            stance foot keeps its own yaw (no stiffness about the vertical), so this damping is all
            that couples the leg's twist to the planted foot: 60 (with the lift-off and ankle limit
            above, 1.2 m/s) gives a stance slip of 0.95 cm/step against 1.01 with 15; 120: no
            better; 5: 2.8 cm, 2: fell (the leg twists freely, the pelvis loses its yaw anchor).
            Applied at every speed it cost a 150 N backward standing push (38/40 against 39/40).
        ankle_back_speeds: ``human_ankle_back`` takes over from ``stance_ankle_limit``'s
            toe-up moment between these desired speeds (m/s) and holds at every faster one
            (:meth:`IPMParams.ankle_back_weight`). Measured (issue 14, ``mjchar gait``): the slow
            band's 0.03 m (which rocked the foot onto its heel at 1.2 m/s) left most of the slip
            late in stance at 1.0 m/s; with 0.01 m: 1.29 -> 0.65 cm/step at 1.0 m/s, 0.92 -> 0.56
            at 0.9, 0.76 -> 0.56 at 0.8 (1.0 m/s walks 0.92 instead of 0.94 m/s over 3-20 s); at 0.6
            m/s it gave 0.55 against 0.46, so it starts at 0.7.
        human_toe_up, toe_up_phase: the swing foot's target is pitched toes up by
            ``human_toe_up`` (rad) at lift-off, easing (smoothstep) to flat by ``toe_up_phase``,
            from ``fast_speed`` on (blended in from ``slow_speed``). Measured (1.2 m/s): the
            trailing foot left the floor pitched toes down (7 deg, heel up from push-off) and
            tipped further (12 deg) as the knee lifted it, its toe dragged forward within 1 cm
            of the floor for ~50 ms at 0.5-1.5 m/s; toes up 0.2 rad: 0.95 -> 0.83 cm/step, 0.35:
            0.80, 0.5: 0.82 (phase 0.3 or 0.6 alike); 1.1 / 1.3 m/s 1.10 / 0.97 -> 0.75 / 0.82.
            In the slow band (0.5 s steps, no push-off) it made it worse (1.0 m/s: 1.29 -> 1.9).
        human_push_off, push_off_phase: from ``fast_speed`` on, from ``push_off_phase`` to the end
            of the step a toes-down moment of ``human_push_off`` x body weight (m) on the stance
            foot (smoothstep), and the forward ankle limit grows to the ball of the foot (its toe
            joint) with it, so the heel lifts. Measured why: with a straight stance knee and 0.5 s
            steps the stance foot stayed flat to the end (pitch 0 deg at the next landing), so the
            hip sank over it (0.83 -> 0.77 m in 6 s), every landing came deeper (swing knee 0.57 ->
            0.92 rad at contact) and the walk fell at 12.8 s; with 0.2 it holds (landing hip ~0.80
            m).
        human_coronal_scale: ``coronal_scale`` in that band: 0.8 (at 1.0 the longer steps
            stepped 0.20-0.26 m wide; 0.9: 0.15 m, 0.8: 0.12 m; 0.7 fell at 6.2 s).
        human_speed_integral: ``speed_integral`` in that band (s): 0.06; with 0.02 the
            human-like gait took ~20 s to reach its speed (1.2 m/s: 1.10 m/s mean over 3-16 s).
        min_phase: swing-foot contact ends the step only after this phase.
        max_phase: the step is ended at this phase even without contact.
        sagittal_scale, coronal_scale: IPM offset scales ``s_s``, ``s_c`` (paper: 1.1, 1.3).
        speed_offset: ``k_v`` in ``- k_v v_d`` (s): how far before the IPM point to step
            (paper: 0.05).
        speed_integral, max_speed_bias: after every step the sagittal placement moves back by
            ``speed_integral`` (s) x the step's mean speed error (m/s), up to ``max_speed_bias`` m
            (integral action on top of ``- speed_offset v_d``).
        step_width: ``w``, coronal offset of the swing foot from the COM (m).
        min_width: least coronal distance (m) of the swing foot target from the stance foot
            (the hip width when coming to a stop).
        clamp: step offset limit as a fraction of the leg length (per axis).
        swing_heights: sole heights (m) at phases 0, 0.5, 1.
        descent_speed: m/s the swing target sinks after phase 1.
        swing_blend: ``"quadratic"`` (lift-off weight ``(1 - phase)^2``, the paper's) or
            ``"smooth"`` (``1 - smoothstep(phase)``), see :class:`SwingTrajectory`.
        swing_ankle_kp, swing_ankle_kd: the swing foot's (world frame) gains, so it lands flat.
        hip_kp, hip_kd, knee_kp, knee_kd, ankle_kp, ankle_kd, pelvis_kp, pelvis_kd: PD gains
            (N m/rad, N m s/rad); pelvis in the world frame.
        pelvis_yaw_kp, pelvis_yaw_kd: the pelvis gains about the vertical (heading) axis.
        stance_knee: stance knee flexion target (rad).
        stance_knee_kp: the stance knee's stiffness up to ``slow_speed`` (N m/rad; ``None``:
            ``knee_kp``, the swing knee's).
        stance_knee_ramp: the stance knee's target eases (smoothstep) from its flexion at
            landing to ``stance_knee`` over this many phases (0: the target from the start):
            no knee-extension impulse at landing.
        stance_knee_ramp_max: the ramp starts from at most this flexion (rad), so a knee that
            lands deeply bent is still pushed up at once (without it a fast walk sinks into a
            deeper crouch step after step and collapses).
        upper_gain_scale: factor on the model's gains table for spine, arms, head and toes.
        vf_sagittal, vf_coronal_pos, vf_coronal_vel: virtual-force gains ``30``, ``c_p``,
            ``c_v`` (1/s, 1/s^2, 1/s; paper: 30, 20, 9).
        vf_max_sagittal, vf_max_coronal: virtual-force clamps (N).
        coronal_offset: desired coronal COM offset from the stance foot (m, towards the swing
            side positive) in the virtual force.
        lean: forward pelvis pitch target (rad) per m/s of desired speed.
        turn_rate: rad/s the heading target turns at, at most; and at most
            ``turn_acceleration / v_d`` (m/s^2 of centripetal acceleration) when walking.
        acceleration: m/s^2 the speed target (used by the placement and the virtual force)
            follows the speed command at.
        gravity_compensation: apply the gravity compensation.
        feedforward: track the swing thigh's and knee's target velocities (finite differences
            of the IK targets), not zero velocity.
        max_target_rate: clamp on those target velocities (rad/s).
        implicit_damping: evaluate every damping term at the next step's velocity (stable PD
            generalised to the controller's damping matrix); explicit damping needs a time step
            of about 0.5 ms.
        stop_speed: COM speed (m/s) under which a step may end in standing (zero command);
            also the COM's sideways speed under which a stopping step's target is widened to
            the standing width (checked every control step, so the target can move by
            ``stand_width - min_width`` within a swing; a blend from half ``stop_speed`` to
            ``stop_speed`` lost the 150 N push this rule saves).
        heading_tolerance: heading error (rad) below which the character may stand.
        capture_margin: the capture point may lie this far (m) outside the support polygon
            before standing turns into stepping (3x that during ``settle_time`` after a stop).
        stance_ankle_limit: ``(pitch_fwd, pitch_back, roll)`` moments (N m per N of body weight,
            i.e. m) the stance ankle may apply, so the foot does not roll; ``None`` = no limit.
        turn_ankle_limit: ``stance_ankle_limit`` in turning steps (a step that starts while the
            heading target moves, or up to ``turn_hold`` after): no pressure behind the ankle
            and less roll, so the stance foot stays flat and keeps its yaw grip. Measured (issue
            14, docs/ipm.md): with the straight-walking limits the sagittal virtual force (60 N
            forward in mid-stance) rocks the stance foot back onto its heel edge from phase
            ~0.25 to ~0.7 (toes up to 9 deg; the contact patch holds ~14 N m of yaw moment
            instead of ~30), in a turn onto one heel corner (none), where it spins 15-25 deg;
            the 90 deg turn then fell in 24 of 48 cases (0.5, 1.0-1.6 m/s, left and right, three
            start times). With ``(0.08, 0, 0.025)`` 3 of 35 fell; with roll 0.015 and
            ``turn_hold`` 1 s, none of 48 (2 of 48, both at 1.6 m/s, with the human band's
            slip change merged in).
        turn_hold: seconds after the heading target stops that steps still count as turning:
            the gait right after a turn is still swaying (with 0, a 1.1 m/s right turn fell
            1.8 s after the target stopped).
        arm_abduction: arms hang this far (rad) from the body.
        stance_yaw_limit: largest vertical (yaw) moment (N m) the stance hip may apply to the
            pelvis; more spins the stance foot on the ground.
        yaw_friction: the stance hip's yaw moment is also limited to ``yaw_friction x m g x r``
            with ``r`` the spread of the stance foot's contact points (0 on a single point).
        first_step_time: duration (s) of the first step out of standing: short, so the COM
            falls only a little towards the swing side before the swing foot catches it, which
            starts the lateral sway of walking.
        push_step_time: duration (s) of the first step when a push (capture point outside the
            feet) ends standing.
        settle_time: seconds of standing before a speed or heading command starts a walk (a
            push starts stepping at once).
    """

    step_time: float = 0.5
    slow_speed: float = 1.0
    fast_speed: float = 1.1
    fast_step_time: float = 0.4
    cadence_gain: float = 0.52
    min_phase: float = 0.5
    max_phase: float = 1.6
    sagittal_scale: float = 1.0
    coronal_scale: float = 1.0
    speed_offset: float = 0.1
    speed_integral: float = 0.02
    max_speed_bias: float = 0.1
    step_width: float = 0.03
    min_width: float = 0.1
    clamp: float = 0.4
    swing_heights: tuple[float, float, float] = (0.04, 0.15, 0.02)
    descent_speed: float = 1.0
    swing_blend: str = "smooth"
    hip_kp: float = 600.0
    hip_kd: float = 60.0
    knee_kp: float = 300.0
    knee_kd: float = 35.0
    ankle_kp: float = 50.0
    ankle_kd: float = 15.0
    swing_ankle_kp: float = 200.0
    swing_ankle_kd: float = 20.0
    pelvis_kp: float = 1000.0
    pelvis_kd: float = 200.0
    pelvis_yaw_kp: float = 300.0
    pelvis_yaw_kd: float = 60.0
    stance_knee: float = 0.15
    stance_knee_kp: float | None = None
    stance_knee_ramp: float = 0.0
    fast_stance_knee_kp: float = 200.0
    fast_stance_knee_ramp: float = 1.0
    stance_knee_ramp_max: float = 0.9
    human_top: float = 1.35
    human_end: float = 1.6
    human_step_time: float = 0.48
    human_stance_knee_kp: float = 300.0
    human_stance_knee_ramp: float = 0.0
    human_swing_height: float = 0.05
    human_liftoff_height: float = 0.12
    human_push_off: float = 0.2
    human_ankle_back: float = 0.01
    human_ankle_yaw_kd: float = 60.0
    human_toe_up: float = 0.35
    toe_up_phase: float = 0.3
    ankle_back_speeds: tuple[float, float] = (0.7, 0.9)
    push_off_phase: float = 0.5
    human_coronal_scale: float = 0.8
    human_speed_integral: float = 0.06
    upper_gain_scale: float = 1.0
    vf_sagittal: float = 30.0
    vf_coronal_pos: float = 0.0
    vf_coronal_vel: float = 0.0
    vf_max_sagittal: float = 60.0
    vf_max_coronal: float = 100.0
    coronal_offset: float = 0.0
    lean: float = 0.0
    turn_rate: float = 0.5
    turn_acceleration: float = 0.3
    acceleration: float = 0.5
    gravity_compensation: bool = True
    implicit_damping: bool = True
    feedforward: bool = True
    max_target_rate: float = 10.0
    stop_speed: float = 0.15
    heading_tolerance: float = 0.1
    capture_margin: float = 0.03
    stance_ankle_limit: tuple[float, float, float] | None = (0.08, 0.03, 0.025)
    arm_abduction: float = 0.15
    settle_time: float = 0.3
    stance_yaw_limit: float = 40.0
    yaw_friction: float = 0.5
    first_step_time: float = 0.3
    push_step_time: float = 0.3
    turn_ankle_limit: tuple[float, float, float] = (0.08, 0.0, 0.015)
    turn_hold: float = 1.0

    def updated(self, options: dict) -> IPMParams:
        """These parameters with ``options`` (field: value; sequences as tuples of floats),
        checked (:meth:`check`)."""
        return replace(self, **sequences_as_tuples(options)).check()

    def for_body(self, leg_length: float, mass: float) -> IPMParams:
        """These parameters carried from the tuned body (:data:`TUNED_LEG_LENGTH`,
        :data:`TUNED_MASS`) to a body of ``leg_length`` m and ``mass`` kg by dynamic similarity
        (unchanged, the same object, when the body is the tuned one to 1e-6)."""
        if not (leg_length > 0 and mass > 0):
            raise IPMError(f"leg length and mass must be positive, got {leg_length}, {mass}")
        r, q = leg_length / TUNED_LEG_LENGTH, mass / TUNED_MASS
        if abs(r - 1) < 1e-6 and abs(q - 1) < 1e-6:
            return self
        f = similarity_factors(r, q)
        kinds = ((_LENGTH, "length"), (_TIME, "time"), (_SPEED, "speed"), (_RATE, "rate"),
                 (_RATE2, "per_length"), (_TORQUE_GAIN, "torque_gain"),
                 (_DAMPING_GAIN, "damping_gain"), (_FORCE, "force"), (_TORQUE, "torque"))
        factor = {name: f[kind] for names, kind in kinds for name in names}
        changes = {}
        for name, k in factor.items():
            v = getattr(self, name)
            if v is None:
                continue
            changes[name] = tuple(x * k for x in v) if isinstance(v, tuple) else v * k
        return replace(self, **changes)

    def speed_blend(self, speed: float) -> float:
        """0 up to ``slow_speed`` (m/s), 1 from ``fast_speed`` on, linear in between."""
        v = abs(float(speed))
        if v <= self.slow_speed or self.fast_speed <= self.slow_speed:
            return 0.0 if v <= self.slow_speed else 1.0
        return min((v - self.slow_speed) / (self.fast_speed - self.slow_speed), 1.0)

    def human_weight(self, speed: float) -> float:
        """Weight (0-1) of the ``human_*`` values at a desired speed (m/s): 0 up to
        ``slow_speed``, 1 from ``fast_speed`` to ``human_top``, 0 again from ``human_end`` on
        (linear in between)."""
        v = abs(float(speed))
        x = self.speed_blend(v)
        if v > self.human_top:
            x *= max(0.0, 1.0 - (v - self.human_top) / max(self.human_end - self.human_top, 1e-9))
        return x

    def ankle_back_weight(self, speed: float) -> float:
        """Weight (0-1) of ``human_ankle_back`` at a desired speed (m/s): 0 up to
        ``ankle_back_speeds[0]``, 1 from ``ankle_back_speeds[1]`` on (and from ``fast_speed``
        on in any case), linear in between."""
        v = abs(float(speed))
        lo, hi = self.ankle_back_speeds
        x = 0.0 if v <= lo else 1.0 if v >= hi else (v - lo) / (hi - lo)
        return max(x, self.speed_blend(v))

    def at_speed(self, speed: float) -> tuple[float, float, float]:
        """``(step_time, stance_knee_kp, stance_knee_ramp)`` at a desired speed (m/s): the slow
        values up to ``slow_speed``, the ``fast_*`` ones from ``fast_speed``, linear between;
        above ``fast_speed`` the step rate grows by ``cadence_gain`` per m/s; the ``human_*``
        values blended in by :meth:`human_weight` (so they hold from ``fast_speed`` to
        ``human_top``)."""
        t, k, r = self._fast_at_speed(speed)
        w = self.human_weight(speed)
        if w <= 0:
            return t, k, r
        th = self.human_step_time
        v = abs(float(speed))
        if v > self.fast_speed:  # the human step rate grows with speed too
            th = 1.0 / (1.0 / th + self.cadence_gain * (v - self.fast_speed))
        return (t + w * (th - t), k + w * (self.human_stance_knee_kp - k),
                r + w * (self.human_stance_knee_ramp - r))

    def _fast_at_speed(self, speed: float) -> tuple[float, float, float]:
        x = self.speed_blend(speed)
        kp = self.knee_kp if self.stance_knee_kp is None else self.stance_knee_kp
        step_time = self.step_time + x * (self.fast_step_time - self.step_time)
        v = abs(float(speed))
        if v > self.fast_speed > self.slow_speed:
            rate = 1.0 / self.fast_step_time + self.cadence_gain * (v - self.fast_speed)
            step_time = 1.0 / rate
        return (step_time,
                kp + x * (self.fast_stance_knee_kp - kp),
                self.stance_knee_ramp + x * (self.fast_stance_knee_ramp
                                             - self.stance_knee_ramp))

    def check(self) -> IPMParams:
        """Raise :class:`IPMError` on non-finite or out-of-range values; returns self."""
        if self.swing_blend not in ("quadratic", "smooth"):
            raise IPMError(f"swing_blend must be 'quadratic' or 'smooth', got "
                           f"{self.swing_blend!r}")
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, str):
                continue
            vals = v if isinstance(v, tuple) else (() if v is None else (v,))
            for x in vals:
                if not isinstance(x, bool) and not (isinstance(x, (int, float))
                                                    and math.isfinite(x)):
                    raise IPMError(f"IPM option {f.name} must be finite numbers, got {v!r}")
        if self.step_time <= 0 or self.fast_step_time <= 0:
            raise IPMError(f"step_time and fast_step_time must be positive seconds, got "
                           f"{self.step_time}, {self.fast_step_time}")
        if not (self.human_step_time > 0 and self.human_end > self.human_top >= self.fast_speed):
            raise IPMError("need human_step_time > 0 and fast_speed <= human_top < human_end")
        if self.cadence_gain < 0:
            raise IPMError(f"cadence_gain must be >= 0 (steps/s per m/s), got {self.cadence_gain}")
        if self.stance_knee_ramp < 0 or self.fast_stance_knee_ramp < 0:
            raise IPMError("stance_knee_ramp must be a phase >= 0")
        if not 0 <= self.min_phase < self.max_phase:
            raise IPMError("need 0 <= min_phase < max_phase")
        if self.clamp <= 0:
            raise IPMError("clamp must be a positive fraction of the leg length")
        lo_hi = self.ankle_back_speeds
        if not isinstance(lo_hi, tuple) or len(lo_hi) != 2 or not 0 <= lo_hi[0] < lo_hi[1]:
            raise IPMError(f"ankle_back_speeds must be (from, full) m/s with 0 <= from < full, "
                           f"got {self.ankle_back_speeds!r}")
        if self.toe_up_phase <= 0 or self.human_toe_up < 0:
            raise IPMError(f"need toe_up_phase > 0 and human_toe_up >= 0 (rad), got "
                           f"{self.toe_up_phase}, {self.human_toe_up}")
        if self.turn_ankle_limit is None or len(self.turn_ankle_limit) != 3:
            raise IPMError(f"turn_ankle_limit must be (pitch_fwd, pitch_back, roll), got "
                           f"{self.turn_ankle_limit!r}")
        return self


def sequences_as_tuples(options: dict) -> dict:
    """``options`` with the sequence-valued :class:`IPMParams` fields (``swing_heights``,
    ``ankle_back_speeds``) as tuples of floats; :class:`IPMError` for a single value."""
    out = dict(options)
    for name in ("swing_heights", "ankle_back_speeds"):
        if name in out:
            if isinstance(out[name], str | int | float):
                raise IPMError(f"IPM option {name} must be a sequence of numbers, got "
                               f"{out[name]!r}")
            out[name] = tuple(float(x) for x in out[name])
    return out


def ipm_step_offset(v, h: float, g: float = GRAVITY):
    """Inverted-pendulum step offset ``d = v sqrt(h/g + v^2/(4 g^2))`` (m) for a COM speed ``v``
    (m/s, scalar or array) at height ``h`` (m) over the stance foot: stepping ``d`` ahead of the
    COM brings a pendulum of that energy to rest over the foot."""
    v = np.asarray(v, dtype=float)
    if not (math.isfinite(h) and h > 0):
        raise IPMError(f"COM height must be positive metres, got {h}")
    d = v * np.sqrt(h / g + v * v / (4.0 * g * g))
    return float(d) if d.ndim == 0 else d


def schedule(value, what: str, scale: float = 1.0) -> Callable[[float], float | None]:
    """A command as a function of time: ``None`` (always ``None``), a number (constant, times
    ``scale``) or a callable ``t -> value`` (times ``scale``); a non-finite number raises
    :class:`IPMError` naming ``what``."""
    if value is None:
        return lambda t: None
    if callable(value):
        return lambda t: (None if value(t) is None else float(value(t)) * scale)
    v = float(value)
    if not math.isfinite(v):
        raise IPMError(f"{what} must be a finite number, got {value!r}")
    return lambda t: v * scale
