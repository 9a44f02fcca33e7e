"""IPM stepping's numbers: every tunable parameter (:class:`IPMParams`, in groups by concern), the
inverted-pendulum step offset of Coros, Beaudoin and van de Panne 2010 (:func:`ipm_step_offset`)
and speed or heading commands as functions of time (:func:`schedule`).

Every parameter declares its physical dimension and the values it accepts on its own line
(``step_time: float = time(0.5, gt=0)``, helpers of :mod:`.param_fields`); the body scaling
(:meth:`IPMParams.for_body`) and the checks are derived from those declarations. Parameters are
named ``group.field`` (``timing.step_time``): :meth:`IPMParams.updated` takes such overrides and
refuses an unknown name (listing the valid ones) or a value the field does not accept, in one
:class:`IPMError` line.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ..core.base import ControllerError
from ..core.param_fields import (
    Tunable,
    acceleration,
    angle,
    checked,
    choice,
    damping_gain,
    flag,
    force,
    length,
    names,
    number,
    overridden,
    per_length,
    phase,
    rate,
    scaled,
    speed,
    time,
    torque,
    torque_gain,
    tunables,
)
from ..core.param_fields import flat as _flat
from ..core.similarity import similarity_factors

GRAVITY = 9.81

#: the body the default numbers were tuned on: leg length (m, hip to sole) and mass (kg). Every
#: dimensional parameter is carried to the driven body by dynamic similarity (:meth:`IPMParams.
#: for_body`): lengths x L/L_t, times x sqrt(L/L_t), speeds x sqrt(L/L_t), torque gains and
#: torques x (m/m_t)(L/L_t), damping gains x (m/m_t)(L/L_t)^1.5, forces x m/m_t, rates x
#: sqrt(L_t/L), per-length gains x L_t/L; accelerations and dimensionless ones (phases, scales,
#: angles) stay. So the defaults are in fact in body-relative units, written in SI for a body of
#: this size.
TUNED_LEG_LENGTH = 0.878
TUNED_MASS = 70.0


class IPMError(ControllerError):
    """The IPM controller was configured with impossible options or used on an unsuitable model."""


@dataclass(frozen=True)
class StepTiming:
    """When a step starts and ends (``timing.*``).

    Attributes:
        step_time: nominal step duration ``T`` (s) up to ``speed.slow``.
        fast_step_time: step time (s) at ``speed.fast`` (linear in between,
            :meth:`IPMParams.at_speed`): a faster walk takes quicker steps, as people do.
        cadence_gain: above ``speed.fast`` the step rate keeps growing with the speed,
            ``1 / T = 1 / fast_step_time + cadence_gain (v - speed.fast)`` (steps/s per m/s, i.e.
            1/m), so both the cadence and the step length ``v T`` grow with speed, as in people.
            Measured: at 1.4 m/s 0.4 s steps sank into a deepening crouch (landing knee 1.20 rad
            at 60 s, still growing), at 1.5 m/s 0.39 s steps fell at 30 s, 0.36 s steps held a
            steady gait (docs/ipm.md, speed range).
        first_step_time: duration (s) of the first step out of standing: short, so the COM
            falls only a little towards the swing side before the swing foot catches it, which
            starts the lateral sway of walking.
        push_step_time: duration (s) of the first step when a push (capture point outside the
            feet) ends standing.
        min_phase: swing-foot contact ends the step only after this phase.
        max_phase: the step is ended at this phase even without contact.
    """

    step_time: float = time(0.5, gt=0)
    fast_step_time: float = time(0.4, gt=0)
    cadence_gain: float = per_length(0.52, ge=0, unit="steps/s per m/s")
    first_step_time: float = time(0.3, gt=0)
    push_step_time: float = time(0.3, gt=0)
    min_phase: float = phase(0.5, ge=0)
    max_phase: float = phase(1.6, gt=0)


@dataclass(frozen=True)
class SpeedBands:
    """The speed target and the bands of desired speed the parameters change with (``speed.*``).

    Attributes:
        slow, fast: from ``slow`` to ``fast`` (m/s of desired speed) the fast values
            (``timing.fast_step_time``, ``stance.fast_knee_kp``, ``stance.fast_knee_ramp``)
            take over linearly from their slow counterparts (:meth:`IPMParams.at_speed`) and
            hold above ``fast``; the human band (:class:`HumanBand`) and the feet's measures
            (:class:`FootMeasures`) blend in over the same range (:meth:`IPMParams.speed_blend`).
        human_top, human_end: the human-like gait band (m/s of desired speed). The ``human.*``
            values take over from the slow ones between ``slow`` and ``fast``, hold up to
            ``human_top`` and give way to the fast ones (quick steps, soft knee) by
            ``human_end`` (:meth:`IPMParams.human_weight`); the feet's measures do not give way.
            Measured (60 s walks): the human-like gait alone above 1.35 m/s settles too slow
            (1.6 m/s: steady 1.35 m/s; a larger speed bias or stepping closer fell at 5-13 s),
            while fading it out by 1.5 m/s (knee kp 400, swing 0.06 m) fell at 6.4-7.5 s at
            1.4-1.6 m/s in the switch; kp 300 with this fade walked 1.4/1.5/1.6 m/s 60 s at
            1.351/1.392/1.532 m/s (0.08 m swing), and the defaults pass the 60 s range 0.3-1.6
            m/s (``test_speed_range_60s``).
        acceleration: m/s^2 the speed target (used by the placement and the virtual force)
            follows the speed command at.
    """

    slow: float = speed(1.0, ge=0)
    fast: float = speed(1.1, ge=0)
    human_top: float = speed(1.35)
    human_end: float = speed(1.6)
    acceleration: float = acceleration(0.5, ge=0)


@dataclass(frozen=True)
class FootPlacement:
    """Where the swing foot lands (``placement.*``): relative to the COM in the heading frame,
    ``d_sagittal = s_s d(v_s) - k_v v_d - b`` and ``d_coronal = s_c d(v_c) +- w``.

    Attributes:
        sagittal_scale, coronal_scale: IPM offset scales ``s_s``, ``s_c`` (paper: 1.1, 1.3).
        speed_offset: ``k_v`` in ``- k_v v_d`` (s): how far before the IPM point to step
            (paper: 0.05).
        speed_integral, max_speed_bias: after every step the sagittal placement moves back by
            ``speed_integral`` (s) x the step's mean speed error (m/s), up to ``max_speed_bias`` m
            (the bias ``b``: integral action on top of ``- speed_offset v_d``).
        step_width: ``w``, coronal offset of the swing foot from the COM (m).
        min_width: least coronal distance (m) of the swing foot target from the stance foot
            (the hip width when coming to a stop).
        clamp: step offset limit as a fraction of the leg length (per axis).
    """

    sagittal_scale: float = number(1.0, ge=0)
    coronal_scale: float = number(1.0, ge=0)
    speed_offset: float = time(0.1)
    speed_integral: float = time(0.02, ge=0)
    max_speed_bias: float = length(0.1, ge=0)
    step_width: float = length(0.03)
    min_width: float = length(0.1, ge=0)
    clamp: float = number(0.4, gt=0)


@dataclass(frozen=True)
class SwingFoot:
    """The swing foot's path (``swing.*``, :class:`~mjchar.controllers.walking.swing.
    SwingTrajectory`).

    Attributes:
        heights: sole heights (m) at phases 0, 0.5, 1.
        descent_speed: m/s the swing target sinks after phase 1.
        blend: ``"quadratic"`` (lift-off weight ``(1 - phase)^2``, the paper's) or ``"smooth"``
            (``1 - smoothstep(phase)``).
    """

    heights: tuple[float, float, float] = length((0.04, 0.15, 0.02))
    descent_speed: float = speed(1.0, ge=0)
    blend: str = choice("smooth", ("quadratic", "smooth"))


@dataclass(frozen=True)
class StanceLeg:
    """The stance knee and what the stance foot can hold (``stance.*``).

    Attributes:
        knee: stance knee flexion target (rad).
        knee_kp: the stance knee's stiffness up to ``speed.slow`` (N m/rad; ``None``:
            ``tracking.knee_kp``, the swing knee's).
        knee_ramp: the stance knee's target eases (smoothstep) from its flexion at landing to
            ``knee`` over this many phases (0: the target from the start): no knee-extension
            impulse at landing.
        fast_knee_kp, fast_knee_ramp: ``knee_kp``, ``knee_ramp`` at ``speed.fast``.
        knee_ramp_max: the ramp starts from at most this flexion (rad), so a knee that lands
            deeply bent is still pushed up at once (without it a fast walk sinks into a deeper
            crouch step after step and collapses).
        ankle_limit: ``(pitch_fwd, pitch_back, roll)`` moments (N m per N of body weight, i.e. m)
            the stance ankle may apply, so the foot does not roll; ``None`` = no limit.
        yaw_limit: largest vertical (yaw) moment (N m) the stance hip may apply to the pelvis;
            more spins the stance foot on the ground.
        yaw_friction: the stance hip's yaw moment is also limited to ``yaw_friction x m g x r``
            with ``r`` the spread of the stance foot's contact points (0 on a single point).
    """

    knee: float = angle(0.15)
    knee_kp: float | None = torque_gain(None, ge=0, optional=True)
    knee_ramp: float = phase(0.0, ge=0)
    fast_knee_kp: float = torque_gain(200.0, ge=0)
    fast_knee_ramp: float = phase(1.0, ge=0)
    knee_ramp_max: float = angle(0.9)
    ankle_limit: tuple[float, float, float] | None = length((0.08, 0.03, 0.025), ge=0,
                                                            optional=True)
    yaw_limit: float = torque(40.0, ge=0)
    yaw_friction: float = number(0.5, ge=0)


@dataclass(frozen=True)
class HumanBand:
    """The human-like gait band's values (``human.*``), blended in by
    :meth:`IPMParams.human_weight` (from ``speed.slow`` to ``speed.fast``, held to
    ``speed.human_top``, gone by ``speed.human_end``).

    Attributes:
        step_time: step time (s) at ``speed.fast`` in that band (the rate then grows by
            ``timing.cadence_gain`` like the fast one's): 0.48 s, so 1.2 m/s takes 0.47 s nominal
            steps (~0.5 s as walked, 119 steps/min, 0.59 m; the fast band's 0.39 s gave 145
            steps/min and 0.48 m; people at 1.2 m/s: 100-128 steps/min, 0.55-0.72 m).
        stance_knee_kp, stance_knee_ramp: the stance knee in that band: a plain PD to
            ``stance.knee`` from landing (kp 300, no ramp). The fast band's soft knee (kp 200
            easing from the landing flexion) sank into a crouch with longer steps (0.5 s steps
            at 1.2 m/s: stance knee 68-70 deg, COM 0.78 m; mean knee flexion 73-78 deg); a stiff
            knee from landing holds 23-27 deg with push-off (``feet.push_off``). kp 400 gives
            33-34 deg knee flexion at 1.2 m/s but fell at 1.5 m/s in the switch to the fast band.
        swing_height: mid-swing sole height (m) in that band (``swing.heights[1]`` otherwise):
            0.05 m, foot clearance 0.06 m (the 0.15 m swing: 0.14 m, mocap 0.07-0.08 m) and 2-4
            deg less mean knee flexion (34.0 at 0.05, 35.5 at 0.06, 37.5 at 0.08 m).
        coronal_scale: ``placement.coronal_scale`` in that band: 0.8 (at 1.0 the longer steps
            stepped 0.20-0.26 m wide; 0.9: 0.15 m, 0.8: 0.12 m; 0.7 fell at 6.2 s).
        speed_integral: ``placement.speed_integral`` in that band (s): 0.06; with 0.02 the
            human-like gait took ~20 s to reach its speed (1.2 m/s: 1.10 m/s mean over 3-16 s).
    """

    step_time: float = time(0.48, gt=0)
    stance_knee_kp: float = torque_gain(300.0, ge=0)
    stance_knee_ramp: float = phase(0.0, ge=0)
    swing_height: float = length(0.05)
    coronal_scale: float = number(0.8, ge=0)
    speed_integral: float = time(0.06, ge=0)


@dataclass(frozen=True)
class FootMeasures:
    """The feet's measures at speed (``feet.*``): blended in from ``speed.slow`` to
    ``speed.fast`` like the human band (:meth:`IPMParams.speed_blend`) but held at every faster
    speed (measured at 1.4 m/s, where the band has faded to 0.8: 1.10 cm/step of stance slip
    with them faded, 0.95 held; 1.6 m/s 2.64 -> 1.34 cm with ``ankle_back_speeds``; 60 s steady
    speeds 1.294, 1.392, 1.494 m/s at 1.4, 1.5, 1.6).

    Attributes:
        liftoff_height: the swing target's sole height (m) at lift-off (phase 0,
            ``swing.heights[0]`` otherwise): 0.12 m, so the trailing foot comes straight up
            instead of skimming the floor. Measured (stance slip at 1.2 m/s, ``mjchar gait``):
            with 0.04 m the lifted foot slid on 1-4 mm of air at up to 0.6 m/s before the
            probe's stance ended (0.8 of 1.8 cm/step with no contact left); 0.08 m: 1.06 cm,
            0.12 m: 1.00 cm, 0.16 m: 1.02 cm.
        toe_up, toe_up_phase: the swing foot's target is pitched toes up by ``toe_up`` (rad) at
            lift-off, easing (smoothstep) to flat by ``toe_up_phase``. Measured (1.2 m/s): the
            trailing foot left the floor pitched toes down (7 deg, heel up from push-off) and
            tipped further (12 deg) as the knee lifted it, its toe dragged forward within 1 cm
            of the floor for ~50 ms at 0.5-1.5 m/s; toes up 0.2 rad: 0.95 -> 0.83 cm/step, 0.35:
            0.80, 0.5: 0.82 (phase 0.3 or 0.6 alike); 1.1 / 1.3 m/s 1.10 / 0.97 -> 0.75 / 0.82.
            In the slow band (0.5 s steps, no push-off) it made it worse (1.0 m/s: 1.29 -> 1.9).
        push_off, push_off_phase: from ``push_off_phase`` to the end of the step a toes-down
            moment of ``push_off`` x body weight (m) on the stance foot (smoothstep), and the
            forward ankle limit grows to the ball of the foot (its toe joint) with it, so the
            heel lifts. Measured why: with a straight stance knee and 0.5 s steps the stance foot
            stayed flat to the end (pitch 0 deg at the next landing), so the hip sank over it
            (0.83 -> 0.77 m in 6 s), every landing came deeper (swing knee 0.57 -> 0.92 rad at
            contact) and the walk fell at 12.8 s; with 0.2 it holds (landing hip ~0.80 m).
        ankle_back: ``stance.ankle_limit``'s toe-up (``pitch_back``) moment from
            ``ankle_back_speeds`` on (m x body weight): 0.01 m. With 0.03 m the saturated
            forward virtual force kept the stance ankle at that limit from phase 0.1 to 0.45: the
            foot rocked onto its heel (toes up 9 deg, 2 of 8 corners down) and slapped flat again,
            0.9 cm of the 1.98 cm/step slip at 1.2 m/s; 0.01 m: the foot stays flat (1.2 m/s walks
            1.140 m/s instead of 1.167, 1.5 m/s 60 s steady 1.361 instead of 1.387); 0 m: 0.93 cm
            but a 60 s walk at 1.6 m/s fell (7.2 s, with a 0.10 m lift-off).
        ankle_back_speeds: ``ankle_back`` takes over from ``stance.ankle_limit``'s toe-up moment
            between these desired speeds (m/s) and holds at every faster one
            (:meth:`IPMParams.ankle_back_weight`). Measured (``mjchar gait``): the slow band's
            0.03 m (which rocked the foot onto its heel at 1.2 m/s) left most of the slip late in
            stance at 1.0 m/s; with 0.01 m: 1.29 -> 0.65 cm/step at 1.0 m/s, 0.92 -> 0.56 at 0.9,
            0.76 -> 0.56 at 0.8 (1.0 m/s walks 0.92 instead of 0.94 m/s over 3-20 s); at 0.6 m/s
            it gave 0.55 against 0.46, so it starts at 0.7.
        ankle_yaw_kd: the stance ankle's damping (N m s/rad) about the foot's vertical axis
            (``tracking.ankle_kd`` otherwise, and about the other two axes). The stance foot
            keeps its own yaw (no stiffness about the vertical), so this damping is all that
            couples the leg's twist to the planted foot: 60 (with the lift-off and ankle limit
            above, 1.2 m/s) gives a stance slip of 0.95 cm/step against 1.01 with 15; 120: no
            better; 5: 2.8 cm, 2: fell (the leg twists freely, the pelvis loses its yaw anchor).
            Applied at every speed it cost a 150 N backward standing push (38/40 against 39/40).
    """

    liftoff_height: float = length(0.12)
    toe_up: float = angle(0.35, ge=0)
    toe_up_phase: float = phase(0.3, gt=0)
    push_off: float = length(0.2, ge=0)
    push_off_phase: float = phase(0.5, ge=0, lt=1)
    ankle_back: float = length(0.01, ge=0)
    ankle_back_speeds: tuple[float, float] = speed((0.7, 0.9), ge=0)
    ankle_yaw_kd: float = damping_gain(60.0, ge=0)


@dataclass(frozen=True)
class Tracking:
    """PD tracking (``tracking.*``): gains in N m/rad and N m s/rad; the swing thigh, both feet
    and the pelvis in the world frame, the knees in joint space.

    Attributes:
        hip_kp, hip_kd: the swing thigh's gains.
        knee_kp, knee_kd: the knees' (the stance knee's stiffness: :class:`StanceLeg`).
        ankle_kp, ankle_kd: the stance foot's.
        swing_ankle_kp, swing_ankle_kd: the swing foot's, so it lands flat.
        pelvis_kp, pelvis_kd: the pelvis's about the horizontal axes.
        pelvis_yaw_kp, pelvis_yaw_kd: the pelvis's about the vertical (heading) axis.
        feedforward: track the swing thigh's and knee's target velocities (finite differences
            of the IK targets), not zero velocity.
        max_target_rate: clamp on those target velocities (rad/s).
        gravity_compensation: apply the gravity compensation.
        implicit_damping: evaluate every damping term at the next step's velocity (stable PD
            generalised to the controller's damping matrix); explicit damping needs a time step
            of about 0.5 ms.
    """

    hip_kp: float = torque_gain(600.0, ge=0)
    hip_kd: float = damping_gain(60.0, ge=0)
    knee_kp: float = torque_gain(300.0, ge=0)
    knee_kd: float = damping_gain(35.0, ge=0)
    ankle_kp: float = torque_gain(50.0, ge=0)
    ankle_kd: float = damping_gain(15.0, ge=0)
    swing_ankle_kp: float = torque_gain(200.0, ge=0)
    swing_ankle_kd: float = damping_gain(20.0, ge=0)
    pelvis_kp: float = torque_gain(1000.0, ge=0)
    pelvis_kd: float = damping_gain(200.0, ge=0)
    pelvis_yaw_kp: float = torque_gain(300.0, ge=0)
    pelvis_yaw_kd: float = damping_gain(60.0, ge=0)
    feedforward: bool = flag(True)
    max_target_rate: float = rate(10.0, ge=0, unit="rad/s")
    gravity_compensation: bool = flag(True)
    implicit_damping: bool = flag(True)


@dataclass(frozen=True)
class VirtualForce:
    """The virtual force on the COM (``force.*``), ``F = m [sagittal (v_d - v_s), coronal_pos
    (side coronal_offset - d_c) + coronal_vel (v_dc - v_c)]``, through the stance leg.

    Attributes:
        sagittal, coronal_pos, coronal_vel: the gains ``30``, ``c_p``, ``c_v`` (1/s, 1/s^2,
            1/s; paper: 30, 20, 9).
        max_sagittal, max_coronal: the force's clamps (N).
        coronal_offset: desired coronal COM offset from the stance foot (m, towards the swing
            side positive).
    """

    sagittal: float = rate(30.0, ge=0)
    coronal_pos: float = per_length(0.0, ge=0, unit="1/s^2")
    coronal_vel: float = rate(0.0, ge=0)
    max_sagittal: float = force(60.0, ge=0)
    max_coronal: float = force(100.0, ge=0)
    coronal_offset: float = length(0.0)


@dataclass(frozen=True)
class Turning:
    """How the heading target turns and what a turning step changes (``turning.*``).

    Attributes:
        rate: rad/s the heading target turns at, at most; and at most ``acceleration / v_d``
            when walking.
        acceleration: m/s^2 of centripetal acceleration the heading target's turn asks for at
            most.
        hold: seconds after the heading target stops that steps still count as turning: the
            gait right after a turn is still swaying (with 0, a 1.1 m/s right turn fell 1.8 s
            after the target stopped).
        ankle_limit: ``stance.ankle_limit`` in turning steps (a step that starts while the
            heading target moves, or up to ``hold`` after): no pressure behind the ankle and
            less roll, so the stance foot stays flat and keeps its yaw grip. Measured
            (docs/ipm.md): with the straight-walking limits the sagittal virtual force (60 N
            forward in mid-stance) rocks the stance foot back onto its heel edge from phase
            ~0.25 to ~0.7 (toes up to 9 deg; the contact patch holds ~14 N m of yaw moment
            instead of ~30), in a turn onto one heel corner (none), where it spins 15-25 deg;
            the 90 deg turn then fell in 24 of 48 cases (0.5, 1.0-1.6 m/s, left and right, three
            start times). With ``(0.08, 0, 0.025)`` 3 of 35 fell; with roll 0.015 and ``hold``
            1 s, none of 48 (2 of 48, both at 1.6 m/s, with the feet's measures added).
    """

    rate: float = rate(0.5, ge=0, unit="rad/s")
    acceleration: float = acceleration(0.3, ge=0)
    hold: float = time(1.0, ge=0)
    ankle_limit: tuple[float, float, float] = length((0.08, 0.0, 0.015), ge=0)


@dataclass(frozen=True)
class Standing:
    """When standing turns into stepping and back (``standing.*``).

    Attributes:
        stop_speed: COM speed (m/s) under which a step may end in standing (zero command);
            also the COM's sideways speed under which a stopping step's target is widened to
            the standing width (checked every control step, so the target can move by
            ``stand_width - placement.min_width`` within a swing; a blend from half
            ``stop_speed`` to ``stop_speed`` lost the 150 N push this rule saves).
        heading_tolerance: heading error (rad) below which the character may stand.
        capture_margin: the capture point may lie this far (m) outside the support polygon
            before standing turns into stepping (3x that during ``settle_time`` after a stop).
        settle_time: seconds of standing before a speed or heading command starts a walk (a
            push starts stepping at once).
    """

    stop_speed: float = speed(0.15, ge=0)
    heading_tolerance: float = angle(0.1, ge=0)
    capture_margin: float = length(0.03)
    settle_time: float = time(0.3, ge=0)


@dataclass(frozen=True)
class UpperBody:
    """The pelvis's lean and the body above it (``upper.*``).

    Attributes:
        gain_scale: factor on the model's gains table for spine, arms, head and toes.
        arm_abduction: arms hang this far (rad) from the body.
        lean: forward pelvis pitch target (rad) per m/s of desired speed.
    """

    gain_scale: float = number(1.0, ge=0)
    arm_abduction: float = angle(0.15)
    lean: float = rate(0.0, unit="rad per m/s")


@dataclass(frozen=True)
class IPMParams:
    """Every tunable number of :class:`~mjchar.controllers.walking.ipm.IPMController`, in groups
    by concern (SI units, angles in rad; each group's fields and their measured reasons are in
    its own docstring): :class:`StepTiming` ``timing``, :class:`SpeedBands` ``speed``,
    :class:`FootPlacement` ``placement``, :class:`SwingFoot` ``swing``, :class:`StanceLeg`
    ``stance``, :class:`HumanBand` ``human``, :class:`FootMeasures` ``feet``, :class:`Tracking`
    ``tracking``, :class:`VirtualForce` ``force``, :class:`Turning` ``turning``,
    :class:`Standing` ``standing``, :class:`UpperBody` ``upper``.

    ``IPMParams()`` are the defaults, ``IPMParams().updated({"timing.step_time": 0.45})`` the
    defaults with dotted overrides; ``IPMParams(timing=StepTiming(step_time=0.45))`` or
    :func:`dataclasses.replace` work too. Every construction is checked: a value a field does not
    accept (wrong type, NaN or infinite, out of its range) raises one :class:`IPMError` line
    naming the field and what it accepts (``IPM parameter timing.step_time must be a finite
    number > 0 (s), got -1``); ints become floats and sequences tuples.
    """

    timing: StepTiming = field(default_factory=StepTiming)
    speed: SpeedBands = field(default_factory=SpeedBands)
    placement: FootPlacement = field(default_factory=FootPlacement)
    swing: SwingFoot = field(default_factory=SwingFoot)
    stance: StanceLeg = field(default_factory=StanceLeg)
    human: HumanBand = field(default_factory=HumanBand)
    feet: FootMeasures = field(default_factory=FootMeasures)
    tracking: Tracking = field(default_factory=Tracking)
    force: VirtualForce = field(default_factory=VirtualForce)
    turning: Turning = field(default_factory=Turning)
    standing: Standing = field(default_factory=Standing)
    upper: UpperBody = field(default_factory=UpperBody)

    def __post_init__(self) -> None:
        for name, group in checked(self, IPMError, "IPM parameter").items():
            object.__setattr__(self, name, group)
        t, s, lo_hi = self.timing, self.speed, self.feet.ankle_back_speeds
        if not t.min_phase < t.max_phase:
            raise IPMError(f"IPM parameters need timing.min_phase < timing.max_phase, got "
                           f"{t.min_phase:g} and {t.max_phase:g}")
        if not s.fast <= s.human_top < s.human_end:
            raise IPMError(f"IPM parameters need speed.fast <= speed.human_top < speed.human_end"
                           f", got {s.fast:g}, {s.human_top:g}, {s.human_end:g}")
        if not lo_hi[0] < lo_hi[1]:
            raise IPMError(f"IPM parameter feet.ankle_back_speeds must be (from, full) m/s with "
                           f"from < full, got {lo_hi!r}")

    @staticmethod
    def names() -> list[str]:
        """Every parameter's dotted name (``"timing.step_time"``), in declaration order."""
        return names(IPMParams)

    def flat(self) -> dict[str, object]:
        """``{dotted name: value}`` of every parameter."""
        return _flat(self)

    @staticmethod
    def tunables() -> list[Tunable]:
        """Every parameter as ``--param`` takes it (dotted name, declaration, default, meaning
        from its group's docstring): ``mjchar params ipm``."""
        return tunables(IPMParams())

    def updated(self, overrides: Mapping[str, object]) -> IPMParams:
        """These parameters with ``overrides`` (``{"group.field": value}``; sequences as tuples
        of floats), checked; an unknown name raises :class:`IPMError` listing the valid ones."""
        return overridden(self, overrides, IPMError, "IPM parameter") if overrides else self

    def for_body(self, leg_length: float, mass: float) -> IPMParams:
        """These parameters carried from the tuned body (:data:`TUNED_LEG_LENGTH`,
        :data:`TUNED_MASS`) to a body of ``leg_length`` m and ``mass`` kg by dynamic similarity,
        each by the dimension it is declared with (unchanged, the same object, when the body is
        the tuned one to 1e-6)."""
        if not (leg_length > 0 and mass > 0):
            raise IPMError(f"leg length and mass must be positive, got {leg_length}, {mass}")
        r, q = leg_length / TUNED_LEG_LENGTH, mass / TUNED_MASS
        if abs(r - 1) < 1e-6 and abs(q - 1) < 1e-6:
            return self
        return scaled(self, similarity_factors(r, q))

    def speed_blend(self, v_desired: float) -> float:
        """0 up to ``speed.slow`` (m/s), 1 from ``speed.fast`` on, linear in between."""
        v = abs(float(v_desired))
        slow, fast = self.speed.slow, self.speed.fast
        if v <= slow or fast <= slow:
            return 0.0 if v <= slow else 1.0
        return min((v - slow) / (fast - slow), 1.0)

    def human_weight(self, v_desired: float) -> float:
        """Weight (0-1) of the ``human.*`` values at a desired speed (m/s): 0 up to
        ``speed.slow``, 1 from ``speed.fast`` to ``speed.human_top``, 0 again from
        ``speed.human_end`` on (linear in between)."""
        v = abs(float(v_desired))
        x = self.speed_blend(v)
        top, end = self.speed.human_top, self.speed.human_end
        if v > top:
            x *= max(0.0, 1.0 - (v - top) / max(end - top, 1e-9))
        return x

    def ankle_back_weight(self, v_desired: float) -> float:
        """Weight (0-1) of ``feet.ankle_back`` at a desired speed (m/s): 0 up to
        ``feet.ankle_back_speeds[0]``, 1 from ``feet.ankle_back_speeds[1]`` on (and from
        ``speed.fast`` on in any case), linear in between."""
        v = abs(float(v_desired))
        lo, hi = self.feet.ankle_back_speeds
        x = 0.0 if v <= lo else 1.0 if v >= hi else (v - lo) / (hi - lo)
        return max(x, self.speed_blend(v))

    def at_speed(self, v_desired: float) -> tuple[float, float, float]:
        """``(step_time, stance_knee_kp, stance_knee_ramp)`` at a desired speed (m/s): the slow
        values up to ``speed.slow``, the fast ones from ``speed.fast``, linear between; above
        ``speed.fast`` the step rate grows by ``timing.cadence_gain`` per m/s; the ``human.*``
        values blended in by :meth:`human_weight` (so they hold from ``speed.fast`` to
        ``speed.human_top``)."""
        t, k, r = self._fast_at_speed(v_desired)
        w = self.human_weight(v_desired)
        if w <= 0:
            return t, k, r
        h = self.human
        th = h.step_time
        v = abs(float(v_desired))
        if v > self.speed.fast:  # the human step rate grows with speed too
            th = 1.0 / (1.0 / th + self.timing.cadence_gain * (v - self.speed.fast))
        return (t + w * (th - t), k + w * (h.stance_knee_kp - k),
                r + w * (h.stance_knee_ramp - r))

    def _fast_at_speed(self, v_desired: float) -> tuple[float, float, float]:
        x = self.speed_blend(v_desired)
        tm, st = self.timing, self.stance
        kp = self.tracking.knee_kp if st.knee_kp is None else st.knee_kp
        step_time = tm.step_time + x * (tm.fast_step_time - tm.step_time)
        v = abs(float(v_desired))
        if v > self.speed.fast > self.speed.slow:
            steps_per_s = 1.0 / tm.fast_step_time + tm.cadence_gain * (v - self.speed.fast)
            step_time = 1.0 / steps_per_s
        return (step_time,
                kp + x * (st.fast_knee_kp - kp),
                st.knee_ramp + x * (st.fast_knee_ramp - st.knee_ramp))


def ipm_step_offset(v, h: float, g: float = GRAVITY):
    """Inverted-pendulum step offset ``d = v sqrt(h/g + v^2/(4 g^2))`` (m) for a COM speed ``v``
    (m/s, scalar or array) at height ``h`` (m) over the stance foot: stepping ``d`` ahead of the
    COM brings a pendulum of that energy to rest over the foot."""
    if not (math.isfinite(h) and h > 0):
        raise IPMError(f"COM height must be positive metres, got {h}")
    if isinstance(v, float):  # a Python float: the same IEEE operations, without numpy's calls
        return v * math.sqrt(h / g + v * v / (4.0 * g * g))
    v = np.asarray(v, dtype=float)
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
