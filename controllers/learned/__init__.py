"""Learned tracking policies as controllers, numpy only: the policy file (:mod:`.policy_file`),
MLP inference (:mod:`.mlp`), the observation shared with ``mjchar/Imitation-v0``
(:mod:`.observation`) and the ``policy`` controller (:mod:`.controller`, registered). Training
is the application layer's (:mod:`mjchar.learn`, ``mjchar learn``)."""

from .controller import PolicyController, bundled_policies, find_policy, make_policy
from .mlp import MLP
from .observation import TrackingObserver, clip_phase
from .policy_file import Policy, PolicyError, clip_hash, load_policy, save_policy

__all__ = ["MLP", "Policy", "PolicyController", "PolicyError", "TrackingObserver",
           "bundled_policies", "clip_hash", "clip_phase", "find_policy", "load_policy",
           "make_policy", "save_policy"]
