"""Tracking a clip with PD targets: what SAMCON, CMA-ES and any sampling tracker share.

- Noise widths by joint role (:data:`ROLE_WIDTHS`, :func:`sampling_widths`) and each actuator's
  role (:func:`actuator_roles`).
- The rollout model that records joint positions (:func:`tracking_rollout_model`).
- Base PD targets from inverse dynamics on the reference (:func:`inverse_dynamics_targets`):
  ``q_hat = q + (tau_ID + kd qdot) / kp``.
- The tracking cost of Liu et al. 2010 plus two world-space terms (:class:`CostWeights`,
  :func:`reference_features`, :class:`TrackingCost`)::

      E = wp Ep + wr Er + we Ee + wb Eb + wc Ec + wj Ej

  with :data:`FALL_COST` added to a sample that falls (see :mod:`mjchar.controllers.sampling.samcon`
  for every term), or graded by how early it fell (:func:`fall_penalty`).
- A constant pose as a reference (:class:`PoseReference`), for standing and pushes.
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from mjchar.bvh.errors import MjcharError

from ..core.character import Character
from .rollout import RolloutModel, RolloutResult

__all__ = ["FALL_COST", "JOINT_SITE_PREFIX", "ROLE_WIDTHS", "CostWeights", "PoseReference",
           "ReferenceFeatures", "TrackingCost", "TrackingError", "actuator_roles",
           "fall_penalty", "inverse_dynamics_targets", "reference_features", "sampling_widths",
           "stance_labels", "tracking_rollout_model"]


class TrackingError(MjcharError):
    """Widths or cost weights that cannot be used (unknown role, negative number)."""


#: sampling half-widths (rad) per joint role (uniform: +-w; Gaussian: standard deviation w/2).
#: Narrower than the papers' (hips +-0.6-0.8, knees/ankles +-0.2-0.6, spine/arms <= 0.3): with
#: this model's stiff native PD (hips kp 600) and inverse-dynamics base targets, half of
#: (0.3, 0.25, 0.25, 0.15) gave the lowest tracking errors on walk60 (docs/sampling.md).
ROLE_WIDTHS = {
    "hip": 0.15, "knee": 0.125, "ankle": 0.125, "toe": 0.05, "spine": 0.075, "head": 0.05,
    "clavicle": 0.025, "shoulder": 0.075, "elbow": 0.075, "wrist": 0.025, "unknown": 0.05,
}
#: a sample that fell gets this cost (plus its own): never kept while any sample stands
FALL_COST = 1e6



# ------------------------------------------------------------------------------------------------
# model structure helpers


def _role_kind(role: str) -> str:
    """``left_hip`` -> ``hip``; ``spine`` -> ``spine``."""
    for side in ("left_", "right_"):
        if role.startswith(side):
            return role[len(side):]
    return role


def actuator_roles(character: Character) -> list[str]:
    """``(nu,)`` the role kind (``hip``, ``knee``, ``spine``, ...) of each actuator's joint."""
    joint_of_dof = {}
    for name, ji in character.info.joints.items():
        for d in character.joint_dofs(name):
            joint_of_dof[int(d)] = _role_kind(ji.role or "unknown")
    return [joint_of_dof.get(int(d), "unknown") for d in character.actuator_dof]


def sampling_widths(character: Character, widths: dict | None = None,
                    scale: float = 1.0) -> np.ndarray:
    """``(nu,)`` sampling half-widths (rad) per actuator.

    Args:
        widths: role kind -> width (rad), overriding :data:`ROLE_WIDTHS` entries (``hip``,
            ``knee``, ``ankle``, ``toe``, ``spine``, ``head``, ``clavicle``, ``shoulder``,
            ``elbow``, ``wrist``, ``unknown``).
        scale: factor on every width.
    """
    table = dict(ROLE_WIDTHS)
    for k, v in (widths or {}).items():
        if k not in ROLE_WIDTHS:
            raise TrackingError(f"unknown joint role {k!r} in widths; known: "
                              f"{', '.join(ROLE_WIDTHS)}")
        if not (math.isfinite(v) and v >= 0):
            raise TrackingError(f"width for {k!r} must be a non-negative number of radians")
        table[k] = float(v)
    if not (math.isfinite(scale) and scale >= 0):
        raise TrackingError(f"width scale must be non-negative, got {scale}")
    return np.array([table.get(r, table["unknown"]) for r in actuator_roles(character)]) * scale


