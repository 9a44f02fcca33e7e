"""A vectorised environment stepping N mjchar characters in threads of one process.

``gymnasium.make_vec("mjchar/Imitation-v0", num_envs=N)`` (and ``mjchar/Stand-v0``) returns a
:class:`ThreadedVectorEnv`: N ordinary sub-environments (:class:`~mjchar.envs.ImitationEnv` or
:class:`~mjchar.envs.StandEnv`, each behind Gymnasium's ``TimeLimit`` as ``gymnasium.make`` puts
it). One call to :meth:`~ThreadedVectorEnv.step` splits the sub-environments into
``num_threads`` contiguous groups and steps each group in a thread of a persistent pool (the
first group in the calling thread), every sub-environment whole and in turn: its action, its
physics (:meth:`Character.advance <mjchar.controllers.core.character.Character.advance>`), then
its reward, observation and termination. MuJoCo's Python bindings release the GIL inside
``mj_step``, so one thread's physics runs beside another thread's Python; no process, no
pickling, no copy of the observations beyond the batch itself. :meth:`~ThreadedVectorEnv.reset`
and the autoresets run in the same groups.

Each sub-environment is the single environment unchanged, seeded as ``SyncVectorEnv`` seeds
them (``reset(seed=s)``: sub-environment ``i`` gets ``s + i``), so a vector of N gives the
observations, rewards, terminations and truncations of N single environments bit for bit,
across autoresets too.

Options beside the sub-environments' keyword arguments (``gym.make_vec`` passes them through
``kwargs``; its ``vector_kwargs`` must stay empty for a ``vector_entry_point``):

- ``num_threads``: threads stepping the physics (default ``min(num_envs, os.cpu_count())``);
- ``autoreset_mode``: Gymnasium's ``AutoresetMode`` (or its value): ``NEXT_STEP`` (default),
  ``SAME_STEP`` (``info["final_obs"]``/``info["final_info"]``) or ``DISABLED``;
- ``copy``: return a copy of the observation batch (default ``True``, as ``SyncVectorEnv``).
"""

from __future__ import annotations

import importlib
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from gymnasium.wrappers import TimeLimit

from mjchar.controllers.core.errors import SimulationDiverged

from .common import EnvError

__all__ = ["ThreadedVectorEnv", "ImitationVectorEnv", "StandVectorEnv"]


def _positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise EnvError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def _autoreset_mode(value) -> AutoresetMode:
    try:
        return value if isinstance(value, AutoresetMode) else AutoresetMode(value)
    except ValueError:
        raise EnvError(f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, got "
                       f"{value!r}") from None


