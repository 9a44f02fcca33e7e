"""SIMBICON gait parameters as data (Yin, Loken and van de Panne, "SIMBICON: Simple Biped
Locomotion Control", SIGGRAPH 2007).

A :class:`Gait` is plain data: the per-state target angles of the four-state finite-state
machine, the balance-feedback gains, the torso lean, the pose of the rest of the body and the
PD gains, all JSON round-trippable (:meth:`Gait.to_dict` / :meth:`Gait.from_dict`). States 0 and
2 (and 1 and 3) are mirror images, so a gait stores two :class:`StateParams`: the lift-off state
(0/2, timed) and the swing state (1/3, ended by the swing foot's contact or a timeout).

Angle conventions (anatomical, independent of any model's hinge axes; the controller finds the
sign of each hinge on the model itself, see :mod:`mjchar.controllers.walking.simbicon`):

- hip: ``+`` = flexion (thigh forward); ``coronal`` ``+`` = abduction (thigh away from the
  body's midline). The swing hip's angles are in the *heading* frame (world-aligned, yawed with
  the pelvis), not relative to the pelvis.
- knee: ``+`` = flexion. (The paper writes knee flexion as a negative angle: its 3D walk's swing
  knee ``-1.10`` is ``1.10`` here.)
- ankle: ``+`` = dorsiflexion (toes up), relative to the shank.
- torso: ``pitch`` ``+`` = forward lean of the pelvis in the heading frame.

The balance feedback on the swing hip is ``theta_d = theta_d0 + cd * d + cv * v`` per plane,
with ``d``/``v`` the centre of mass's horizontal offset from the stance ankle and its velocity in
the heading frame (sagittal: forward; coronal: towards the swing leg's side).

Gains are ``(kp, kd)`` in N m/rad and N m s/rad.

Every number is declared with its dimension and plausible range
(:mod:`~mjchar.controllers.core.param_fields`: joint angles within half a turn, durations up to
10 s, feedback gains within +-20, PD gains up to 1e5 N m/rad and 1e4 N m s/rad...), so a gait
or an override (``mjchar run simbicon --param torso_pitch=0.3``) with a wrong type, NaN or an
absurd value is one :class:`GaitError` line naming the parameter and what it accepts;
``mjchar params simbicon`` lists them.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field

from mjchar.bvh.errors import MjcharError

from ..core.param_fields import (
    REFUSED,
    Spec,
    Tunable,
    angle,
    check_fields,
    flag,
    force,
    length,
    number,
    per_length,
    phase,
    rate,
    rebuilt,
    spec_of,
    speed,
    suggest,
    time,
    tunables,
)
from ..core.similarity import similarity_factors

#: standard gravity (m/s^2), for Froude numbers and body scaling
GRAVITY = 9.81


#: :class:`Gait` fields a speed anchor may set besides the per-state parameters
ANCHOR_FIELDS = ("torso_pitch", "spine_pitch", "arm_swing", "max_twist", "contact_phase",
                 "velocity_force")


class GaitError(MjcharError):
    """A gait was asked for by an unknown name, or given a parameter it does not have or a
    value the parameter does not accept."""


#: a joint angle target: within half a turn either way (rad)
HALF_TURN = math.pi
#: the balance feedback gains' range (rad/m, rad s/m)
FEEDBACK_LIMIT = 20.0
#: the PD gain groups a gait may set (``gains``, ``gain_<group>`` overrides) and what they drive
GAIN_GROUPS = {
    "torso": "pelvis pitch and roll in the world frame",
    "torso_yaw": "pelvis yaw in the world frame (default: torso's)",
    "stance_twist": "the stance hip's twist (heading control)",
    "swing_hip": "the swing hip in the world frame",
    "swing_ankle_world": "the swing foot's pitch in the heading frame (swing_ankle_world)",
    "hip": "the hips in joint space",
    "knee": "the knees",
    "ankle": "the ankles",
    "toe": "the toes",
    "spine": "the spine joints",
    "head": "the neck and head",
    "arm": "the shoulders, elbows and wrists",
    "other": "every other joint",
    "stance_ankle_roll": "the stance ankle's roll hinge (default: ankle's)",
    "stance_ankle_twist": "the stance ankle's twist hinge (default: ankle's)",
    "swing_ankle_level": "the swing ankle's roll, levelling the sole in the swing state",
}
#: a gain pair's ``kp`` and ``kd`` (the magnitudes :mod:`param_fields` caps)
_KP = Spec("torque_gain", "N m/rad", low=0.0, high=1e5)
_KD = Spec("damping_gain", "N m s/rad", low=0.0, high=1e4)


def _angle(default=dataclasses.MISSING, **kw):
    return angle(default, ge=kw.pop("ge", -HALF_TURN), le=kw.pop("le", HALF_TURN), **kw)


def _gain_pair(group: str, value, what: str) -> tuple[float, float]:
    """``value`` as a ``(kp, kd)`` pair of floats, or a one-line :class:`GaitError`."""
    if group not in GAIN_GROUPS:
        near = suggest(group, GAIN_GROUPS)
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        raise GaitError(f"{what}: unknown gain group {group!r}{hint}; groups: "
                        f"{', '.join(GAIN_GROUPS)}")
    pair = value if isinstance(value, list | tuple) and len(value) == 2 else None
    kp = REFUSED if pair is None else _KP.coerce(pair[0])
    kd = REFUSED if pair is None else _KD.coerce(pair[1])
    if kp is REFUSED or kd is REFUSED:
        raise GaitError(f"{what} must be [kp, kd]: kp {_KP.accepted()}, kd {_KD.accepted()}; "
                        f"got {value!r}")
    return kp, kd


@dataclass(frozen=True)
class StateParams:
    """Targets and feedback of one FSM state (written for either stance leg).

    Attributes:
        duration: the state's length (s) when timed (states 0/2); for the swing states (1/3) the
            nominal length that the phase is measured against.
        ends_on_contact: end when the swing foot lands (phase > ``contact_phase`` and its normal
            force > ``contact_force``) or after ``timeout``; else after ``duration``.
        swing_hip: swing-hip flexion target theta_d0 in the sagittal plane of the heading
            frame (rad).
        swing_hip_coronal: swing-hip abduction target in the coronal plane (rad).
        swing_knee: swing-knee flexion (rad).
        swing_ankle: swing-ankle dorsiflexion (rad).
        stance_knee: stance-knee flexion (rad).
        stance_ankle: stance-ankle dorsiflexion (rad).
        cd, cv: sagittal feedback gains (rad/m, rad s/m).
        cd_coronal, cv_coronal: coronal feedback gains (rad/m, rad s/m).
        timeout: a contact-ended state ends after this long (s) even without contact.
    """

    duration: float = time(gt=0)
    ends_on_contact: bool = flag()
    swing_hip: float = _angle()
    swing_hip_coronal: float = _angle()
    swing_knee: float = _angle()
    swing_ankle: float = _angle()
    stance_knee: float = _angle()
    stance_ankle: float = _angle()
    cd: float = per_length(ge=-FEEDBACK_LIMIT, le=FEEDBACK_LIMIT, unit="rad/m")
    cv: float = rate(ge=-FEEDBACK_LIMIT, le=FEEDBACK_LIMIT, unit="rad s/m")
    cd_coronal: float = per_length(ge=-FEEDBACK_LIMIT, le=FEEDBACK_LIMIT, unit="rad/m")
    cv_coronal: float = rate(ge=-FEEDBACK_LIMIT, le=FEEDBACK_LIMIT, unit="rad s/m")
    timeout: float = time(1.0, gt=0)

    def __post_init__(self) -> None:
        for k, v in check_fields(self, GaitError, "gait state parameter").items():
            object.__setattr__(self, k, v)


@dataclass(frozen=True)
class Gait:
    """One SIMBICON gait.

    Attributes:
        name: the gait's name.
        states: ``(lift-off state 0/2, swing state 1/3)``.
        torso_pitch: forward lean of the pelvis, heading frame (rad).
        spine_pitch: flexion of each spine joint relative to its parent (rad; ``+`` forward).
        shoulder_down: arms lowered from a T-pose (rad, ``+`` down; a rest pose whose arms
            already hang part of the way down, an A-pose, is lowered by the rest).
        elbow_flexion: elbow flexion (rad).
        arm_swing: shoulder flexion (rad) of the arm opposite the swing leg (the other arm
            extends as much): arms swing against the legs, which cancels part of the legs' yaw.
        swing_ankle_world: control the swing foot in the desired-heading frame (``swing_ankle`` =
            its pitch, toes up) instead of relative to the shank.
        contact_phase, contact_force: the swing-foot contact test of states 1/3 (phase > this
            fraction of ``duration`` and normal force > this many N).
        max_twist: bound (rad) on the stance hip's twist target (the heading control).
        gains: ``(kp, kd)`` per group: ``torso`` (world-frame pelvis pitch and roll),
            ``stance_twist`` (the stance hip's twist, heading control), ``swing_hip`` (world
            frame), ``knee``, ``ankle``, ``toe``, ``spine``, ``head``, ``arm``, and the stance
            ankle's own ``stance_ankle_roll`` and ``stance_ankle_twist`` (its hinges nearest the
            forward and the vertical axis: a soft roll lets the sole sit flat across its width
            instead of on one heel corner, a twist without stiffness lets the leg turn above a
            planted foot instead of spinning it; left out, the stance ankle uses ``ankle``), and
            ``swing_ankle_level`` (in the swing state, the swing ankle's roll hinge levels the
            sole across its width in the world, so the heel lands on both its corners; left
            out, it holds its roll relative to the shank; ``swing_ankle_world`` overrides it).
            The stance ankle's roll and twist still carry the virtual forces' share
            (``velocity_force``). A group left out uses the model's own gains table.
        start_speed: forward speed (m/s) given to the standing start pose.
        speed_target, speed_gain, speed_limit: optional step-to-step speed regulation (off when
            ``speed_target`` is ``None``): at every lift-off the sagittal swing-hip offset
            ``delta += speed_gain (v_step - speed_target)`` (rad; ``v_step`` the mean forward
            speed of the centre of mass over the last step, m/s), bounded by ``speed_limit``,
            is added to theta_d. It is integral action on the speed (e.g. on slopes, where the
            proportional feedback ``cv v`` alone settles at another speed).
        body_leg_length, body_mass: the body the gait was tuned on: its leg length (m; the hips'
            height over the soles in the rest pose) and mass (kg). On another body the gait is
            scaled by :meth:`scaled` (``None``: used as it is on every body).
        froude: the gait's own steady forward speed (no speed regulation) on its body, as a
            Froude number ``v / sqrt(g leg_length)`` (``None``: unknown; then it takes no speed
            command).
        speed_anchors: the speed command's feed-forward: ``((froude, {parameter: value}),
            ...)``, parameters as :meth:`with_overrides` keys (a :class:`Gait` field or
            ``state0_``/``state1_<field>``) tuned at that Froude speed;
            :meth:`for_speed` interpolates them with the gait's own values at :attr:`froude`.
            Only what the controller reads at every step: per-state parameters and
            :data:`ANCHOR_FIELDS`.
        speed_acceleration: how fast a speed command moves from the gait's own speed to the
            commanded one, in g (0.02: 0.2 m/s^2; dimensionless, the same on every body).
        swing_gravity: fraction of the swing leg's weight compensated by Jacobian-transpose
            torques on its joints (Coros, Beaudoin and van de Panne 2010, "Generalized Biped
            Walking Control"; 0: off). Its hip share reacts on the stance hip like the rest
            of the swing hip's torque.
        stance_support: fraction of the body's weight carried by a virtual upward force on
            the centre of mass through the stance leg's ankle and knee (Jacobian transpose with
            the stance foot fixed; 0: off).
        velocity_force, velocity_force_coronal: Coros 2010's velocity tuning: a virtual
            force on the centre of mass through the stance ankle and knee,
            ``F = k m g (v_d - v) / sqrt(g L)`` per plane (``k`` dimensionless, ``m`` the
            body's mass, ``L`` its leg length), ``v_d`` the speed target forward (none: no
            sagittal force) and 0 sideways; 0: off.
    """

    name: str
    states: tuple[StateParams, StateParams]
    torso_pitch: float = _angle(0.0)
    spine_pitch: float = _angle(0.0)
    shoulder_down: float = _angle(1.3)
    elbow_flexion: float = _angle(0.2)
    arm_swing: float = _angle(0.0)
    swing_ankle_world: bool = flag(False)
    contact_phase: float = phase(0.5, ge=0)
    contact_force: float = force(20.0, ge=0)
    max_twist: float = _angle(0.5, ge=0)
    gains: dict = field(default_factory=dict)
    start_speed: float = speed(0.0)
    speed_target: float | None = speed(None, ge=0, optional=True)
    speed_gain: float = rate(0.0, ge=0, le=10, unit="rad per m/s")
    speed_limit: float = _angle(0.3, ge=0)
    body_leg_length: float | None = length(None, gt=0, optional=True)
    body_mass: float | None = number(None, gt=0, le=1e4, optional=True, unit="kg")
    froude: float | None = number(None, ge=0, le=5, optional=True)
    speed_anchors: tuple = ()
    speed_acceleration: float = number(0.02, ge=0, le=10, unit="g")
    swing_gravity: float = number(0.0, ge=0, le=2)
    stance_support: float = number(0.0, ge=0, le=2)
    velocity_force: float = number(0.0, ge=0, le=10)
    velocity_force_coronal: float = number(0.0, ge=0, le=10)

    def __post_init__(self) -> None:
        what = f"gait {self.name!r}:" if isinstance(self.name, str) else "gait:"
        if not isinstance(self.name, str):
            raise GaitError(f"a gait's name must be text, got {self.name!r}")
        if not (isinstance(self.states, tuple) and len(self.states) == 2
                and all(isinstance(s, StateParams) for s in self.states)):
            raise GaitError(f"{what} states must be 2 StateParams (0/2 and 1/3)")
        if not isinstance(self.gains, dict):
            raise GaitError(f"{what} gains must be an object of group: [kp, kd]")
        gains = {g: _gain_pair(g, v, f"{what} gain_{g}") for g, v in self.gains.items()}
        changes = check_fields(self, GaitError, what)
        if gains != self.gains or any(type(v) is not tuple for v in self.gains.values()):
            changes["gains"] = gains
        for k, v in changes.items():
            object.__setattr__(self, k, v)

    # -- data in and out ----------------------------------------------------------------------
    def to_dict(self) -> dict:
        """A JSON-ready dict (``states`` as a list of two dicts, gains as lists)."""
        d = dataclasses.asdict(self)
        d["states"] = [dataclasses.asdict(s) for s in self.states]
        d["gains"] = {k: list(v) for k, v in self.gains.items()}
        d["speed_anchors"] = [[f, dict(o)] for f, o in self.speed_anchors]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Gait:
        """Inverse of :meth:`to_dict`; raises :class:`GaitError` on unknown or missing keys."""
        d = dict(d)
        try:
            states = tuple(StateParams(**s) for s in d.pop("states"))
        except (KeyError, TypeError) as e:
            raise GaitError(f"gait states: {e}") from None
        if len(states) != 2:
            raise GaitError(f"a gait has 2 states (0/2 and 1/3), got {len(states)}")
        gains = d.pop("gains", {})
        if not isinstance(gains, dict):
            raise GaitError(f"gait gains must be an object of group: [kp, kd], got {gains!r}")
        try:
            anchors = tuple((float(f), dict(o)) for f, o in d.pop("speed_anchors", ()))
        except (TypeError, ValueError) as e:
            raise GaitError(f"gait speed_anchors: a list of [froude, {{parameter: value}}]: {e}") \
                from None
        try:
            return cls(states=states, gains=gains, speed_anchors=anchors, **d)  # type: ignore[arg-type]
        except TypeError as e:
            raise GaitError(f"gait: {e}") from None

    @classmethod
    def from_json(cls, text: str) -> Gait:
        return cls.from_dict(json.loads(text))

    # -- variations ----------------------------------------------------------------------------
    def with_overrides(self, **overrides) -> Gait:
        """A copy with some parameters changed.

        Keys may be any :class:`Gait` field; any :class:`StateParams` field (applied to both
        states, e.g. ``cd=0``); ``state0_<field>`` / ``state1_<field>`` for one state;
        ``gain_<group>``
        = ``(kp, kd)``; and ``feedback=False`` (all ``cd``/``cv`` zero).
        """
        top: dict = {}
        per_state: list[dict] = [{}, {}]
        gains = dict(self.gains)
        for key, value in overrides.items():
            if key == "feedback":
                if not isinstance(value, bool):
                    raise GaitError(f"gait parameter feedback must be true or false, got "
                                    f"{value!r}")
                if not value:
                    for ps in per_state:
                        ps.update(cd=0.0, cv=0.0, cd_coronal=0.0, cv_coronal=0.0)
            elif key.startswith("gain_"):
                gains[key[5:]] = _gain_pair(key[5:], value, f"gait parameter {key}")
            elif key in _STATE_SPECS:
                value = _accepted(key, _STATE_SPECS[key], value)
                for ps in per_state:
                    ps[key] = value
            elif key[:7] in ("state0_", "state1_") and key[7:] in _STATE_SPECS:
                per_state[int(key[5])][key[7:]] = _accepted(key, _STATE_SPECS[key[7:]], value)
            elif key in _GAIT_SPECS:
                top[key] = _accepted(key, _GAIT_SPECS[key], value)
            else:
                valid = [*_GAIT_SPECS, *_STATE_SPECS,
                         *(f"state{i}_{k}" for i in (0, 1) for k in _STATE_SPECS),
                         *(f"gain_{g}" for g in GAIN_GROUPS), "feedback"]
                near = suggest(key, valid)
                hint = f" (did you mean {', '.join(near)}?)" if near else ""
                raise GaitError(
                    f"unknown gait parameter {key!r}{hint}; use a Gait field, a state field "
                    f"(both states), state0_/state1_<field>, gain_<group> or feedback "
                    f"(`mjchar params simbicon` lists them)")
        states = tuple(
            dataclasses.replace(s, **ps) for s, ps in zip(self.states, per_state, strict=True)
        )
        return dataclasses.replace(self, states=states, gains=gains, **top)

    def value(self, key: str) -> float:
        """The number that :meth:`with_overrides` key ``key`` sets (a :class:`Gait` field or
        ``state0_``/``state1_<field>``)."""
        if key[:7] in ("state0_", "state1_"):
            return getattr(self.states[int(key[5])], key[7:])
        if key in ("states", "gains", "speed_anchors") or not hasattr(self, key):
            raise GaitError(f"{key!r} is not a number of the gait (speed_anchors take a Gait "
                            "field or state0_/state1_<field>)")
        return getattr(self, key)

    def for_speed(self, froude: float) -> Gait:
        """The gait's feed-forward for a commanded speed (a Froude number ``v / sqrt(g L)``):
        every parameter of :attr:`speed_anchors` interpolated linearly in Froude speed between
        the gait's own value at :attr:`froude` and the anchors' values (held beyond the last
        anchor). The speed regulation (:attr:`speed_target`) is left to the caller."""
        if self.froude is None:
            raise GaitError(f"gait {self.name!r} takes no speed command (its froude is unknown)")
        keys = sorted({k for _, o in self.speed_anchors for k in o})
        for k in keys:
            if k not in ANCHOR_FIELDS and k[:7] not in ("state0_", "state1_"):
                raise GaitError(f"speed anchor parameter {k!r}: give state0_/state1_<field> or "
                                f"one of {', '.join(ANCHOR_FIELDS)}")
        points = sorted([(self.froude, {})] + [(float(f), o) for f, o in self.speed_anchors],
                        key=lambda p: p[0])
        xs = [f for f, _ in points]
        out = {}
        for k in keys:
            ys = [o.get(k, self.value(k)) for _, o in points]
            out[k] = float(_interp(froude, xs, ys))
        return self.with_overrides(**out) if out else self

    def scaled(self, leg_length: float, mass: float) -> Gait:
        """The gait on a body of ``leg_length`` m and ``mass`` kg, dynamically similar to its
        own body (:attr:`body_leg_length`, :attr:`body_mass`): with ``l`` and ``m`` the length
        and mass ratios, times (durations, timeout) scale by ``sqrt(l)``, speeds by ``sqrt(l)``,
        PD stiffness by ``m l`` (torque per rad, as ``mass g leg_length``) and damping by
        ``m l sqrt(l)``, the balance feedback ``cd`` by ``1/l`` (rad/m), ``cv`` and the speed
        gain by ``1/sqrt(l)`` (rad s/m), the contact-force test by ``m``; angles are unchanged.
        The same gait (``self``) when the body is the gait's own or the gait has none. The
        result has no :attr:`speed_anchors` (they are in the own body's units: call
        :meth:`for_speed` first)."""
        if self.body_leg_length is None or self.body_mass is None:
            return self
        ratio_l = leg_length / self.body_leg_length
        ratio_m = mass / self.body_mass
        if ratio_l == 1.0 and ratio_m == 1.0:
            return self
        f = similarity_factors(ratio_l, ratio_m)
        t, k = f["time"], f["torque_gain"]

        # not checked again (param_fields.rebuilt): the ranges are the tuned body's
        def state(p: StateParams) -> StateParams:
            return rebuilt(
                p, duration=p.duration * t, timeout=p.timeout * t, cd=p.cd / ratio_l,
                cv=p.cv / t, cd_coronal=p.cd_coronal / ratio_l, cv_coronal=p.cv_coronal / t)

        return rebuilt(
            self,
            states=tuple(state(p) for p in self.states),
            gains={g: (kp * k, kd * k * t) for g, (kp, kd) in self.gains.items()},
            contact_force=self.contact_force * ratio_m,
            start_speed=self.start_speed * t,
            speed_target=None if self.speed_target is None else self.speed_target * t,
            speed_gain=self.speed_gain / t,
            body_leg_length=leg_length,
            body_mass=mass,
            speed_anchors=(),  # in the gait's own body's units: apply for_speed first
        )


#: the declared numbers of a gait and of a state, by name (what overrides may set)
_GAIT_SPECS = {f.name: spec_of(f) for f in dataclasses.fields(Gait) if "param" in f.metadata}
_STATE_SPECS = {f.name: spec_of(f) for f in dataclasses.fields(StateParams)}


def _accepted(key: str, spec: Spec, value):
    """``value`` as the parameter ``key`` stores it, or a one-line :class:`GaitError`."""
    stored = spec.coerce(value)
    if stored is REFUSED:
        raise GaitError(f"gait parameter {key} must be {spec.accepted()}, got {value!r}")
    return stored


def gait_tunables(gait: Gait) -> list[Tunable]:
    """Every ``--param`` of a SIMBICON gait with its default in ``gait``: the gait's numbers,
    each state's (``state0_<field>``: the lift-off states 0/2, ``state1_<field>``: the swing
    states 1/3; a bare state field sets both), the gain groups (``gain_<group>``) and
    ``feedback``."""
    rows = tunables(gait)
    for i, what in ((0, "lift-off states 0/2"), (1, "swing states 1/3")):
        rows += [t._replace(meaning=f"{what}: {t.meaning}")
                 for t in tunables(gait.states[i], prefix=f"state{i}_")]
    pair = Spec("none", "N m/rad, N m s/rad", size=2, low=0.0, high=1e5)
    rows += [Tunable(f"gain_{g}", pair, gait.gains.get(g), f"(kp, kd) of {meaning}")
             for g, meaning in GAIN_GROUPS.items()]
    rows.append(Tunable("feedback", Spec("none", kind="flag"), True,
                        "false zeroes every balance feedback gain (cd, cv, coronal too)"))
    return rows


def _interp(x: float, xs: list[float], ys: list[float]) -> float:
    """Piecewise-linear ``y(x)`` through ``(xs, ys)`` (``xs`` ascending), held at the ends."""
    if x <= xs[0]:
        return ys[0]
    for x0, x1, y0, y1 in zip(xs, xs[1:], ys, ys[1:], strict=False):
        if x <= x1:
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0) if x1 > x0 else y1
    return ys[-1]


#: leg length (m, hips' height over the soles at rest) and mass (kg) of the bundled humanoid,
#: the body the gaits below were tuned on, as :class:`~mjchar.controllers.walking.simbicon.Simbicon`
#: measures them
BUNDLED_LEG_LENGTH, BUNDLED_MASS = 0.878, 70.00001

#: Normal walk. Started from REFERENCE.md's 3D SIMBICON walk targets and tuned on the bundled
#: humanoid by CMA-ES (walk speed, heading, pushes at random phases, 5 degree slopes; see
#: docs/simbicon.md). Steady speed 1.05 m/s on level ground (Froude 0.357); no speed regulation
#: of its own (it made the uphill walk slower, see docs/simbicon.md). A speed command
#: (``Simbicon(speed=V)``, ``mjchar run simbicon --speed V``) interpolates two anchors tuned by
#: hand on the bundled humanoid at Froude 0.22 (less lean, more swing-hip flexion and coronal
#: feedback) and 0.53 (more lean, less swing-hip flexion) and regulates towards V with
#: ``speed_gain`` (docs/simbicon.md, "Speed command").
WALK = Gait(
    name="walk",
    states=(
        StateParams(
            duration=0.261,
            ends_on_contact=False,
            swing_hip=0.576,
            swing_hip_coronal=-0.023,
            swing_knee=1.583,
            swing_ankle=0.739,
            stance_knee=-0.009,
            stance_ankle=0.003,
            cd=0.534,
            cv=0.208,
            cd_coronal=0.657,
            cv_coronal=0.188,
        ),
        StateParams(
            duration=0.3,
            ends_on_contact=True,
            swing_hip=0.131,
            swing_hip_coronal=-0.023,
            swing_knee=0.083,
            swing_ankle=0.087,
            stance_knee=0.146,
            stance_ankle=0.163,
            cd=0.534,
            cv=0.208,
            cd_coronal=0.657,
            cv_coronal=0.188,
        ),
    ),
    torso_pitch=0.298,
    spine_pitch=-0.029,
    arm_swing=0.442,
    max_twist=0.21,
    speed_gain=0.02,
    body_leg_length=BUNDLED_LEG_LENGTH,
    body_mass=BUNDLED_MASS,
    froude=0.357,
    speed_anchors=(
        (0.22, {"state0_swing_hip": 0.666, "state1_swing_hip": 0.221, "torso_pitch": 0.2,
                "state0_cd_coronal": 0.8, "state1_cd_coronal": 0.8}),
        (0.53, {"state0_swing_hip": 0.486, "state1_swing_hip": 0.041, "torso_pitch": 0.5,
                "arm_swing": 0.6, "state0_cd_coronal": 0.8, "state1_cd_coronal": 0.8,
                "contact_phase": 0.25}),
    ),
    gains={
        "torso": (873.399, 87.34),
        "swing_hip": (260.881, 26.088),
        "ankle": (363.157, 36.316),
        "stance_twist": (600.0, 60.0),
    },
)

#: the per-state fields a speed anchor takes from another gait's legs (:func:`_legs_at`)
_LEG_FIELDS = ("swing_hip", "swing_hip_coronal", "swing_knee", "swing_ankle", "stance_knee",
               "stance_ankle", "cd", "cv", "cd_coronal", "cv_coronal")


def _legs_at(gait: Gait, froude: float) -> dict:
    """Speed-anchor values: ``gait``'s per-state targets and feedback (states 0 and 1, which
    states 2 and 3 mirror) and lean at the Froude speed ``froude``."""
    g = gait.for_speed(froude)
    legs = {f"state{i}_{k}": getattr(g.states[i], k) for i in (0, 1) for k in _LEG_FIELDS}
    return {**legs, "torso_pitch": g.torso_pitch}


#: Crouch walk: the same controller with bent stance knees (0.5 rad, 29 degrees, in both
#: states), a 0.283 rad forward lean and dorsiflexed stance ankles; derived from an earlier walk
#: (its gains) and re-tuned by CMA-ES for 0.9 m/s at 4 seeds (docs/simbicon.md). Level ground
#: only: it does not meet the walk's push and slope figures.
CROUCH = Gait(
    name="crouch",
    states=(
        StateParams(
            duration=0.253,
            ends_on_contact=False,
            swing_hip=0.667,
            swing_hip_coronal=-0.023,
            swing_knee=1.486,
            swing_ankle=0.913,
            stance_knee=0.5,
            stance_ankle=0.225,
            cd=0.493,
            cv=0.275,
            cd_coronal=0.585,
            cv_coronal=0.291,
        ),
        StateParams(
            duration=0.3,
            ends_on_contact=True,
            swing_hip=0.142,
            swing_hip_coronal=-0.023,
            swing_knee=0.1,
            swing_ankle=0.062,
            stance_knee=0.5,
            stance_ankle=0.467,
            cd=0.493,
            cv=0.275,
            cd_coronal=0.585,
            cv_coronal=0.291,
        ),
    ),
    torso_pitch=0.283,
    spine_pitch=-0.029,
    arm_swing=0.442,
    max_twist=0.21,
    speed_target=0.9,
    speed_gain=0.002,
    body_leg_length=BUNDLED_LEG_LENGTH,
    body_mass=BUNDLED_MASS,
    gains={
        "torso": (843.423, 84.342),
        "swing_hip": (337.36, 33.736),
        "ankle": (363.157, 36.316),
        "stance_twist": (600.0, 60.0),
    },
)

#: the natural gait's legs and lean before its stance-foot retune: its fast anchor
_NATURAL_FAST_LEGS = {
    "state0_swing_hip": 0.6334, "state0_swing_hip_coronal": -0.0691, "state0_swing_knee": 1.4516,
    "state0_swing_ankle": 0.9036, "state0_stance_knee": -0.0351, "state0_stance_ankle": 0.143,
    "state0_cd": 0.5818, "state0_cv": 0.1379, "state0_cd_coronal": 0.4473,
    "state0_cv_coronal": 0.1926,
    "state1_swing_hip": 0.2015, "state1_swing_hip_coronal": -0.0691, "state1_swing_knee": 0.083,
    "state1_swing_ankle": -0.1738, "state1_stance_knee": -0.0325, "state1_stance_ankle": 0.3215,
    "state1_cd": 0.5818, "state1_cv": 0.1379, "state1_cd_coronal": 0.4473,
    "state1_cv_coronal": 0.1926,
    "torso_pitch": 0.3718,
}

#: the natural gait at 1.0 m/s on the bundled humanoid (Froude 0.341): its slow speed anchor's
#: legs, lean, lift-off duration and velocity force (CMA-ES; docs/simbicon.md)
_NATURAL_1_0 = {
    "state0_swing_hip": 0.6799, "state0_swing_hip_coronal": -0.0698, "state0_swing_knee": 1.4801,
    "state0_swing_ankle": 0.9177, "state0_stance_knee": -0.0265, "state0_stance_ankle": 0.0874,
    "state0_cd": 0.5149, "state0_cv": 0.2328, "state0_cd_coronal": 0.5142,
    "state0_cv_coronal": 0.2456, "state1_swing_hip": 0.1557, "state1_swing_hip_coronal": -0.0698,
    "state1_swing_knee": 0.1236, "state1_swing_ankle": -0.1064, "state1_stance_knee": 0.0263,
    "state1_stance_ankle": 0.276, "state1_cd": 0.5149, "state1_cv": 0.2328,
    "state1_cd_coronal": 0.5142, "state1_cv_coronal": 0.2456, "torso_pitch": 0.3192,
    "state0_duration": 0.1951, "velocity_force": 0.1663,
}

#: the natural gait at 1.4 m/s on the bundled humanoid (Froude 0.477): its fast speed anchor's
#: legs, pelvis and spine pitch, state durations, contact phase and velocity force (CMA-ES,
#: docs/simbicon.md)
_NATURAL_1_4 = {
    "state0_swing_hip": 0.765, "state0_swing_hip_coronal": -0.1026, "state0_swing_knee": 1.4405,
    "state0_swing_ankle": 0.9549, "state0_stance_knee": -0.0351, "state0_stance_ankle": 0.2175,
    "state0_cd": 0.6391, "state0_cv": 0.1333, "state0_cd_coronal": 0.4473,
    "state0_cv_coronal": 0.2863, "state1_swing_hip": 0.1985, "state1_swing_hip_coronal": -0.1026,
    "state1_swing_knee": 0.1135, "state1_swing_ankle": -0.212, "state1_stance_knee": -0.0325,
    "state1_stance_ankle": 0.3707, "state1_cd": 0.6391, "state1_cv": 0.1333,
    "state1_cd_coronal": 0.4473, "state1_cv_coronal": 0.2863, "torso_pitch": 0.3954,
    "state0_duration": 0.2545, "state1_duration": 0.1694, "contact_phase": 0.5691,
    "velocity_force": 0.2689, "spine_pitch": -0.2344,
}

#: Natural walk: human-like gait statistics at 1.2 m/s (cadence, step length and
#: width, trunk lean, knee flexion; docs/simbicon.md). The walk's controller with Coros,
#: Beaudoin and van de Panne 2010's swing-leg gravity compensation (``swing_gravity``) and
#: velocity tuning (``velocity_force``), the pelvis pitched forward and the spine extended so
#: the trunk (pelvis to head) stands nearly upright; tuned on the bundled humanoid by CMA-ES
#: (21 numbers, cost = normalised violations of the gait bars + speed error + falls, 10 s
#: walks at 1.2 m/s), then, for forward pushes and the downhill walk (the robustness bars),
#: weaker sagittal feedback (cd 0.667 -> 0.58, cv 0.189 -> 0.14) with the swing hip raised by
#: what cv gave up at 1.2 m/s and a longer lift-off state (by hand, then a small CMA-ES on the
#: 20 s cadence with the pushes and the downhill walk as pass/fail; docs/simbicon.md), then, for
#: the bars from ``terrain.walk``'s seeded starts (``mjchar gait --seed``), a CMA-ES over the
#: lift-off duration, the swing state's swing hip, the coronal target and ``cv_coronal``, the
#: stance knees and the pelvis and spine pitch (more pelvis pitch, more spine extension: longer
#: steps at the same trunk lean; docs/simbicon.md, "Seeded starts"), then, for the stance-foot
#: slip, a stance ankle whose roll is soft (about a third of the ankle's gains) and whose twist
#: has no stiffness (damping only), and a swing foot levelled across its width before it lands (with
#: the ankle's full gains the stance foot stood on one heel corner and spun 20-35 deg about it
#: every step, and the whole body with it), followed by a CMA-ES over the gait's numbers on the
#: 20 s slip under the bars (docs/simbicon.md, "The stance foot"). Own speed
#: 1.2 m/s (Froude 0.409); a speed command regulates towards the command with ``speed_gain`` and
#: the virtual force, and interpolates speed anchors: walk's slow legs at Froude 0.22 (by hand),
#: anchors at 1.0 and 1.4 m/s (CMA-ES, for the bars and the slip there) and the legs before the
#: stance-foot retune at 1.6 m/s (docs/simbicon.md, "Anchors at 1.0 and 1.4 m/s").
NATURAL = Gait(
    name="natural",
    states=(
        StateParams(
            duration=0.2094,
            ends_on_contact=False,
            swing_hip=0.6142,
            swing_hip_coronal=-0.07,
            swing_knee=1.4296,
            swing_ankle=1.0054,
            stance_knee=-0.0351,
            stance_ankle=0.0537,
            cd=0.5386,
            cv=0.1568,
            cd_coronal=0.4473,
            cv_coronal=0.2296,
        ),
        StateParams(
            duration=0.1574,
            ends_on_contact=True,
            swing_hip=0.2169,
            swing_hip_coronal=-0.07,
            swing_knee=0.1436,
            swing_ankle=-0.2013,
            stance_knee=-0.0325,
            stance_ankle=0.3249,
            cd=0.5386,
            cv=0.1568,
            cd_coronal=0.4473,
            cv_coronal=0.2296,
        ),
    ),
    torso_pitch=0.3677,
    contact_phase=0.4386,
    spine_pitch=-0.2135,
    arm_swing=0.392,
    max_twist=0.21,
    speed_gain=0.011,
    swing_gravity=0.9763,
    velocity_force=0.1705,
    body_leg_length=BUNDLED_LEG_LENGTH,
    body_mass=BUNDLED_MASS,
    froude=0.409,
    speed_anchors=(
        # walk's legs at its slow anchor (WALK.for_speed(0.22): per-state targets and feedback,
        # lean 0.2), the natural gait's own state durations and velocity force: without it the
        # natural gait drifts sideways below ~1.1 m/s (0.75 m/s sideways at 0.6)
        (0.22, _legs_at(WALK, 0.22)),
        # 1.0 m/s: every key of its neighbours (the slow anchor's; narrower steps and less
        # stance-foot slip than their interpolation), tuned by CMA-ES over 12 numbers on 20 s
        # walks at 1.0 and 1.1 m/s (standing start, seed 1) for the gait bars and the slip
        (0.341, _NATURAL_1_0),
        # the gait's own values from Froude 0.40 to 0.41: 1.2 m/s on the bundled humanoid is
        # Froude 0.4089, just below 0.409, and walks exactly as the gait does without anchors
        (0.40, {}),
        (0.41, {}),
        # 1.4 m/s: every key of the fast anchor's, longer states and steps (a lower cadence),
        # more pelvis pitch and spine extension; CMA-ES over 15 numbers on 20 s walks at 1.4
        # (standing start, seed 1) and 1.3 m/s (standing start)
        (0.477, _NATURAL_1_4),
        # 1.6 m/s on the bundled humanoid: the legs and lean the gait had before its stance-foot
        # retune (its durations and gains stay): the retuned legs top out near 1.4 m/s, with
        # these a 1.6 m/s command walks 1.50 (docs/simbicon.md)
        (0.545, _NATURAL_FAST_LEGS),
    ),
    gains={
        "torso": (873.399, 87.34),
        "swing_hip": (260.881, 26.088),
        "ankle": (368.43, 36.843),
        "stance_twist": (600.0, 60.0),
        "stance_ankle_roll": (115.42, 11.542),
        "stance_ankle_twist": (0.0, 3.684),
        "swing_ankle_level": (299.08, 29.908),
    },
)

#: The gaits by name.
GAITS: dict[str, Gait] = {"walk": WALK, "crouch": CROUCH, "natural": NATURAL}


def get_gait(gait: str | Gait | dict, **overrides) -> Gait:
    """A :class:`Gait` from a name in :data:`GAITS`, a Gait, or a dict (:meth:`Gait.from_dict`),
    with ``overrides`` applied (:meth:`Gait.with_overrides`)."""
    if isinstance(gait, Gait):
        g = gait
    elif isinstance(gait, dict):
        g = Gait.from_dict(gait)
    elif isinstance(gait, str):
        if gait not in GAITS:
            raise GaitError(f"unknown gait {gait!r}; choose from {', '.join(GAITS)}")
        g = GAITS[gait]
    else:
        raise GaitError(f"a gait is a name, a Gait or a dict, got {type(gait).__name__}")
    return g.with_overrides(**overrides) if overrides else g