JOINT_SITE_PREFIX = "mjchar_joint/"


def tracking_rollout_model(source, character: Character) -> RolloutModel:
    """A :class:`~mjchar.controllers.sampling.rollout.RolloutModel` of ``source`` that records the
    model's own sites (head, hands, feet, toes) and, through massless sites added at every BVH joint
    body's origin (named :data:`JOINT_SITE_PREFIX` + joint), the joint positions the tracking metric
    compares (``mjchar.controllers.core.metrics``). Sites change no physics."""
    from .rollout import RolloutError

    try:
        spec = mujoco.MjSpec.from_file(str(source))
    except (ValueError, TypeError) as e:
        raise RolloutError(f"cannot parse the model {source}: {e}") from e
    plain = [n for n in character.site_names if n]
    added = []
    for name in character.joint_names:
        body = spec.body(character.info.joints[name].body)
        if body is None:
            continue
        site_name = JOINT_SITE_PREFIX + name
        body.add_site(name=site_name, pos=[0.0, 0.0, 0.0], size=[0.005, 0.005, 0.005],
                      group=5)
        added.append(site_name)
    return RolloutModel.from_source(spec, sites=plain + added)


def clip_window(reference, start: float, duration: float | None, error: type[Exception]) -> float:
    """Seconds to track from ``start``: ``duration``, or to the clip's end when ``None``. A start
    past the end, or (for a clip that does not loop) a window past the end, raises ``error``
    naming the clip's length: past its end a non-cyclic reference holds its last frame, and a
    tracker would chase a figure frozen mid-stride."""
    end = reference.duration
    if start >= end:
        raise error(f"start {start:g} s is past the end of the clip ({end:.3f} s)")
    duration = (end - start) if duration is None else float(duration)
    if start + duration > end + 1e-6 and not getattr(reference, "cyclic", False):
        raise error(f"start {start:g} s + duration {duration:g} s goes past the end of the clip "
                    f"({end:.3f} s): a duration of at most {end - start:.3f} s")
    return duration


# ------------------------------------------------------------------------------------------------
# inverse dynamics targets


class PoseReference:
    """A constant pose ``qpos (nq,)`` at rest as a reference motion: what
    :func:`inverse_dynamics_targets` and :func:`reference_features` read (``qpos(t)``,
    ``qvel(t)`` zero, both feet in contact, ``frame_time``), e.g. for standing."""

    frame_time = 0.01
    cyclic = False

    def __init__(self, qpos: np.ndarray, nv: int):
        self.q = np.asarray(qpos, dtype=float).copy()
        self.nv = int(nv)

    def qpos(self, t) -> np.ndarray:
        return np.broadcast_to(self.q, np.shape(t) + self.q.shape).copy()

    def qvel(self, t) -> np.ndarray:
        return np.zeros(np.shape(t) + (self.nv,))

    def foot_contacts(self, t, height: float | None = None,
                      speed: float | None = None) -> np.ndarray:
        return np.ones(np.shape(t) + (2,), dtype=bool)


#: on a contact-floor reference (``floor="contact"``, where every supporting foot has been put
#: on the floor), a foot carries load when one of its points is within this fraction of the
#: clip's mean root height of the floor (2 cm for a 1 m root height). The contact floor's own
#: CONTACT_HEIGHT (12 %) is for raw mocap, whose stance feet float; on the grounded clip it
#: labels a swing foot descending 6-9 cm above the floor as a stance foot, and the inverse
#: dynamics hands it half the body's weight (docs/sampling.md, "Stance labels and the clip's
#: start").
GROUNDED_STANCE_HEIGHT = 0.02


