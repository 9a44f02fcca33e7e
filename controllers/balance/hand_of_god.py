"""Hand-of-god tracking (GAMES-105 lab 3): a PD tracker plus a PD force and torque on the root.

The tracker (any PD-family controller) drives the joints towards the reference; on top, an
external wrench pulls the root body towards the reference root, as a PD law on the free joint's
own coordinates::

    f   = kp (p_bar + lift z - p) + kd (v_bar - v)            (world frame, N, at the root origin)
    tau = kp_rot log(q^-1 q_bar) + kd_rot (w_bar - w)         (root frame, N m)

with ``(p_bar, q_bar, v_bar, w_bar)`` the reference root's position, orientation and velocities
and ``lift`` an optional raise of the target. It is the tracker's own PD law with gains on the
root rows (:meth:`mjchar.controllers.core.pd._PDTracker.set_root_gains`): explicit for explicit and
native PD, and inside the implicit prediction for stable PD. (An explicit root PD next to stable PD
is unstable at ordinary time steps: stable PD's joint torques do not anticipate the root wrench, so
the pelvis alone, with a small inertia, meets the explicit root damping.)

It makes tracking work and looks like a puppet on a string: every other controller's goal is to
need none of it. The wrench it applied is recorded (:attr:`HandOfGod.last_force`,
:attr:`HandOfGod.last_torque`, and per step by the scenarios through
``character.actuation.root_wrench``).
"""

from __future__ import annotations

import numpy as np

from ..core.base import Action, ControllerError, LiftedTarget
from ..core.character import Character
from ..core.registry import ControllerSpec, get, make_controller, register


class HandOfGod:
    """Wrap a PD tracker and pull its root towards the tracker's target.

    Args:
        tracker: a PD-family controller (``PDController``, ``StablePDController``,
            ``NativePDController``) whose target is the reference to follow.
        kp, kd: root force gains (N/m, N s/m).
        kp_rot, kd_rot: root torque gains (N m/rad, N m s/rad).
        lift: metres added to the target root height.
        support: fraction of the body weight the string carries: adds ``support * m g / kp`` to
            ``lift``, so that ``kp * lift`` holds that much weight when the root is on target
            (GAMES-105 raises the target ~0.1 m for walking; with ``support=1`` the puppet hangs
            at the reference height whether or not the reference's feet reach the floor).
    """

    name = "hand_of_god"

    def __init__(self, tracker, *, kp: float = 4000.0, kd: float = 1000.0,
                 kp_rot: float = 2000.0, kd_rot: float = 200.0, lift: float = 0.0,
                 support: float = 1.0):
        for n, v in (("kp", kp), ("kd", kd), ("kp_rot", kp_rot), ("kd_rot", kd_rot),
                     ("lift", abs(lift)), ("support", support)):
            if not (np.isfinite(v) and v >= 0):
                raise ControllerError(f"hand of god: {n} must be a non-negative number, got {v}")
        self.tracker = tracker
        self.kp, self.kd, self.kp_rot, self.kd_rot = kp, kd, kp_rot, kd_rot
        self.lift = float(lift)
        self.support = float(support)
        if support > 0 and kp <= 0:
            raise ControllerError("hand of god: support needs kp > 0")
        self.last_force = np.zeros(3)
        self.last_torque = np.zeros(3)

    @property
    def actuation(self) -> str:
        """The tracker's actuation mode."""
        return self.tracker.actuation

    @property
    def target(self):
        """The tracker's bound target (``None`` before :meth:`reset`)."""
        return self.tracker.target

    def reset(self, character: Character) -> None:
        """Reset the tracker (binding its target and switching the actuation), then give its
        root rows the hand-of-god gains."""
        self.tracker.reset(character)
        lift = self.lift
        if self.support:
            g = -float(character.dynamics.gravity[2])
            lift += self.support * character.dynamics.mass * g / self.kp
        if lift:
            self.tracker.set_target(LiftedTarget(self.tracker.target, lift), character)
        self.tracker.set_root_gains(character, self.kp, self.kd, self.kp_rot, self.kd_rot)
        r = character.root_dofs  # (the root's six dofs: a slice when contiguous, as they are)
        contiguous = np.array_equal(r, np.arange(r[0], r[0] + len(r)))
        self._r = slice(int(r[0]), int(r[0]) + len(r)) if contiguous else r
        self.last_force = np.zeros(3)
        self.last_torque = np.zeros(3)

    def act(self, character: Character, t: float) -> Action:
        """The tracker's action, whose root rows carry the hand-of-god wrench."""
        if self.tracker.target is None:
            raise ControllerError("hand of god: act() called before reset()")
        a = self.tracker.act(character, t)
        w = np.zeros(6) if a.torque is None else a.torque[self._r]
        self.last_force = w[:3].copy()
        self.last_torque = character.state.root_rotation @ w[3:]
        return a


def make_hand_of_god(character: Character, target=None, *, gains=None, tracker: str = "spd",
                     **options) -> HandOfGod:
    """Hand-of-god around the PD variant ``tracker`` (a registered ``pd``-kind controller:
    ``pd``, ``spd``, ``native_pd``) following ``target``; ``options`` go to :class:`HandOfGod`."""
    if get(tracker).kind != "pd":
        raise ControllerError(f"hand_of_god wraps a PD tracker, not {tracker!r}")
    return HandOfGod(make_controller(tracker, character, target, gains=gains), **options)


register(ControllerSpec(
    name="hand_of_god", label="stable PD + root force", kind="balance", factory=make_hand_of_god,
    abilities=("stand", "track"),
    default_scenario="track", options=("tracker",), floor="clip",
    bench=("stand", "track"), expected=("stand", "track")))