class ThreadedVectorEnv(VectorEnv):
    """``num_envs`` sub-environments of ``env_entry`` stepped together in threads.

    Args:
        env_entry: the sub-environment class, or its ``"module:Class"`` string.
        num_envs: number of sub-environments.
        num_threads: threads stepping the physics (``None``: ``min(num_envs, os.cpu_count())``).
        autoreset_mode: ``AutoresetMode`` or its value (default ``NEXT_STEP``).
        copy: :meth:`reset` and :meth:`step` return a copy of the observation batch.
        max_episode_steps: each sub-environment's ``TimeLimit`` (``None``: none; ``make_vec``
            passes the id's 300).
        **kwargs: passed to every sub-environment.
    Raises:
        EnvError: a bad option (one line naming it).
    """

    def __init__(self, env_entry, num_envs: int = 1, *, num_threads: int | None = None,
                 autoreset_mode=AutoresetMode.NEXT_STEP, copy: bool = True,
                 max_episode_steps: int | None = None, **kwargs):
        super().__init__()
        n = _positive_int(num_envs, "num_envs")
        threads = min(n, os.cpu_count() or 1) if num_threads is None else \
            _positive_int(num_threads, "num_threads")
        threads = min(threads, n)
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        if max_episode_steps is not None:
            max_episode_steps = _positive_int(max_episode_steps, "max_episode_steps")
        if isinstance(env_entry, str):
            module, _, name = env_entry.partition(":")
            env_entry = getattr(importlib.import_module(module), name)
        self.copy = bool(copy)
        self.num_envs = n
        self.num_threads = threads
        self._pool = None
        self.envs = []
        try:
            for _ in range(n):
                env = env_entry(**kwargs)
                if max_episode_steps is not None:
                    env = TimeLimit(env, max_episode_steps)
                self.envs.append(env)
        except BaseException:
            for env in self.envs:  # (a bad option fails the first; free what was built)
                env.close()
            raise
        first = self.envs[0]
        self.metadata = dict(first.metadata, autoreset_mode=self.autoreset_mode)
        self.render_mode = first.render_mode
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        # contiguous groups, one per thread; the calling thread steps the first
        bounds = np.linspace(0, n, threads + 1).round().astype(int)
        self._groups = [range(int(a), int(b))
                        for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        if threads > 1:  # (step: the physics of every sub-environment; reset: the groups)
            self._pool = ThreadPoolExecutor(threads, thread_name_prefix="mjchar-vec")
        self._obs = np.zeros(self.observation_space.shape, self.observation_space.dtype)
        self._rewards = np.zeros(n)
        self._terminations = np.zeros(n, dtype=bool)
        self._truncations = np.zeros(n, dtype=bool)
        self._autoreset = np.zeros(n, dtype=bool)
        self._infos: list = [None] * n
        self._final: list = [None] * n

    # -- the parallel map ---------------------------------------------------------------------
    def _run(self, work, mask=None) -> None:
        """Call ``work(i)`` for every sub-environment (where ``mask``), each group in its own
        thread, the first in this one; re-raises the first error."""
        def group(g):
            for i in g:
                if mask is None or mask[i]:
                    work(i)

        futures = [self._pool.submit(group, g) for g in self._groups[1:]] if self._pool else []
        try:
            group(self._groups[0])
        finally:
            for f in futures:
                f.result()

    def _batch_infos(self, indices) -> dict:
        """The sub-environments' infos batched as Gymnasium's ``_add_info`` batches them
        (an array and a ``_key`` mask per key, nested dicts likewise)."""
        indices = list(indices)
        if len(indices) == self.num_envs and all(f is None for f in self._final):
            batched = self._batch_same_keys(self._infos)
            if batched is not None:
                return batched
        infos: dict = {}
        for i in indices:
            if self._final[i] is not None:
                infos = self._add_info(infos, self._final[i], i)
                self._final[i] = None
            infos = self._add_info(infos, self._infos[i], i)
        return infos

    def _batch_same_keys(self, infos: list) -> dict | None:
        """``_add_info`` over every sub-environment at once when all their infos have the same
        keys (every step without an episode's end): one array per key instead of one
        assignment per key and sub-environment; ``None`` otherwise."""
        keys = infos[0].keys()
        if any(info.keys() != keys for info in infos):
            return None
        n = self.num_envs
        out: dict = {}
        for key, first in infos[0].items():
            if isinstance(first, dict):
                array = self._batch_same_keys([info[key] for info in infos])
                if array is None:
                    return None
            else:
                kind = type(first)
                if kind in (int, float, bool) or issubclass(kind, np.number):
                    array = np.zeros(n, dtype=kind)
                elif isinstance(first, np.ndarray):
                    array = np.zeros((n, *first.shape), dtype=first.dtype)
                else:
                    array = np.full(n, fill_value=None, dtype=object)
                for i, info in enumerate(infos):  # (as _add_info assigns: same conversions)
                    array[i] = info[key]
            out[key], out[f"_{key}"] = array, np.ones(n, dtype=np.bool_)
        return out

    # -- gymnasium API -----------------------------------------------------------------------
    def reset(self, *, seed=None, options: dict | None = None):
        """Reset every sub-environment (or those of ``options["reset_mask"]``, a bool array
        ``(num_envs,)``); ``seed``: ``None``, an int ``s`` (sub-environment ``i`` gets ``s + i``)
        or a list of ``num_envs`` ints or ``None``. Returns ``(obs (num_envs, obs_dim), infos)``."""
        n = self.num_envs
        if seed is None or isinstance(seed, int | np.integer):
            seeds = [None] * n if seed is None else [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise EnvError(f"seed must be None, an int or a list of {n} seeds, got "
                               f"{len(seeds)} seeds")
        options = {} if options is None else dict(options)
        mask = options.pop("reset_mask", None)
        if mask is not None:
            mask = np.asarray(mask)
            if mask.dtype != np.bool_ or mask.shape != (n,) or not mask.any():
                raise EnvError(f"options['reset_mask'] must be a bool array of shape ({n},) "
                               f"with a True value, got {mask!r}")
        sub_options = options or None

        def reset_one(i):
            obs, self._infos[i] = self.envs[i].reset(seed=seeds[i], options=sub_options)
            self._obs[i] = obs
            self._terminations[i] = self._truncations[i] = self._autoreset[i] = False

        self._run(reset_one, mask)
        infos = self._batch_infos(range(n) if mask is None else np.flatnonzero(mask))
        return (self._obs.copy() if self.copy else self._obs), infos

    def step(self, actions):
        """Step every sub-environment with its row of ``actions`` ``(num_envs, act_dim)``
        (a sub-environment whose episode ended last step is reset instead under ``NEXT_STEP``);
        returns ``(obs, rewards, terminations, truncations, infos)`` batched."""
        a = np.asarray(actions)
        if a.shape != self.action_space.shape:
            raise EnvError(f"actions must have shape {self.action_space.shape}, got {a.shape}")
        mode = self.autoreset_mode
        if mode == AutoresetMode.DISABLED and self._autoreset.any():
            raise EnvError(f"sub-environment(s) {np.flatnonzero(self._autoreset).tolist()} ended "
                           f"their episode: reset them (options['reset_mask']) before step() "
                           f"with autoreset_mode DISABLED")

        # each thread steps its group whole (action, physics, reward, observation): the
        # Python holds the interpreter, MuJoCo releases it, so one thread's physics overlaps
        # another's Python (the calling thread steps the first group rather than wait)
        self._run(lambda i: self._step_one(i, a[i], mode))
        infos = self._batch_infos(range(self.num_envs))
        np.logical_or(self._terminations, self._truncations, out=self._autoreset)
        return ((self._obs.copy() if self.copy else self._obs), self._rewards.copy(),
                self._terminations.copy(), self._truncations.copy(), infos)

    def _step_one(self, i: int, action, mode) -> None:
        """Sub-environment ``i``'s step (or, under ``NEXT_STEP`` after its episode ended, its
        reset), into the batch; runs in the thread of ``i``'s group."""
        env = self.envs[i]
        if mode == AutoresetMode.NEXT_STEP and self._autoreset[i]:
            self._obs[i], self._infos[i] = env.reset()
            self._rewards[i] = 0.0
            self._terminations[i] = self._truncations[i] = False
            return
        base = env.unwrapped
        ch = base.character
        ch.begin_step(base._step_begin(action))
        try:
            ch.advance(base.n_substeps)
            ch.end_step()
        except SimulationDiverged as e:
            obs, r, term, trunc, info = base._step_diverged(e)
        else:
            obs, r, term, trunc, info = base._step_end()
        if isinstance(env, TimeLimit):  # what the wrapper's step adds
            env._elapsed_steps += 1
            if env._elapsed_steps >= env._max_episode_steps:
                trunc = True
        self._rewards[i], self._terminations[i], self._truncations[i] = r, term, trunc
        if mode == AutoresetMode.SAME_STEP and (term or trunc):
            self._final[i] = {"final_obs": obs, "final_info": info}
            obs, info = env.reset()
        self._infos[i] = info
        self._obs[i] = obs

    def render(self) -> tuple:
        """Each sub-environment's ``render()``."""
        return tuple(env.render() for env in self.envs)

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Call method ``name`` of every sub-environment (or read the attribute)."""
        out = []
        for env in self.envs:
            f = env.get_wrapper_attr(name)
            out.append(f(*args, **kwargs) if callable(f) else f)
        return tuple(out)

    def get_attr(self, name: str) -> tuple:
        """Attribute ``name`` of every sub-environment."""
        return tuple(env.get_wrapper_attr(name) for env in self.envs)

    def set_attr(self, name: str, values) -> None:
        """Set attribute ``name`` of every sub-environment (a list or tuple: one value each)."""
        if not isinstance(values, list | tuple):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise EnvError(f"set_attr needs {self.num_envs} values, got {len(values)}")
        for env, v in zip(self.envs, values, strict=True):
            env.set_wrapper_attr(name, v)

    @property
    def np_random_seed(self) -> tuple:
        """The sub-environments' seeds."""
        return self.get_attr("np_random_seed")

    @property
    def np_random(self) -> tuple:
        """The sub-environments' generators."""
        return self.get_attr("np_random")

    def close_extras(self, **kwargs) -> None:
        """Stop the threads and close every sub-environment."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        for env in self.envs:
            env.close()

    def __deepcopy__(self, memo):  # a thread pool cannot be copied
        raise EnvError("a ThreadedVectorEnv cannot be copied; make another with gym.make_vec")


class ImitationVectorEnv(ThreadedVectorEnv):
    """:class:`ThreadedVectorEnv` of :class:`~mjchar.envs.ImitationEnv` (the vector entry point
    of ``mjchar/Imitation-v0``)."""

    def __init__(self, num_envs: int = 1, **kwargs):
        super().__init__("mjchar.envs.imitation:ImitationEnv", num_envs, **kwargs)


class StandVectorEnv(ThreadedVectorEnv):
    """:class:`ThreadedVectorEnv` of :class:`~mjchar.envs.StandEnv` (the vector entry point of
    ``mjchar/Stand-v0``)."""

    def __init__(self, num_envs: int = 1, **kwargs):
        super().__init__("mjchar.envs.stand:StandEnv", num_envs, **kwargs)