def stance_labels(character: Character, reference, times: np.ndarray, *,
                  height: float | None = None) -> np.ndarray:
    """``(N, 2)`` bool: the feet (left, right) that carry the body at ``times``: a foot point
    lower than a fraction of the clip's mean root height and slower than
    :data:`~mjchar.bvh.reference.foot_points.CONTACT_SPEED` x ``sqrt(g x root height)``
    (Froude-scaled, so a 2 m figure walking at 1.6 m/s gets the labels a 1.6 m one gets at 1.2 m/s;
    fixed
    0.1 m / 0.5 m/s thresholds leave a tall rig without a stance foot in 13 % of its walk).
    The height fraction is :data:`GROUNDED_STANCE_HEIGHT` on a contact-floor reference, whose
    supporting feet are on the floor, and otherwise the contact floor's own
    :data:`~mjchar.bvh.reference.foot_points.CONTACT_HEIGHT`
    (:func:`mjchar.bvh.reference.foot_points.contact_grounding`), which allows for the floating feet
    of raw mocap. ``height`` (a fraction of the root height) overrides the choice."""
    from mjchar.bvh.reference.foot_points import CONTACT_HEIGHT, CONTACT_SPEED

    times = np.asarray(times, dtype=float).reshape(-1)
    clip_t = getattr(reference, "times", None)
    q = reference.qpos(times if clip_t is None else clip_t)
    h = max(float(np.mean(q[..., character.root_qpos[2]])), 1e-3)
    if height is not None:
        if not (isinstance(height, int | float) and math.isfinite(height) and height > 0):
            raise TrackingError(f"the stance height must be a positive fraction of the root "
                                f"height, not {height!r}")
        frac = float(height)
    elif getattr(reference, "floor", None) == "contact":
        frac = GROUNDED_STANCE_HEIGHT
    else:
        frac = CONTACT_HEIGHT
    labels = reference.foot_contacts(times, height=frac * h,
                                     speed=CONTACT_SPEED * math.sqrt(9.81 * h))
    return np.asarray(labels, dtype=bool).reshape(len(times), 2)


def _reference_acceleration(reference, times: np.ndarray, h: float) -> np.ndarray:
    """``(N, nv)`` generalised accelerations of ``reference`` at ``times`` by central differences
    of ``qvel`` with step ``h``, one-sided where a non-cyclic clip's start or end is closer than
    ``h`` (outside the clip, where it holds its first or last pose, zero): the reference's
    velocity is zero outside the clip, and differencing across the ends would read its
    forward speed as an acceleration of ``v / 2h`` (31.5 m/s^2 at walk60's first control)."""
    duration = getattr(reference, "duration", None)
    if getattr(reference, "cyclic", True) or duration is None:
        return (reference.qvel(times + h) - reference.qvel(times - h)) / (2 * h)
    lo = np.clip(times - h, 0.0, duration)
    hi = np.clip(times + h, 0.0, duration)
    span = hi - lo
    a = (reference.qvel(hi) - reference.qvel(lo)) / np.where(span > 0, span, 1.0)[:, None]
    a[span <= 0] = 0.0
    return a


def _without_root_wrench(m: mujoco.MjModel, d: mujoco.MjData, tau: np.ndarray,
                         stance: list[int], root, contact_weight: float, moment_weight: float,
                         jacp: np.ndarray, jacr: np.ndarray) -> np.ndarray:
    """``tau - J^T x``: the inverse-dynamics torques ``tau`` ``(nv,)`` with the root rows carried
    by wrenches ``x`` (force, moment) at the ``stance`` sole sites, ``A x = tau[root]`` (``A``:
    the root rows of the contact Jacobians' transpose), minimum norm with moments weighted
    ``moment_weight`` and forces ``contact_weight``; ``jacp``, ``jacr``: ``(3, nv)`` scratch."""
    cols = []
    for s in stance:
        mujoco.mj_jacSite(m, d, jacp, jacr, s)
        cols.append(np.vstack([jacp, jacr]).T)  # (nv, 6): generalised force of (f, m)
    J = np.hstack(cols)  # (nv, 6k)
    A = J[root]  # (6, 6k)
    wdiag = np.tile(np.r_[np.full(3, contact_weight), np.full(3, moment_weight)], len(stance))
    Winv = 1.0 / wdiag
    x = Winv * (A.T @ np.linalg.solve((A * Winv) @ A.T + 1e-9 * np.eye(6), tau[root]))
    return tau - J @ x


