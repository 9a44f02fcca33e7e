"""Metrics shared by every scenario: falls, the :class:`Result` record and what it aggregates.

Every number the project reports about a controller is measured here, the same way for tests,
the CLI, the benchmarks and the environments:

- **fall**: the root (pelvis) drops below ``fall_height`` (default 0.55 x the standing root
  height), or a body other than the feet (ankle and toe bodies) touches the floor. A diverging
  simulation also counts as a fall (and sets ``diverged``).
- **tracking error**: mean over time and over the BVH joints of the distance between the
  simulated joint (body origin) and the same joint in the reference *as projected into the
  model* (the model's kinematics of the reference qpos), in m; the **root error** is the same for
  the root body alone.
- **root force / torque**: the root-help check (:mod:`.root_help`): per control step the largest
  force (N) and torque (N m) the character got from outside its joint actuators and the run did
  not declare as a push: the hand of god's root wrench, ``qfrc_applied``, actuator and gravity
  compensation forces on the root's dofs, ``xfrc_applied`` on any body beyond the scheduled
  pushes; averaged and maximised over the run. Both maxima are exactly zero for a controller
  that stands on its own feet (:meth:`Result.unaided`).
- **distance / speed**: horizontal displacement of the root from start to end (or to the fall),
  and that over the simulated time.
- **foot travel**: largest horizontal displacement of either foot sole site from where it
  started (a step or a slide when above a few centimetres).
- **COM drop**: how far the centre of mass went below its starting height (a squat, a fall).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from .character import Character
from .root_help import RootHelp

#: fraction of the standing root height below which the character has fallen
FALL_HEIGHT_FRACTION = 0.55
#: horizontal foot displacement (m) that counts as taking a step (or sliding a foot away)
STEP_DISTANCE = 0.05


@dataclass
class Result:
    """The outcome of one scenario run (JSON-ready through :meth:`to_dict`).

    Times in s, distances in m, speeds in m/s, forces in N. ``None`` where a metric does not
    apply (no reference, no push).
    """

    controller: str
    scenario: str
    fell: bool
    fall_time_s: float | None
    sim_time_s: float
    distance_m: float
    mean_speed_mps: float
    tracking_error_m: float | None
    root_error_m: float | None
    root_force_mean_N: float
    root_force_max_N: float
    root_torque_mean_Nm: float
    max_push_N: float | None
    wall_s: float
    steps_per_s: float
    timestep_s: float
    control_dt_s: float
    n_steps: int
    seed: int | None = None
    diverged: bool = False
    fall_reason: str | None = None
    foot_travel_m: float = 0.0
    stepped: bool = False
    com_drop_m: float = 0.0
    push_N: float | None = None
    push_direction_deg: float | None = None
    max_push_by_direction_N: dict | None = None
    root_torque_max_Nm: float = 0.0
    extra: dict = field(default_factory=dict)

    @property
    def unaided(self) -> bool:
        """No force and no torque from outside in any step, beyond the declared pushes (the
        root-help check: the claim "no root force")."""
        return self.root_force_max_N == 0.0 and self.root_torque_max_Nm == 0.0

    def to_dict(self) -> dict:
        """A JSON-serialisable dict (non-finite floats become ``None``)."""

        def clean(v):
            if isinstance(v, float | np.floating):
                v = float(v)
                return v if math.isfinite(v) else None
            if isinstance(v, np.integer):
                return int(v)
            if isinstance(v, np.bool_):
                return bool(v)
            if isinstance(v, dict):
                return {str(k): clean(x) for k, x in v.items()}
            if isinstance(v, list | tuple | np.ndarray):
                return [clean(x) for x in v]
            return v

        return {k: clean(v) for k, v in asdict(self).items()}

    def summary(self) -> str:
        """A few readable lines."""
        lines = [f"{self.controller} / {self.scenario}: "
                 + (f"FELL at {self.fall_time_s:.2f} s ({self.fall_reason})" if self.fell
                    else f"no fall in {_seconds(self.sim_time_s)} s")]
        if self.diverged:
            lines.append("  simulation diverged")
        lines.append(f"  distance {self.distance_m:.3f} m, mean speed "
                     f"{self.mean_speed_mps:.3f} m/s, foot travel {self.foot_travel_m:.3f} m, "
                     f"COM drop {self.com_drop_m:.3f} m")
        if self.tracking_error_m is not None:
            lines.append(f"  tracking error {self.tracking_error_m:.4f} m (mean joint), root error "
                         f"{self.root_error_m:.4f} m")
        if self.extra.get("tracking_error_raw_m") is not None:
            lines.append(f"  against the raw clip: tracking error "
                         f"{self.extra['tracking_error_raw_m']:.4f} m, root error "
                         f"{self.extra['root_error_raw_m']:.4f} m "
                         f"({self.extra.get('conditioning', 'conditioned')})")
        lines.append(f"  root force mean {self.root_force_mean_N:.1f} N (max "
                     f"{self.root_force_max_N:.1f} N), root torque mean "
                     f"{self.root_torque_mean_Nm:.1f} N m (max {self.root_torque_max_Nm:.1f} N m)")
        if self.push_N is not None:
            where = ("random directions" if self.push_direction_deg is None
                     else f"towards {self.push_direction_deg:g} deg")
            lines.append(f"  push {self.push_N:.1f} N, {where}")
        if self.max_push_by_direction_N:
            per = ", ".join(f"{k} {v:.0f} N" for k, v in self.max_push_by_direction_N.items())
            lines.append(f"  largest survived push (0.2 s, pelvis): {per}")
        elif self.max_push_N is not None:
            lines.append(f"  largest push survived {self.max_push_N:.1f} N")
        lines.append(f"  {self.n_steps} steps of {self.timestep_s * 1000:.3g} ms in "
                     f"{self.wall_s:.2f} s wall ({self.steps_per_s:.0f} steps/s)")
        for k, v in self.extra.items():
            if k not in RAW_CLIP_KEYS:  # said above
                lines.append(f"  {k}: {readable(k, v)}")
        return "\n".join(lines)


def _seconds(t: float) -> str:
    """A time to the millisecond, without trailing zeros (``10``, ``3.02``)."""
    return f"{t:.3f}".rstrip("0").rstrip(".")


#: digits after the point a value needs, by the unit its name ends with
_DECIMALS = {"_m": 3, "_mm": 1, "_s": 2, "_mps": 3, "_N": 1, "_Nm": 1, "_deg": 1, "_rad": 3,
             "_kg": 2, "_hz": 1, "_spm": 1}


def readable(name: str, value):
    """``value`` rounded to what its unit needs (by the suffix of ``name``: metres to the
    millimetre, seconds to the hundredth...; other floats to 4 significant digits), for the
    human-readable summary (``to_dict`` keeps every digit)."""
    if isinstance(value, bool) or not isinstance(value, float | np.floating):
        if isinstance(value, dict):
            return {k: readable(k if isinstance(k, str) else name, v) for k, v in value.items()}
        if isinstance(value, list | tuple):
            return type(value)(readable(name, v) for v in value)
        return value
    value = float(value)
    if not math.isfinite(value):
        return value
    for suffix, digits in _DECIMALS.items():
        if name.endswith(suffix):
            return round(value, digits)
    return float(f"{value:.4g}")


#: ``Result.extra`` keys of a run on a conditioned clip (its error against the raw clip)
RAW_CLIP_KEYS = ("tracking_error_raw_m", "root_error_raw_m", "conditioning")


class FallDetector:
    """Decides whether the character has fallen.

    Args:
        character: the character (its current pose gives the standing root height unless
            ``fall_height`` is given).
        fall_height: root height (m) below which it has fallen (default
            :data:`FALL_HEIGHT_FRACTION` x the standing root height of the model's rest pose).
    """

    def __init__(self, character: Character, fall_height: float | None = None):
        if fall_height is None:
            standing = character.poses.standing()[character.root_qpos[2]]
            fall_height = FALL_HEIGHT_FRACTION * float(standing)
        self.fall_height = float(fall_height)

    def check(self, character: Character) -> str | None:
        """``None`` while standing, else the reason of the fall."""
        h = character.state.root_height
        if h < self.fall_height:
            return f"root height {h:.3f} m below {self.fall_height:.3f} m"
        if character.contacts.any_non_foot():
            bodies = character.contacts.non_foot()
            if bodies:
                return f"{', '.join(bodies)} touched the ground"
        return None


class Recorder:
    """Collects what a run's :class:`Result` needs, one :meth:`record` per control step.

    Joint and root positions are sampled at most ``sample_rate`` times per second (tracking
    errors are computed against the reference once, at the end); without a reference there are
    no tracking errors, and ``joint_positions`` stays empty.
    """

    def __init__(self, character: Character, reference=None, sample_rate: float = 120.0):
        self.reference = reference
        self.sample_dt = 1.0 / sample_rate
        self._next_sample = 0.0
        self.times: list[float] = []
        self.joint_positions: list[np.ndarray] = []
        self.root_force: list[float] = []
        self.root_torque: list[float] = []
        self.start_root = character.state.root_position
        self.root = self.start_root.copy()
        self.start_feet = self._feet_xy(character)
        self._feet = (character.site_id("left_foot"), character.site_id("right_foot"))
        self.foot_travel = 0.0
        self.start_com_z = float(character.state.com()[2])
        self.help = RootHelp(character)
        self.com_min_z = self.start_com_z
        self._sample(character)

    @staticmethod
    def _feet_xy(character: Character) -> np.ndarray:
        """``(2, 2)`` horizontal positions (m) of the left and right sole sites."""
        left, right = character.contacts.foot_sites()
        return np.array([left[:2], right[:2]])

    def _sample(self, character: Character) -> None:
        self.times.append(character.time)
        if self.reference is not None:
            self.joint_positions.append(character.state.joint_positions())
        self._next_sample = character.time + self.sample_dt - 1e-9

    def record(self, character: Character) -> None:
        """Record the step just taken (the outside help it got, positions when due)."""
        force, torque = self.help.measure()
        self.root_force.append(force)
        self.root_torque.append(torque)
        self.root = character.state.root_position
        if character.time >= self._next_sample:
            self._sample(character)
            sites, (left, right) = character.state.site_positions, self._feet
            (lx, ly), (rx, ry) = sites[left, :2].tolist(), sites[right, :2].tolist()
            (sx, sy), (tx, ty) = self.start_feet.tolist()
            # the largest of the two feet's horizontal displacements (on Python floats: the
            # same operations as np.linalg.norm(feet - start_feet, axis=1).max())
            lx, ly, rx, ry = lx - sx, ly - sy, rx - tx, ry - ty
            travel = max(math.sqrt(lx * lx + ly * ly), math.sqrt(rx * rx + ry * ry))
            self.foot_travel = max(self.foot_travel, travel)
            self.com_min_z = min(self.com_min_z,
                                 float(character.state.subtree_coms[character.root_body, 2]))

    def tracking_errors(self, joint_body_index: int = 0,
                        reference=None) -> tuple[float | None, float | None]:
        """``(mean joint error, mean root error)`` in m against the reference (``None`` without).

        The reference joints are the model's kinematics of the reference qpos
        (``ReferenceMotion.body_positions``), in the Character's joint order. ``reference``:
        another reference on the same model to measure against (the raw clip of a conditioned
        one); default the run's.
        """
        reference = self.reference if reference is None else reference
        if reference is None or not self.times:
            return None, None
        t = np.asarray(self.times)
        ref = reference.body_positions(t)[:, reference.joint_body_ids]
        sim = np.asarray(self.joint_positions)
        err = np.linalg.norm(sim - ref, axis=-1)  # (T, J)
        return float(err.mean()), float(err[:, joint_body_index].mean())

    def aggregates(self) -> dict:
        """Distance (m), root force/torque statistics, foot travel and COM drop."""
        d = float(np.linalg.norm((self.root - self.start_root)[:2]))
        rf = np.asarray(self.root_force) if self.root_force else np.zeros(1)
        rt = np.asarray(self.root_torque) if self.root_torque else np.zeros(1)
        return {"distance_m": d, "root_force_mean_N": float(rf.mean()),
                "root_force_max_N": float(rf.max()), "root_torque_mean_Nm": float(rt.mean()),
                "root_torque_max_Nm": float(rt.max()),
                "foot_travel_m": self.foot_travel,
                "com_drop_m": self.start_com_z - self.com_min_z}
