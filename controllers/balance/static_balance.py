"""Static balance with a Jacobian-transpose virtual force on the centre of mass (GAMES-105 lab 3).

A PD controller holds a standing pose; on top, a virtual force on the centre of mass ``c``::

    f = kp (c_bar - c) - kd c_dot

pulls it towards a target ``c_bar`` over the support polygon (horizontally the middle of the two
foot soles, vertically the standing COM height plus an offset that can be lowered to squat). The
stance legs realise it: for a point force ``f`` at ``x = c`` carried by a leg whose foot is fixed
on the ground, each joint ``i`` (at ``p_i``, axis ``a_i``) of that leg applies
``tau_i = a_i . ((p_i - x) x f)``, which is ``tau = -J_x^T f`` with ``J_x`` the Jacobian of the
point ``x`` attached to the foot body (MuJoCo's tree is rooted at the pelvis, so the sign is the
reverse of a foot-rooted chain's ``J^T f``). Only the hip, knee and ankle dofs of legs in contact
take part (not the toes); two stance legs share ``f`` equally.

Squatting: lowering ``c_bar`` by ``dz`` also moves the PD pose to the leg pose (damped
least-squares IK on hips, knees and ankles) that lowers the pelvis by ``dz`` with the feet where
they are, so the PD does not fight the virtual force.

No force is ever applied to the root: the character stands on its own feet.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.base import Action, ControllerError
from ..core.character import Character
from ..core.geometry import smoothstep
from ..core.pd import StablePDController
from ..core.registry import ControllerSpec, register


def squat_profile(depth: float = 0.2, start: float = 1.0, down: float = 1.5, hold: float = 1.0,
                  up: float = 1.5) -> Callable[[float], float]:
    """A COM height offset ``t -> dz`` (m): 0 until ``start``, smoothly down to ``-depth`` over
    ``down`` s, held ``hold`` s, back to 0 over ``up`` s (smoothstep ramps)."""

    def dz(t: float) -> float:
        if t < start:
            return 0.0
        if t < start + down:
            return -depth * smoothstep((t - start) / down)
        if t < start + down + hold:
            return -depth
        return -depth * (1 - smoothstep((t - start - down - hold) / up))

    dz.duration = start + down + hold + up  # type: ignore[attr-defined]
    return dz


#: default virtual-force stiffness per kilogram of the character (s^-2; x, y, z): a COM
#: natural frequency of 2.9 rad/s horizontally, 2.1 rad/s vertically (600/300 N/m at 70 kg)
COM_KP_PER_KG = np.array([600.0, 600.0, 300.0]) / 70.0
#: default virtual-force damping per kilogram (s^-1; x, y, z)
COM_KD_PER_KG = np.array([120.0, 120.0, 60.0]) / 70.0


class StaticBalance:
    """PD on a pose + Jacobian-transpose virtual COM force on the stance legs.

    Args:
        pose: ``(nq,)`` pose to hold (``None``: the pose at reset).
        pd: the PD controller to use (default: stable PD); its target is set to ``pose``.
        kp, kd: virtual-force gains, scalars or ``(3,)`` per world axis (N/m, N s/m); ``None``
            (default): :data:`COM_KP_PER_KG` and :data:`COM_KD_PER_KG` times the character's
            mass, so every body gets the same COM dynamics.
        height: COM height offset in m (a number, or a callable ``t -> dz`` such as
            :func:`squat_profile`); negative squats.
        offset: ``(2,)`` horizontal offset (m, world) of the COM target from the support centre.
        squat_ik: move the PD pose with the height offset (see the module docstring).
    """

    name = "static_balance"

    def __init__(self, pose: np.ndarray | None = None, *, pd=None, kp=None, kd=None,
                 height: float | Callable[[float], float] = 0.0,
                 offset=(0.0, 0.0), squat_ik: bool = True):
        self.pose = None if pose is None else np.array(pose, dtype=float)
        self.pd = pd if pd is not None else StablePDController()
        self._gains = (kp, kd)
        self.kp = self.kd = None
        for g in (kp, kd):
            v = np.asarray(0.0 if g is None else g, dtype=float)
            if not (np.all(np.isfinite(v)) and np.all(v >= 0)):
                raise ControllerError("static balance: kp and kd must be non-negative numbers")
        self.height = height
        self.offset = np.asarray(offset, dtype=float).reshape(2)
        self.squat_ik = squat_ik
        self.last_force = np.zeros(3)
        self.com_target = np.zeros(3)

    @property
    def actuation(self) -> str:
        """The PD controller's actuation mode."""
        return self.pd.actuation

    def reset(self, character: Character) -> None:
        """Bind the pose, reset the PD, and take the support centre and COM height from now."""
        pose = character.state.qpos.copy() if self.pose is None else self.pose
        self._base_pose = pose
        kp, kd = self._gains
        mass = character.dynamics.mass
        self.kp = np.broadcast_to(np.asarray(
            COM_KP_PER_KG * mass if kp is None else kp, dtype=float), (3,)).copy()
        self.kd = np.broadcast_to(np.asarray(
            COM_KD_PER_KG * mass if kd is None else kd, dtype=float), (3,)).copy()
        self.pd.reset(character)
        self.pd.set_target(pose, character)
        self._legs = []
        for side in ("left", "right"):
            joints = [character.role(f"{side}_{p}") for p in ("hip", "knee", "ankle")]
            self._legs.append((character.dofs(joints), character.body_id(joints[-1])))
        self._leg_dofs = np.concatenate([d for d, _ in self._legs])
        self._leg_mask = np.zeros((2, character.nv))
        for i, (dofs, _) in enumerate(self._legs):
            self._leg_mask[i, dofs] = 1.0
        self._jac = (np.zeros((3, character.nv)), np.zeros((3, character.nv)))
        self._leg_qpos = np.concatenate([character.joint_qpos(character.role(f"{s}_{p}"))
                                         for s in ("left", "right")
                                         for p in ("hip", "knee", "ankle")])
        self._knee_qpos = np.concatenate([character.joint_qpos(character.role(f"{s}_knee"))
                                          for s in ("left", "right")])
        # where the feet are in the held pose: the squat IK keeps them there
        self._foot_targets = [(foot, *character.poses.body_pose(pose, foot))
                              for _, foot in self._legs]
        left, right = character.contacts.foot_sites()
        self._support = 0.5 * (left[:2] + right[:2]) + self.offset
        self._com_z = character.state.com()[2]
        self._pose_cache: dict[int, np.ndarray] = {0: pose}
        self._dz_key = 0
        self.com_target = np.array([*self._support, self._com_z])

    def height_offset(self, t: float) -> float:
        """COM height offset (m) at time ``t``."""
        return float(self.height(t)) if callable(self.height) else float(self.height)

    def pose_for_height(self, character: Character, dz: float) -> np.ndarray:
        """``(nq,)`` the held pose with the pelvis moved vertically by ``dz`` m (negative: down)
        and the feet in place (IK on the hips, knees and ankles; cached per millimetre)."""
        key = int(round(dz * 1000))
        if key not in self._pose_cache:
            q = self._base_pose.copy()
            q[character.root_qpos[2]] += key / 1000.0
            near = min(self._pose_cache, key=lambda k: abs(k - key))  # warm start
            q[self._leg_qpos] = self._pose_cache[near][self._leg_qpos]
            if near == 0:  # straight knees are singular for vertical motion: seed a flexion
                q[self._knee_qpos] = np.maximum(q[self._knee_qpos], 0.2)
            self._pose_cache[key] = character.poses.solve_ik(q, self._foot_targets, self._leg_dofs)
        return self._pose_cache[key]

    def virtual_force_torques(self, character: Character, f: np.ndarray) -> np.ndarray:
        """``(nv,)`` joint torques realising the COM force ``f`` ``(3,)`` N on the stance legs:
        ``-J_x^T f`` per stance leg (``x`` the COM attached to that foot), on its hip, knee and
        ankle dofs only, ``f`` shared equally between the legs in contact (both if none is)."""
        return self._leg_torques(character, f, character.state.com())

    def _leg_torques(self, character: Character, f: np.ndarray, c: np.ndarray) -> np.ndarray:
        """:meth:`virtual_force_torques` with the centre of mass ``c`` ``(3,)`` already read."""
        contacts = character.contacts.feet()
        stance = [i for i in (0, 1) if contacts[i]] or [0, 1]
        share = np.asarray(f, dtype=float) / len(stance)
        tau = np.zeros(character.nv)
        jac = self._jac
        for i in stance:
            jacp, _ = character.dynamics.point_jacobian(self._legs[i][1], c, out=jac)
            tau -= (share @ jacp) * self._leg_mask[i]
        return tau

    def act(self, character: Character, t: float) -> Action:
        """PD action on the (possibly lowered) pose plus the virtual-force torques."""
        if self.pd.gains is None:
            raise ControllerError("static balance: act() called before reset()")
        dz = self.height_offset(t)
        if self.squat_ik:
            key = int(round(dz * 1000))
            if key != self._dz_key:
                self.pd.set_target(self.pose_for_height(character, dz), character)
                self._dz_key = key
        self.com_target = np.array([*self._support, self._com_z + dz])
        state = character.state
        c = state.com()
        f = self.kp * (self.com_target - c) - self.kd * state.com_velocity()
        self.last_force = f
        a = self.pd.act(character, t)
        tau = self._leg_torques(character, f, c)
        return Action(torque=tau if a.torque is None else a.torque + tau, target=a.target)


def make_static_balance(character: Character, target=None, *, gains=None,
                        **options) -> StaticBalance:
    """Static balance holding ``target`` when it is a pose ``(nq,)`` (else the standing pose),
    on stable PD with ``gains``; ``options`` go to :class:`StaticBalance` (e.g. ``height``)."""
    pose = target if isinstance(target, np.ndarray) else None
    return StaticBalance(pose, pd=StablePDController(None, gains), **options)


register(ControllerSpec(
    name="static_balance", label="stable PD + COM virtual force", kind="balance",
    factory=make_static_balance, abilities=("stand",),
    default_scenario="stand", options=("height",),
    bench=("stand", "random-push", "push-search"), expected=("stand", "random-push")))