def inverse_dynamics_targets(character: Character, reference, times: np.ndarray, *,
                             smoothing: float = 0.03, contact_weight: float = 1.0,
                             moment_weight: float = 10.0, max_offset: float = 1.0,
                             fd_dt: float | None = None,
                             unlabelled: str = "lowest",
                             stance_height: float | None = None) -> np.ndarray:
    """PD targets that make the native actuators produce inverse-dynamics torques on the clip.

    For each time ``t``: ``q, qdot`` from the reference, ``qddot`` by central differences of
    ``qvel`` (step ``fd_dt``, default the clip's frame time; one-sided at the ends of a non-cyclic
    clip); ``mj_inverse`` (constraints off) gives ``tau`` ``(nv,)``. Its root rows ``w`` (6)
    must come from the ground: the stance feet
    (:func:`stance_labels`, body-scaled; when none is labelled, ``unlabelled`` decides) get
    wrenches ``x`` at their sole sites with ``A x = w`` (``A`` = root rows of the
    contact Jacobians' transpose), minimum norm with moments weighted ``moment_weight`` times
    more than forces. Then
    ``tau_act = tau - J^T x`` and, per actuator with gains ``kp, kd``::

        q_hat = q + (tau_act + kd qdot) / kp

    Offsets ``q_hat - q`` are clipped to ``+-max_offset`` rad and smoothed with a Gaussian of
    ``smoothing`` s standard deviation (0 turns it off).

    Args:
        character: the character (model, gains, sites ``left_foot``/``right_foot``).
        reference: a ``ReferenceMotion`` for ``character.model``.
        times: ``(N,)`` seconds, increasing and evenly spaced when ``smoothing`` > 0.
        unlabelled: the feet that carry the root wrench in a frame with no stance label (on
            the shared walks: heel strikes, the landing foot still fast, the trailing one on its
            toes): ``"lowest"``, the foot whose sole site is lowest (what keeps the open-loop
            reconstructions of tall or fast rigs standing), or ``"both"`` (what the closed-loop
            MPC tracks best with; docs/sampling.md, "Zoo rigs").
        stance_height: the stance labels' height fraction (:func:`stance_labels`; default:
            by the reference's floor).

    Returns:
        ``(N, nu)`` targets (rad) for the actuators.
    """
    from scipy.ndimage import gaussian_filter1d

    if unlabelled not in ("lowest", "both"):
        raise TrackingError(f"unlabelled must be 'lowest' or 'both', not {unlabelled!r}")
    # inverse dynamics of the reference, not of the simulated character: on a copy of the
    # model (constraints off) with data of its own, like the batched rollouts
    m = character.model
    times = np.asarray(times, dtype=float).reshape(-1)
    h = float(fd_dt if fd_dt is not None else getattr(reference, "frame_time", 0.01))
    q = reference.qpos(times)
    v = reference.qvel(times)
    a = _reference_acceleration(reference, times, h)
    contacts = stance_labels(character, reference, times, height=stance_height)
    mi = copy.deepcopy(m)
    mi.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    d = mujoco.MjData(mi)
    feet = [character.site_id("left_foot"), character.site_id("right_foot")]
    root = character.root_dofs
    kp, kd = character.actuation.default_gains()
    act = character.actuator_dof
    jacp = np.zeros((3, m.nv))
    jacr = np.zeros((3, m.nv))
    offsets = np.zeros((len(times), m.nu))
    for n in range(len(times)):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[n], v[n], a[n]
        mujoco.mj_inverse(mi, d)
        tau = d.qfrc_inverse.copy()
        stance = [s for s, c in zip(feet, contacts[n], strict=True) if c]
        if not stance:
            stance = feet if unlabelled == "both" else [min(feet, key=lambda s: d.site_xpos[s, 2])]
        tau_act = _without_root_wrench(mi, d, tau, stance, root, contact_weight,
                                       moment_weight, jacp, jacr)
        off = (tau_act[act] + kd[act] * v[n, act]) / np.where(kp[act] > 0, kp[act], 1.0)
        offsets[n] = np.clip(off, -max_offset, max_offset)
    if smoothing > 0 and len(times) > 1:
        step = float(np.mean(np.diff(times)))
        offsets = gaussian_filter1d(offsets, smoothing / step, axis=0, mode="nearest")
    return q[:, character.actuator_qpos] + offsets


# ------------------------------------------------------------------------------------------------
# cost


