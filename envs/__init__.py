"""Gymnasium environments, registered as ``mjchar/...`` (see :mod:`mjchar.gym_ids`).

=========================  =====================================================================
``mjchar/Imitation-v0``    imitate a reference motion (DeepMimic reward),
:mod:`mjchar.envs.imitation` ``mjchar/Stand-v0``        stand and recover from random pushes,
:mod:`mjchar.envs.stand` =========================
=====================================================================

Gymnasium 1.x has no plugin discovery (no entry-point group): importing this package
registers the ids, and so does importing ``mjchar`` (at once when Gymnasium is already
imported, else when it is), or let ``gymnasium.make`` import it for you with the ``module:id``
form::

    import gymnasium as gym
    import mjchar.envs  # noqa: F401  (registers mjchar/...)
    env = gym.make("mjchar/Imitation-v0")
    env = gym.make("mjchar.envs:mjchar/Stand-v0")  # the same without the import

The environment classes are importable as ``mjchar.envs.ImitationEnv`` and
``mjchar.envs.StandEnv`` (loaded on first access, so that importing the package stays light for
vectorised workers).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__all__ = ["ENV_IDS", "VECTOR_ENTRY_POINTS", "MAX_EPISODE_STEPS", "ImitationEnv", "StandEnv",
           "ThreadedVectorEnv"]

#: the registered ids and their entry points
ENV_IDS = {
    "mjchar/Imitation-v0": "mjchar.envs.imitation:ImitationEnv",
    "mjchar/Stand-v0": "mjchar.envs.stand:StandEnv",
}
#: their vector entry points (``gym.make_vec(id, num_envs=N)``: threads in one process,
#: :mod:`mjchar.envs.vector`; ``vectorization_mode="sync"``/``"async"`` use the entry points)
VECTOR_ENTRY_POINTS = {
    "mjchar/Imitation-v0": "mjchar.envs.vector:ImitationVectorEnv",
    "mjchar/Stand-v0": "mjchar.envs.vector:StandVectorEnv",
}
#: the episode limit every id states (``TimeLimit``): the envs' default 10 s at 30 Hz; give
#: ``gym.make(id, max_episode_steps=...)`` with other ``episode_seconds`` or ``control_freq``
MAX_EPISODE_STEPS = 300

for _id, _entry in ENV_IDS.items():
    if _id not in registry:  # re-importing (reload) must not warn about overriding
        register(id=_id, entry_point=_entry, vector_entry_point=VECTOR_ENTRY_POINTS[_id],
                 max_episode_steps=MAX_EPISODE_STEPS)


def __getattr__(name: str):
    if name == "ImitationEnv":
        from .imitation import ImitationEnv

        return ImitationEnv
    if name == "StandEnv":
        from .stand import StandEnv

        return StandEnv
    if name == "ThreadedVectorEnv":
        from .vector import ThreadedVectorEnv

        return ThreadedVectorEnv
    raise AttributeError(f"module 'mjchar.envs' has no attribute {name!r}")
