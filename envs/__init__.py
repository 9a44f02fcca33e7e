"""Gymnasium environments, registered as ``mjchar/...`` when this package is imported.

=========================  =====================================================================
``mjchar/Imitation-v0``    imitate a reference motion (DeepMimic reward), :mod:`envs.imitation`
``mjchar/Stand-v0``        stand and recover from random pushes, :mod:`envs.stand`
=========================  =====================================================================

Gymnasium 1.x has no plugin discovery (no entry-point group): importing ``envs`` registers the
ids, or let ``gymnasium.make`` import it for you with the ``module:id`` form::

    import gymnasium as gym
    import envs  # noqa: F401  (registers mjchar/...)
    env = gym.make("mjchar/Imitation-v0")
    env = gym.make("envs:mjchar/Stand-v0")  # same without the import

The environment classes are importable as ``envs.ImitationEnv`` and ``envs.StandEnv`` (loaded on
first access, so that ``import envs`` stays light for vectorised workers).
"""

from __future__ import annotations

import os
import sys

if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                             or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering, read when MuJoCo loads

from gymnasium.envs.registration import register, registry  # noqa: E402

__all__ = ["ENV_IDS", "ImitationEnv", "StandEnv"]

#: the registered ids and their entry points
ENV_IDS = {
    "mjchar/Imitation-v0": "envs.imitation:ImitationEnv",
    "mjchar/Stand-v0": "envs.stand:StandEnv",
}

for _id, _entry in ENV_IDS.items():
    if _id not in registry:  # re-importing (reload) must not warn about overriding
        register(id=_id, entry_point=_entry)


def __getattr__(name: str):
    if name == "ImitationEnv":
        from .imitation import ImitationEnv

        return ImitationEnv
    if name == "StandEnv":
        from .stand import StandEnv

        return StandEnv
    raise AttributeError(f"module 'envs' has no attribute {name!r}")