@dataclass
class CostWeights:
    """Weights of the SAMCON cost terms.

    ``pose``, ``root``, ``end_effector``, ``balance`` and ``velocity`` (the factor on every
    velocity sub-term) are Liu et al. 2010's (5, 3, 30, 10; 0.1). This project adds ``com``
    (per metre of world COM error predicted ``com_horizon`` s ahead, horizontal and vertical
    parts added) and ``joints`` (per metre of mean world joint position error, the quantity
    the tracking metric averages): without them the reconstruction drifts away from the clip's
    path, which the paper's relative terms do not see.
    """

    pose: float = 5.0
    root: float = 3.0
    end_effector: float = 30.0
    balance: float = 10.0
    com: float = 100.0
    joints: float = 100.0
    velocity: float = 0.1
    com_horizon: float = 0.3

    def __post_init__(self):
        for k, v in asdict(self).items():
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise TrackingError(f"cost weight {k} must be a non-negative number, got {v!r}")


@dataclass
class ReferenceFeatures:
    """What the cost compares with, at ``N`` times (one row per time).

    Attributes:
        times: ``(N,)`` s; qpos ``(N, nq)``; qvel ``(N, nv)``; com, com_vel ``(N, 3)`` (m, m/s);
        sites ``(N, S, 3)`` world positions of the rollout model's sites (m).
    """

    times: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    sites: np.ndarray


def reference_features(rmodel: RolloutModel, reference, times) -> ReferenceFeatures:
    """Sample ``reference`` at ``times`` (s) into :class:`ReferenceFeatures` using the rollout
    model's kinematics (sites in ``rmodel.site_names`` order, COM of ``rmodel.root_body``)."""
    m = rmodel.model
    times = np.asarray(times, dtype=float).reshape(-1)
    q, v = reference.qpos(times), reference.qvel(times)
    d = mujoco.MjData(m)
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, rmodel.root_body)
    sid = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, s) for s in rmodel.site_names]
    com, comv = np.zeros((len(times), 3)), np.zeros((len(times), 3))
    sites = np.zeros((len(times), len(sid), 3))
    for n in range(len(times)):
        d.qpos[:], d.qvel[:] = q[n], v[n]
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_subtreeVel(m, d)
        com[n] = d.subtree_com[root]
        comv[n] = d.subtree_linvel[root]
        sites[n] = d.site_xpos[sid]
    return ReferenceFeatures(times, q, v, com, comv, sites)


