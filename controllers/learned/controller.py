"""A learned tracking policy as a controller (``mjchar run policy POLICY``).

The policy acts as it did in ``mjchar/Imitation-v0`` (:mod:`mjchar.envs.imitation`), at the
control frequency of its file: every ``1 / control_freq`` seconds it observes the character
(:class:`~.observation.TrackingObserver`, the env's observation at the clip time ``t``) and
sets the PD targets of MuJoCo's native PD actuators to::

    u = base + s * pi(o)

``base``: the native PD set-points of the reference one control step ahead
(``u = q_bar + (kd / kp) qdot_bar`` at ``t + 1 / control_freq``, as the env's base controller);
``s``: the per-actuator scale of the file; ``pi``: the network, clipped to [-1, 1]. The targets
are held until the next control step. No force on the root. The character's physics time step
is the one the policy was trained at (the file's ``n_substeps`` steps per control), unless the
run gives another.

Running it needs numpy only (:class:`~.mlp.MLP`). A policy trained on another model or another
clip is refused in one line (:meth:`~.policy_file.Policy.check`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.base import Action, ControllerError, ReferenceTarget
from ..core.character import Character
from ..core.pd import NativePDController
from ..core.registry import ControllerSpec, register
from .observation import TrackingObserver
from .policy_file import Policy, PolicyError, load_policy

__all__ = ["DEFAULT_POLICY", "PolicyController", "bundled_policies", "find_policy",
           "make_policy", "own_clip"]

#: the bundled policy ``mjchar run policy`` runs when none is named
DEFAULT_POLICY = "walk60"


def find_policy(name_or_path) -> Policy:
    """A policy file by path, or a bundled policy by name (``assets/policies/NAME.npz``;
    ``None``: :data:`DEFAULT_POLICY`); an unknown name lists the bundled ones."""
    if isinstance(name_or_path, Policy):
        return name_or_path
    if name_or_path is None and DEFAULT_POLICY in bundled_policies():
        name_or_path = DEFAULT_POLICY
    if name_or_path is None:
        raise PolicyError("policy needs a policy file: mjchar run policy POLICY (a file written "
                          f"by mjchar learn, or a bundled one: {', '.join(bundled_policies())})")
    p = Path(name_or_path)
    if p.is_file():
        return load_policy(p)
    bundled = _policy_dir() / f"{p.name}.npz"
    if p.suffix == "" and bundled.is_file():
        return load_policy(bundled)
    raise PolicyError(f"{name_or_path}: no such policy file or bundled policy (bundled: "
                      f"{', '.join(bundled_policies()) or 'none'})")


def _policy_dir() -> Path:
    from mjchar import assets

    return Path(assets.__file__).parent / "policies"


def bundled_policies() -> list[str]:
    """Names of the bundled policies."""
    d = _policy_dir()
    return sorted(f.stem for f in d.glob("*.npz")) if d.is_dir() else []


class PolicyController:
    """Runs a learned policy (module docstring).

    Args:
        target: the ReferenceMotion the policy tracks (the clip it was trained on).
        policy: a :class:`~.policy_file.Policy`, a policy file path or a bundled name.
    """

    name = "policy"
    actuation = "native"

    def __init__(self, target=None, policy=None):
        self.policy = find_policy(policy)
        self.target = target
        env = self.policy.meta["env"]
        #: the physics step the policy was trained at (s); applied by ``make_controller``
        self.timestep = float(env["timestep"])
        self.control_dt = 1.0 / float(env["control_freq"])
        self.scale = np.asarray(self.policy.meta["action"]["scale_rad"], dtype=np.float64)
        self._bound = False

    def reset(self, character: Character) -> None:
        """Check the model and the clip against the policy's, then bind the base PD and the
        observation."""
        from ..sampling.trajectory import model_fingerprint

        ref = self.target
        if ref is None or isinstance(ref, np.ndarray) or not hasattr(ref, "qpos"):
            clip = self.policy.meta["clip"]["name"]
            raise PolicyError(f"the policy tracks its clip ({clip}); it cannot hold a pose: run "
                              "it in the track scenario with --motion CLIP")
        self.policy.check(fingerprint=model_fingerprint(character.model), reference=ref)
        if self.scale.shape != (character.nu,):
            raise PolicyError(f"{self.policy.path}: {self.scale.shape[0]} actions for a model "
                              f"with {character.nu} actuators")
        self.pd = NativePDController(ReferenceTarget(ref, time_offset=self.control_dt))
        self.pd.reset(character)
        obs = self.policy.meta["observation"]
        self.observer = TrackingObserver(character, ref, obs["future_steps"], self.control_dt)
        if self.observer.size != obs["size"]:
            raise PolicyError(f"{self.policy.path}: observes {obs['size']} numbers, this "
                              f"character gives {self.observer.size}")
        self._next = 0
        self._u = None
        self.steps = 0
        self._bound = True

    def act(self, character: Character, t: float) -> Action:
        """The held PD targets; a new action at each control step."""
        if not self._bound:
            raise ControllerError("policy: act() called before reset()")
        n = int(math.floor(t / self.control_dt + 1e-6))
        if self._u is None or n >= self._next:
            base = self.pd.act(character, t).target
            a = self.policy(self.observer.observe(character.data, t))
            self._u = base + self.scale * a
            self._next = n + 1
            self.steps += 1
        return Action(target=self._u)


def make_policy(character: Character | None = None, target=None, *, policy=None
                ) -> PolicyController:
    """A :class:`PolicyController` running ``policy`` (file, bundled name or Policy) on
    ``target``."""
    return PolicyController(target, policy)


def own_clip(options) -> tuple:
    """``(motion, loop)``: the clip the ``policy`` option's policy (default
    :data:`DEFAULT_POLICY`) was trained on, and whether it was looped."""
    policy = find_policy(options.get("policy"))
    return policy.clip_motion(), bool(policy.meta["clip"].get("loop"))


register(ControllerSpec(
    name="policy", label="learned tracking policy (mjchar learn)", kind="balance",
    factory=make_policy, abilities=("track",), default_scenario="track",
    options=("policy",), bench=("track",), own_clip=own_clip))
