"""Gait analysis of any walk in a converted model: a simulated run or a motion-capture clip.

Both come down to a ``qpos`` trajectory of a converted model (a run: what the simulation did; a
clip: :class:`mjchar.bvh.reference.reference_motion.ReferenceMotion`'s frames), so one probe
measures both the same way::

    stats = analyse(model, times, qpos, start=3.0)        # GaitStats
    stats.speed_mps, stats.cadence_spm, stats.step_length_m, stats.to_dict()
    stats = analyse_clip("walk60.bvh")                    # converts the clip, then the same

What is measured (world z up, metres, degrees; over ``[start, end]``):

- feet: per side, the points bounding the foot geoms from below
  (:mod:`mjchar.bvh.reference.foot_points`); the foot's height is their lowest, its floor the 5th
  percentile of that height over the window. A foot is in **stance** while its centre moves slower
  than :data:`STANCE_SPEED_FACTOR` x the walking speed + 0.1 m/s and it is within
  :data:`CONTACT_HEIGHT` of its floor (speed decides: mocap stance feet float centimetres above
  the placed floor); runs shorter than :data:`MIN_PHASE` are merged into their neighbours. A
  **foot strike** starts a stance.
- **step**: consecutive strikes of opposite feet. Step length: the distance between the two
  stance feet (mean foot-centre position over each stance) along the direction of travel
  (root displacement between the strikes); step width: across it. **Cadence**: steps per
  minute, 60 / mean time between consecutive opposite strikes.
- **stance fraction**: stance time / stride time per foot (complete strides); **double
  support**: fraction of the window with both feet in stance.
- **trunk lean**: angle of the pelvis-to-head vector from vertical (mean and range).
- **pelvis rotation**: the pelvis's transverse-plane (yaw) angle is the signed horizontal angle
  from the stride's direction of travel (root displacement from left strike to left strike) to
  the forward normal of the hip line (the horizontal part of left hip joint minus right hip
  joint, rotated by -90 deg about the vertical): joint positions only, no body's local axes.
  Its peak-to-peak range within each stride of the left foot (mean over strides).
- **knee flexion**: 180 deg minus the hip-knee-ankle angle; **hip flexion**: angle of the thigh
  (hip to knee) from the trunk's downward axis in the sagittal plane, + forward.
- **foot clearance**: highest rise of the foot above its floor in each swing (mean).
- **stance slip**: horizontal travel of the foot points touching the floor (within 1 cm) while
  they stay touching, summed over a stance (mean per step, m).
- **COM vertical excursion**: range of the centre-of-mass height within each stride (mean).
- **cycle curves**: knee and hip flexion (both sides), trunk lean and pelvis rotation (the
  angle above, against each stride's own direction of travel) over the normalised gait
  cycle (left strike to left strike, 0-100 %, mean and standard deviation over strides).
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field

import mujoco
import numpy as np

from mjchar.bvh.errors import MjcharError
from mjchar.bvh.reference.foot_points import FOOT_SIDES, _FootPoints

__all__ = ["GaitAnalysisError", "GaitStats", "analyse", "analyse_clip", "clip_walk", "table",
           "CONTACT_HEIGHT"]

#: a foot within this height (m) of its floor may be in stance (loose: mocap stance feet float
#: several centimetres above the placed floor, and by different amounts at strike and toe-off)
CONTACT_HEIGHT = 0.10
#: a stance foot's centre moves slower than this x walking speed (+ 0.1 m/s)
STANCE_SPEED_FACTOR = 0.3
#: shortest stance or swing phase kept, s
MIN_PHASE = 0.06
#: a foot point within this height (m) of the floor touches it (stance slip)
TOUCH_HEIGHT = 0.01
#: samples of the normalised gait cycle
CYCLE_SAMPLES = 101
_ROLES = ("pelvis", "head", "left_hip", "left_knee", "left_ankle", "right_hip", "right_knee",
          "right_ankle")


class GaitAnalysisError(MjcharError):
    """A walk cannot be analysed (too short, no steps, a model without the roles needed)."""


@dataclass
class GaitStats:
    """Gait statistics of one walk (see the module docstring for each definition)."""

    label: str
    duration_s: float
    speed_mps: float
    cadence_spm: float | None
    step_length_m: float | None
    step_width_m: float | None
    steps: int
    stance_fraction: float | None
    double_support_fraction: float | None
    trunk_lean_deg: float
    trunk_lean_range_deg: float
    pelvis_rotation_deg: float | None
    knee_flexion_deg: float
    hip_flexion_deg: float
    foot_clearance_m: float | None
    stance_slip_m: float | None
    com_excursion_m: float | None
    #: name -> (CYCLE_SAMPLES,) mean curve over the normalised gait cycle
    cycle_mean: dict = field(default_factory=dict, repr=False)
    #: name -> (CYCLE_SAMPLES,) standard deviation over strides
    cycle_std: dict = field(default_factory=dict, repr=False)
    strides: int = 0
    #: times (s) of the left foot's strikes in the window (its strides run between them)
    left_strikes: list = field(default_factory=list, repr=False)

    ROWS = (("speed_mps", "speed m/s", 2), ("cadence_spm", "cadence steps/min", 0),
            ("step_length_m", "step length m", 2), ("step_width_m", "step width m", 3),
            ("stance_fraction", "stance fraction", 2),
            ("double_support_fraction", "double support fraction", 2),
            ("trunk_lean_deg", "trunk lean deg", 1), ("trunk_lean_range_deg", "lean range deg", 1),
            ("pelvis_rotation_deg", "pelvis rotation deg", 1),
            ("knee_flexion_deg", "mean knee flexion deg", 1),
            ("hip_flexion_deg", "mean hip flexion deg", 1),
            ("foot_clearance_m", "foot clearance m", 3), ("stance_slip_m", "stance slip m/step", 4),
            ("com_excursion_m", "COM vertical excursion m", 3), ("steps", "steps", 0))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["cycle_mean"] = {k: [float(x) for x in v] for k, v in self.cycle_mean.items()}
        d["cycle_std"] = {k: [float(x) for x in v] for k, v in self.cycle_std.items()}
        return d


def table(stats: list[GaitStats]) -> str:
    """A markdown table: one row per statistic, one column per walk."""
    lines = ["| statistic | " + " | ".join(s.label for s in stats) + " |",
             "|---|" + "---|" * len(stats)]
    for key, name, digits in GaitStats.ROWS:
        cells = []
        for s in stats:
            v = getattr(s, key)
            cells.append("-" if v is None else f"{v:.{digits}f}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# -- the probe ------------------------------------------------------------------------------------
def _bodies(model: mujoco.MjModel, info) -> dict[str, int]:
    out = {}
    missing = []
    for role in _ROLES:
        joint = info.roles.get(role)
        if not isinstance(joint, str) or joint not in info.joints:
            missing.append(role)
            continue
        out[role] = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, info.joints[joint].body)
    if missing:
        raise GaitAnalysisError(f"gait analysis needs the roles {', '.join(missing)}, which the "
                                "model does not have")
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[(start, stop)]`` of the True runs of ``mask`` (stop exclusive)."""
    d = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def _debounce(mask: np.ndarray, n_min: int) -> np.ndarray:
    """Flip runs (either value) shorter than ``n_min`` samples, shortest first."""
    mask = mask.copy()
    for value in (False, True):
        for a, b in _runs(mask == value):
            if b - a < n_min and a > 0 and b < len(mask):
                mask[a:b] = not value
    return mask


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    c = np.sum(u * v, axis=-1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def _pelvis_yaw(hip_left: np.ndarray, hip_right: np.ndarray, travel: np.ndarray) -> np.ndarray:
    """Signed angle (deg, + counter-clockwise seen from above) from the horizontal direction
    ``travel (2,)`` to the hip line's forward normal, per sample of ``hip_left``, ``hip_right``
    ``(n, 3)`` (unwrapped, so a range is meaningful)."""
    lat = hip_left[:, :2] - hip_right[:, :2]
    fwd = np.stack([lat[:, 1], -lat[:, 0]], axis=1)          # the left vector rotated by -90 deg
    cross = travel[0] * fwd[:, 1] - travel[1] * fwd[:, 0]
    return np.degrees(np.unwrap(np.arctan2(cross, fwd @ travel)))


def _stride_yaws(hip_left: np.ndarray, hip_right: np.ndarray, root: np.ndarray,
                 strikes) -> dict[int, np.ndarray]:
    """The pelvis's yaw (deg, :func:`_pelvis_yaw`) over each stride between consecutive sample
    indices of ``strikes`` (both ends included), against the stride's root displacement
    (``root (n, 3)``), keyed by the stride's first index; a stride without horizontal travel is
    skipped."""
    out = {}
    for a0, a1 in zip(strikes, strikes[1:], strict=False):
        travel = root[a1, :2] - root[a0, :2]
        if np.linalg.norm(travel) >= 1e-6:
            out[a0] = _pelvis_yaw(hip_left[a0:a1 + 1], hip_right[a0:a1 + 1], travel)
    return out


def analyse(model: mujoco.MjModel, times, qpos, *, start: float = 0.0,
            end: float | None = None, info=None, label: str = "walk") -> GaitStats:
    """Gait statistics of the ``qpos (T, nq)`` trajectory at ``times (T,)`` over ``[start,
    end]`` (see the module docstring)."""
    if info is None:
        from mjchar.bvh.mjcf import ModelInfo

        info = ModelInfo.from_model(model)
    t, q = _window(times, qpos, start, end)
    bodies = _bodies(model, info)
    feet = _FootPoints(model, info)
    if any(s not in feet.sides for s in FOOT_SIDES):
        raise GaitAnalysisError("gait analysis needs both feet (ankle geoms or foot sites)")
    pos, com, pts = _sample(model, q, bodies, feet)
    n = len(t)
    root = pos["pelvis"]
    travel = root[-1, :2] - root[0, :2]
    duration = float(t[-1] - t[0])
    path = float(np.sum(np.linalg.norm(np.diff(root[:, :2], axis=0), axis=1)))
    speed = float(np.linalg.norm(travel) / duration)
    stance, floor, centre = _stance(pts, t, path, duration)
    # strikes (a stance that begins inside the window) and steps
    strikes = sorted((a, s) for s in FOOT_SIDES for a, b in _runs(stance[s]) if a > 0)
    lengths, widths, step_times = _steps(strikes, stance, centre, root, t)
    fractions, slips, clearances = _foot_phases(strikes, stance, pts, floor, n)
    both = stance["left"] & stance["right"]
    curves, lean, knees, hips = _angles(pos, root, t)
    left = [a for a, side in strikes if side == "left"]
    excursions, cycles, rotations = _left_strides(left, pos, com, root, t, curves)
    return GaitStats(
        label=label, duration_s=duration, speed_mps=speed,
        cadence_spm=60.0 / float(np.mean(step_times)) if step_times else None,
        step_length_m=_mean(lengths), step_width_m=_mean(widths), steps=len(lengths),
        stance_fraction=_mean(fractions),
        double_support_fraction=float(both.mean()) if lengths else None,
        trunk_lean_deg=float(lean.mean()), trunk_lean_range_deg=float(np.ptp(lean)),
        pelvis_rotation_deg=_mean(rotations),
        knee_flexion_deg=float(np.mean(knees)), hip_flexion_deg=float(np.mean(hips)),
        foot_clearance_m=_mean(clearances), stance_slip_m=_mean(slips),
        com_excursion_m=_mean(excursions),
        cycle_mean={k: np.mean(v, axis=0) for k, v in cycles.items() if v},
        cycle_std={k: np.std(v, axis=0) for k, v in cycles.items() if v},
        strides=len(excursions), left_strikes=[float(t[a]) for a in left])


def _mean(v) -> float | None:
    """The mean of ``v``, ``None`` when it is empty."""
    return float(np.mean(v)) if len(v) else None


def _window(times, qpos, start: float, end: float | None) -> tuple[np.ndarray, np.ndarray]:
    """``(t, q)``: the samples within ``[start, end]`` (at least 10 over 0.5 s)."""
    times = np.asarray(times, dtype=float)
    qpos = np.asarray(qpos, dtype=float)
    end = times[-1] if end is None else end
    sel = (times >= start - 1e-9) & (times <= end + 1e-9)
    t, q = times[sel], qpos[sel]
    if len(t) < 10 or t[-1] - t[0] < 0.5:
        raise GaitAnalysisError(f"the window [{start:g}, {end:g}] s holds {len(t)} samples; a gait "
                                "analysis needs at least 0.5 s")
    return t, q


def _sample(model: mujoco.MjModel, q: np.ndarray, bodies: dict[str, int],
            feet: _FootPoints) -> tuple[dict[str, np.ndarray], np.ndarray, dict[str, np.ndarray]]:
    """``(pos, com, pts)`` per sample of ``q``: the role bodies' positions ``(n, 3)``, the
    centre of mass ``(n, 3)`` and each foot's points ``(n, P, 3)``."""
    data = mujoco.MjData(model)
    n = len(q)
    pos = {r: np.empty((n, 3)) for r in bodies}
    com = np.empty((n, 3))
    pts = {s: [] for s in FOOT_SIDES}
    for k, qk in enumerate(q):
        data.qpos[:] = qk
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        for r, b in bodies.items():
            pos[r][k] = data.xpos[b]
        com[k] = data.subtree_com[0]
        for s in FOOT_SIDES:
            pts[s].append(feet.sample(data, feet.sides[s]))
    return pos, com, {s: np.array(v) for s, v in pts.items()}                    # (n, P, 3)


def _stance(pts: dict[str, np.ndarray], t: np.ndarray, path: float,
            duration: float) -> tuple[dict[str, np.ndarray], dict[str, float], dict]:
    """Per foot: ``(stance (n,) bool, floor height, centre (n, 3))``; a foot stands while it is
    slow (against the root's ``path`` length over ``duration``) and near its floor."""
    stance, floor, centre = {}, {}, {}
    n_min = max(1, int(round(MIN_PHASE / np.median(np.diff(t)))))
    for s in FOOT_SIDES:
        low = pts[s][..., 2].min(axis=1)
        floor[s] = float(np.percentile(low, 5))
        centre[s] = pts[s].mean(axis=1)
        v = np.linalg.norm(np.gradient(centre[s][:, :2], t, axis=0), axis=1)
        limit = STANCE_SPEED_FACTOR * path / duration + 0.1
        stance[s] = _debounce((low - floor[s] < CONTACT_HEIGHT) & (v < limit), n_min)
    return stance, floor, centre


def _steps(strikes: list, stance: dict, centre: dict, root: np.ndarray,
           t: np.ndarray) -> tuple[list[float], list[float], list[float]]:
    """``(lengths, widths, times)`` of the steps between strikes of opposite feet: the stance
    feet's distance along and across the root's travel, and the time between the strikes."""
    stance_pos = {}
    for s in FOOT_SIDES:
        for a, b in _runs(stance[s]):
            stance_pos[(a, s)] = centre[s][a:b, :2].mean(axis=0)
    lengths, widths, step_times = [], [], []
    for (a0, s0), (a1, s1) in zip(strikes, strikes[1:], strict=False):
        if s0 == s1:
            continue
        d = root[a1, :2] - root[a0, :2]
        if np.linalg.norm(d) < 1e-6:
            continue
        f = d / np.linalg.norm(d)
        step = stance_pos[(a1, s1)] - stance_pos[(a0, s0)]
        lengths.append(float(step @ f))
        widths.append(float(abs(step @ np.array([-f[1], f[0]]))))
        step_times.append(float(t[a1] - t[a0]))
    return lengths, widths, step_times


def _foot_phases(strikes: list, stance: dict, pts: dict, floor: dict,
                 n: int) -> tuple[list[float], list[float], list[float]]:
    """Per-foot strides: ``(stance fractions, stance slips, swing clearances)``."""
    fractions, slips, clearances = [], [], []
    for s in FOOT_SIDES:
        own = [a for a, side in strikes if side == s]
        for a0, a1 in zip(own, own[1:], strict=False):
            fractions.append(float(stance[s][a0:a1].mean()))
        for a, b in _runs(stance[s]):
            z = pts[s][a:b, :, 2] - floor[s]
            touch = (z[1:] < TOUCH_HEIGHT) & (z[:-1] < TOUCH_HEIGHT)
            moves = np.linalg.norm(np.diff(pts[s][a:b, :, :2], axis=0), axis=2)
            if b - a > 1:
                slips.append(float(np.sum(np.where(touch, moves, 0.0).sum(axis=1)
                                          / np.maximum(touch.sum(axis=1), 1))))
        for a, b in _runs(~stance[s]):
            if a > 0 and b < n:
                clearances.append(float((pts[s][a:b, :, 2].min(axis=1) - floor[s]).max()))
    return fractions, slips, clearances


def _angles(pos: dict[str, np.ndarray], root: np.ndarray,
            t: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray, list, list]:
    """``(curves, lean, knees, hips)``: trunk lean, and knee and hip flexion per side (deg per
    sample), the curves by name."""
    n = len(t)
    up = pos["head"] - pos["pelvis"]
    lean = _angle(up, np.array([0.0, 0.0, 1.0]))
    vel = np.gradient(root[:, :2], t, axis=0)
    fwd = np.zeros((n, 3))
    fwd[:, :2] = vel / np.maximum(np.linalg.norm(vel, axis=1, keepdims=True), 1e-9)
    curves = {"trunk_lean": lean}
    knees, hips = [], []
    u_hat = up / np.linalg.norm(up, axis=1, keepdims=True)
    f_perp = fwd - np.sum(fwd * u_hat, axis=1, keepdims=True) * u_hat
    f_perp /= np.maximum(np.linalg.norm(f_perp, axis=1, keepdims=True), 1e-9)
    for s in FOOT_SIDES:
        hip, knee, ankle = pos[f"{s}_hip"], pos[f"{s}_knee"], pos[f"{s}_ankle"]
        kf = 180.0 - _angle(hip - knee, ankle - knee)
        thigh = knee - hip
        hf = np.degrees(np.arctan2(np.sum(thigh * f_perp, axis=1), np.sum(thigh * -u_hat, axis=1)))
        curves[f"{s}_knee_flexion"], curves[f"{s}_hip_flexion"] = kf, hf
        knees.append(kf)
        hips.append(hf)
    return curves, lean, knees, hips


def _left_strides(left: list, pos: dict[str, np.ndarray], com: np.ndarray, root: np.ndarray,
                  t: np.ndarray, curves: dict[str, np.ndarray]) -> tuple[list, dict, list]:
    """Over the strides of the left foot (strike sample indices ``left``): ``(COM vertical
    excursions, cycle curves by name, pelvis rotation ranges)``."""
    excursions, cycles = [], {k: [] for k in [*curves, "pelvis_rotation"]}
    grid = np.linspace(0.0, 1.0, CYCLE_SAMPLES)
    yaws = _stride_yaws(pos["left_hip"], pos["right_hip"], root, left)
    for a0, a1 in zip(left, left[1:], strict=False):
        excursions.append(float(np.ptp(com[a0:a1 + 1, 2])))
        phase = (t[a0:a1 + 1] - t[a0]) / (t[a1] - t[a0])
        for k, c in curves.items():
            cycles[k].append(np.interp(grid, phase, c[a0:a1 + 1]))
        if a0 in yaws:
            cycles["pelvis_rotation"].append(np.interp(grid, phase, yaws[a0]))
    rotations = [float(np.ptp(y)) for y in yaws.values()]
    return excursions, cycles, rotations


def clip_walk(path: str | os.PathLike, *, model=None):
    """A BVH clip as a walk to analyse: ``(model, info, times, qpos)``, the clip converted
    (default options, or onto ``model``, an ``MjModel`` converted from the same skeleton) and
    read through :class:`~mjchar.bvh.reference.reference_motion.ReferenceMotion` (its default floor
    placement)."""
    from mjchar.bvh.io import load
    from mjchar.bvh.mjcf import ModelInfo, convert
    from mjchar.bvh.reference.reference_motion import ReferenceMotion

    motion = load(path)
    if model is None:
        model = mujoco.MjModel.from_xml_string(convert(motion).xml)
    info = ModelInfo.from_model(model)
    ref = ReferenceMotion(model, motion, info=info)
    return model, info, np.arange(ref.n_frames) * motion.frame_time, ref.frame_qpos


def analyse_clip(path: str | os.PathLike, *, model=None, start: float = 0.0,
                 end: float | None = None, label: str | None = None) -> GaitStats:
    """Gait statistics of a BVH clip (:func:`clip_walk`)."""
    model, info, times, qpos = clip_walk(path, model=model)
    name = label or os.path.splitext(os.path.basename(os.fspath(path)))[0]
    return analyse(model, times, qpos, start=start, end=end, info=info, label=name)