class TrackingCost:
    """The SAMCON cost of many simulated states against one reference row (vectorised).

    Args:
        character: for the model structure (joints, root, actuated qpos/dofs).
        weights: :class:`CostWeights`.
        fall_height: root height (m) below which a state counts as fallen.
        site_names: the rollout model's sites, in the order of the ``sites`` arrays: names
            starting with :data:`JOINT_SITE_PREFIX` are joint positions (the ``joints`` term),
            the others end effectors (the ``end_effector`` and ``balance`` terms). Default:
            the character's own sites.
    """

    def __init__(self, character: Character, weights: CostWeights | None = None,
                 fall_height: float | None = None, site_names=None):
        self.weights = weights or CostWeights()
        ch = character
        site_names = list(ch.site_names if site_names is None else site_names)
        self._ee = np.array([i for i, n in enumerate(site_names)
                             if not n.startswith(JOINT_SITE_PREFIX)], dtype=int)
        self._joints = np.array([i for i, n in enumerate(site_names)
                                 if n.startswith(JOINT_SITE_PREFIX)], dtype=int)
        groups_q, groups_v = [], []
        for name in ch.joint_names:
            dofs = ch.joint_dofs(name)
            if len(dofs) == 0 or np.any(np.isin(dofs, ch.root_dofs)):
                continue
            groups_q.append(ch.joint_qpos(name))
            groups_v.append(dofs)
        self._q_idx = np.concatenate(groups_q)
        self._v_idx = np.concatenate(groups_v)
        member = np.zeros((len(self._q_idx), len(groups_q)))
        k = 0
        for j, g in enumerate(groups_q):
            member[k:k + len(g), j] = 1.0
            k += len(g)
        self._member = member
        rq = ch.root_qpos
        self._root_pos = rq[:3]
        self._root_quat = rq[3:7]
        self._root_angvel = ch.root_dofs[3:6]
        if fall_height is None:
            from ..core.metrics import FALL_HEIGHT_FRACTION

            standing = ch.poses.standing()[rq[2]]
            fall_height = FALL_HEIGHT_FRACTION * float(standing)
        self.fall_height = float(fall_height)

    @property
    def root_height_index(self) -> int:
        """qpos index of the root height."""
        return int(self._root_pos[2])

    def terms(self, qpos: np.ndarray, qvel: np.ndarray, com: np.ndarray, com_vel: np.ndarray,
              sites: np.ndarray, ref: ReferenceFeatures, i: int) -> dict[str, np.ndarray]:
        """Unweighted terms ``(B,)`` each (``pose``, ``root``, ``end_effector``, ``balance``,
        ``com``) of states ``qpos (B, nq)``, ``qvel (B, nv)``, ``com, com_vel (B, 3)``,
        ``sites (B, S, 3)`` against row ``i`` of ``ref``; velocity sub-terms included."""
        v = self.weights.velocity
        dq = qpos[:, self._q_idx] - ref.qpos[i, self._q_idx]
        dv = qvel[:, self._v_idx] - ref.qvel[i, self._v_idx]
        pose = (np.sqrt((dq * dq) @ self._member).sum(axis=1)
                + v * np.sqrt((dv * dv) @ self._member).sum(axis=1))
        dot = np.abs(qpos[:, self._root_quat] @ ref.qpos[i, self._root_quat])
        ang = 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))
        root = ang + v * np.linalg.norm(qvel[:, self._root_angvel]
                                        - ref.qvel[i, self._root_angvel], axis=1)
        ee_s, ee_r = sites[:, self._ee], ref.sites[i, self._ee]
        ee = np.abs(ee_s[..., 2] - ee_r[:, 2]).sum(axis=1)
        cz = np.maximum(com[:, 2:3], 1e-3)
        rz = max(ref.com[i, 2], 1e-3)
        r = (com[:, None, :2] - ee_s[..., :2]) / cz[:, None]
        rbar = (ref.com[i, None, :2] - ee_r[:, :2]) / rz
        bal = (np.linalg.norm(r - rbar, axis=2).sum(axis=1)
               + v * np.linalg.norm(com_vel - ref.com_vel[i], axis=1))
        h = self.weights.com_horizon
        dc = com - ref.com[i] + h * (com_vel - ref.com_vel[i])
        comt = np.linalg.norm(dc[:, :2], axis=1) + np.abs(dc[:, 2])
        if len(self._joints):
            dj = sites[:, self._joints] - ref.sites[i, self._joints]
            joints = np.linalg.norm(dj, axis=2).mean(axis=1)
        else:
            joints = np.zeros(len(qpos))
        return {"pose": pose, "root": root, "end_effector": ee, "balance": bal, "com": comt,
                "joints": joints}

    def __call__(self, qpos, qvel, com, com_vel, sites, ref: ReferenceFeatures,
                 i: int) -> np.ndarray:
        """``(B,)`` weighted cost (see :meth:`terms`); NaN states cost ``inf``."""
        t = self.terms(qpos, qvel, com, com_vel, sites, ref, i)
        w = self.weights
        c = (w.pose * t["pose"] + w.root * t["root"] + w.end_effector * t["end_effector"]
             + w.balance * t["balance"] + w.com * t["com"] + w.joints * t["joints"])
        return np.where(np.isfinite(c), c, np.inf)

    def joint_error(self, sites: np.ndarray, ref: ReferenceFeatures,
                    rows: np.ndarray) -> np.ndarray:
        """``(B,)`` mean world joint position error (m, the tracking metric's quantity) of whole
        rollouts ``sites (B, T, S, 3)`` against rows ``rows (T,)`` of ``ref``, averaged over
        time (NaN states: ``inf``); zeros when the sites name no joint."""
        if not len(self._joints):
            return np.zeros(len(sites))
        rows = np.asarray(rows, dtype=int)
        dj = sites[:, :, self._joints] - ref.sites[rows][:, self._joints]
        e = np.linalg.norm(dj, axis=-1).mean(axis=(1, 2))
        return np.where(np.isfinite(e), e, np.inf)

    def over_time(self, qpos: np.ndarray, qvel: np.ndarray, com: np.ndarray,
                  com_vel: np.ndarray, sites: np.ndarray, ref: ReferenceFeatures,
                  rows: np.ndarray, *, joint_error: bool = False):
        """``(B, T)`` weighted cost of whole rollouts in one vectorised pass: state ``t`` of
        every sample (``qpos (B, T, nq)``, ``qvel (B, T, nv)``, ``com, com_vel (B, T, 3)``,
        ``sites (B, T, S, 3)``, e.g. a :class:`RolloutResult`'s) against row ``rows[t]`` of
        ``ref``; the same numbers as :meth:`__call__` per control (to rounding), about twenty
        times cheaper for a horizon of 35 controls. NaN states cost ``inf``. With
        ``joint_error``: ``(costs, (B,) mean joint errors)``, the second what
        :meth:`joint_error` returns (to rounding), from the same pass."""
        w = self.weights
        v = w.velocity
        rows = np.asarray(rows, dtype=int)
        rq, rv = ref.qpos[rows], ref.qvel[rows]  # (T, nq), (T, nv)
        dq = qpos[..., self._q_idx] - rq[:, self._q_idx]
        dv = qvel[..., self._v_idx] - rv[:, self._v_idx]
        pose = (np.sqrt((dq * dq) @ self._member).sum(axis=-1)
                + v * np.sqrt((dv * dv) @ self._member).sum(axis=-1))
        dot = np.abs(np.einsum("btq,tq->bt", qpos[..., self._root_quat],
                               rq[:, self._root_quat]))
        ang = 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))
        root = ang + v * np.linalg.norm(qvel[..., self._root_angvel]
                                        - rv[:, self._root_angvel], axis=-1)
        rsites, rcom, rcomv = ref.sites[rows], ref.com[rows], ref.com_vel[rows]
        ee_s, ee_r = sites[:, :, self._ee], rsites[:, self._ee]  # (B, T, E, 3), (T, E, 3)
        ee = np.abs(ee_s[..., 2] - ee_r[..., 2]).sum(axis=-1)
        cz = np.maximum(com[..., 2:3], 1e-3)  # (B, T, 1)
        rz = np.maximum(rcom[:, 2:3], 1e-3)  # (T, 1)
        r = (com[:, :, None, :2] - ee_s[..., :2]) / cz[..., None]
        rbar = (rcom[:, None, :2] - ee_r[..., :2]) / rz[..., None]
        bal = (np.linalg.norm(r - rbar, axis=-1).sum(axis=-1)
               + v * np.linalg.norm(com_vel - rcomv, axis=-1))
        dc = com - rcom + w.com_horizon * (com_vel - rcomv)
        comt = np.linalg.norm(dc[..., :2], axis=-1) + np.abs(dc[..., 2])
        if len(self._joints):
            dj = sites[:, :, self._joints] - rsites[:, self._joints]
            joints = np.linalg.norm(dj, axis=-1).mean(axis=-1)
        else:
            joints = np.zeros(qpos.shape[:2])
        c = (w.pose * pose + w.root * root + w.end_effector * ee + w.balance * bal
             + w.com * comt + w.joints * joints)
        c = np.where(np.isfinite(c), c, np.inf)
        if not joint_error:
            return c
        e = joints.mean(axis=1)
        return c, np.where(np.isfinite(e), e, np.inf)

    def fallen(self, result: RolloutResult, upto: int | None = None) -> np.ndarray:
        """``(B,)`` bool: non-foot floor contact, divergence, or root below the fall height at
        any control end of ``result`` (up to control index ``upto`` exclusive)."""
        sl = slice(None, upto)
        z = result.qpos[:, sl, self._root_pos[2]]
        low = ~(z >= self.fall_height)  # NaN counts as fallen
        return result.non_foot_contact[:, sl].any(axis=1) | low.any(axis=1) | ~result.ok


def fall_penalty(cost: TrackingCost, res: RolloutResult) -> np.ndarray:
    """``(B,)`` :data:`FALL_COST` x (1 - fraction of the rollout survived), 0 for no fall: a
    graded penalty, so that an optimiser still sees which falling candidate lasted longer.
    A fall is what :meth:`TrackingCost.fallen` detects, at the control end it first shows."""
    n = res.qpos.shape[1]
    z = res.qpos[:, :, cost.root_height_index]
    bad = res.non_foot_contact | ~(z >= cost.fall_height)
    first = np.where(bad.any(axis=1), bad.argmax(axis=1), n)
    first = np.where(res.ok, first, np.minimum(first, res.failed_step // res.steps_per_control))
    return FALL_COST * (1.0 - first / n) * (first < n)
