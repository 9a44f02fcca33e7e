"""The threaded vector env (``gym.make_vec("mjchar/...", num_envs=N)``): step for step equal to
Gymnasium's ``SyncVectorEnv`` of the same envs (observations, rewards, terminations, truncations
bit for bit, infos exactly, across autoresets), Gymnasium's vector-env contract, options and
bad arguments.

Gymnasium 1.4 ships no checker for vector envs (``gymnasium.utils.env_checker.check_env`` takes
a single env and refuses a ``VectorEnv``); the contract ``SyncVectorEnv`` keeps is checked here:
batched spaces, containment, dtypes and shapes, ``_key`` info masks, ``autoreset_mode`` metadata,
``SyncVectorEnv``'s seeding; every sub-env passes ``check_env``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode

from mjchar import envs
from mjchar.envs.common import EnvError
from mjchar.envs.vector import ThreadedVectorEnv

IMITATION, STAND = "mjchar/Imitation-v0", "mjchar/Stand-v0"


def assert_same_infos(a: dict, b: dict) -> None:
    """Same keys, dtypes and values (NaN equal to NaN: ``data_equivalence`` has NaN != NaN)."""
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], dict):
            assert_same_infos(a[k], b[k])
        else:
            assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
            for x, y in zip(a[k], b[k], strict=True):  # (object arrays hold arrays, None)
                np.testing.assert_equal(x, y, err_msg=k)


def random_actions(venv, n: int, seed: int) -> list[np.ndarray]:
    """Full-range random actions: episodes end within about a second (autoresets happen)."""
    venv.action_space.seed(seed)
    return [venv.action_space.sample() for _ in range(n)]


@pytest.mark.parametrize("env_id", list(envs.ENV_IDS))
def test_make_vec_picks_the_threaded_env(env_id):
    venv = gym.make_vec(env_id, num_envs=2)
    try:
        assert isinstance(venv, ThreadedVectorEnv)
        assert venv.num_envs == 2 and venv.num_threads <= 2
        assert venv.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
        assert venv.spec.id == env_id and venv.spec.kwargs["vectorization_mode"] == \
            "vector_entry_point"
        single = gym.make(env_id)
        assert venv.single_observation_space == single.observation_space
        assert venv.single_action_space == single.action_space
        assert venv.observation_space.shape == (2, *single.observation_space.shape)
        assert venv.action_space.shape == (2, *single.action_space.shape)
        assert venv.get_attr("_max_episode_steps") == (envs.MAX_EPISODE_STEPS,) * 2
    finally:
        venv.close()
    sync = gym.make_vec(env_id, num_envs=1, vectorization_mode="sync")
    assert isinstance(sync, gym.vector.SyncVectorEnv)
    sync.close()


@pytest.mark.parametrize("env_id,mode,num_envs,threads", [
    (IMITATION, AutoresetMode.NEXT_STEP, 3, 2),  # uneven groups
    (IMITATION, AutoresetMode.SAME_STEP, 2, None),
    (STAND, AutoresetMode.NEXT_STEP, 2, None),
])
def test_equals_sync_vector_env_step_for_step(env_id, mode, num_envs, threads):
    venv = gym.make_vec(env_id, num_envs=num_envs, num_threads=threads, autoreset_mode=mode)
    sync = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="sync",
                        vector_kwargs={"autoreset_mode": mode})
    try:
        a, b = venv.reset(seed=7), sync.reset(seed=7)
        assert np.array_equal(a[0], b[0])
        assert_same_infos(a[1], b[1])
        ended, finals = 0, 0
        for act in random_actions(venv, 70, seed=1):
            a, b = venv.step(act), sync.step(act)
            for x, y in zip(a[:4], b[:4], strict=True):
                assert x.dtype == y.dtype and np.array_equal(x, y)
            assert_same_infos(a[4], b[4])
            ended += int(np.sum(a[2] | a[3]))
            finals += int(np.sum(a[4].get("_final_obs", 0)))
        assert ended >= 2  # autoresets were part of the comparison
        assert finals == (ended if mode == AutoresetMode.SAME_STEP else 0)
    finally:
        venv.close()
        sync.close()


def test_vector_contract_and_seeding():
    venv = gym.make_vec(STAND, num_envs=2, push_force=0.0)
    try:
        obs, infos = venv.reset(seed=5)
        single = gym.make(STAND, push_force=0.0)
        for i in range(2):  # sub-env i is seeded with seed + i, as SyncVectorEnv does
            assert np.array_equal(obs[i], single.reset(seed=5 + i)[0])
        assert obs.dtype == venv.observation_space.dtype and obs in venv.observation_space
        assert infos["_sim_time_s"].all() and infos["sim_time_s"].shape == (2,)
        for act in random_actions(venv, 5, seed=0):
            obs, rew, term, trunc, infos = venv.step(act)
            assert obs in venv.observation_space
            assert rew.dtype == np.float64 and rew.shape == (2,)
            assert term.dtype == trunc.dtype == np.bool_ and term.shape == (2,)
            assert set(infos["reward_terms"]) >= {"upright", "_upright"}
            assert infos["_reward_terms"].all()
        obs2 = venv.step(venv.action_space.sample())[0]
        assert not np.shares_memory(obs, obs2)  # copy=True: the batch is not reused
        check_env(venv.envs[0].unwrapped, skip_render_check=True)
        obs, infos = venv.reset(options={"reset_mask": np.array([False, True])})
        assert list(infos["_sim_time_s"]) == [False, True] and infos["sim_time_s"][1] == 0.0
    finally:
        venv.close()
    venv.close()  # twice is fine


def test_options_reach_every_sub_env():
    venv = gym.make_vec(STAND, num_envs=2, num_threads=1, control_freq=15.0)
    try:
        assert venv.num_threads == 1
        assert venv.get_attr("n_substeps") == (gym.make(STAND, control_freq=15.0)
                                               .unwrapped.n_substeps,) * 2
        assert venv.call("reset", seed=0)[0][0].shape == venv.single_observation_space.shape
    finally:
        venv.close()


@pytest.mark.parametrize("kwargs,match", [
    ({"num_envs": 0}, "num_envs must be a positive integer"),
    ({"num_envs": 2, "num_threads": 0}, "num_threads must be a positive integer"),
    ({"num_envs": 2, "autoreset_mode": "sometimes"}, "autoreset_mode must be one of"),
    ({"num_envs": 1, "push_force": (3.0, 1.0)}, "push_force"),
])
def test_bad_arguments_are_one_line_errors(kwargs, match):
    with pytest.raises(EnvError, match=match) as e:
        gym.make_vec(STAND, **kwargs)
    assert "\n" not in str(e.value)


def test_bad_calls_are_one_line_errors():
    venv = gym.make_vec(STAND, num_envs=2, autoreset_mode=AutoresetMode.DISABLED)
    try:
        venv.reset(seed=0)
        with pytest.raises(EnvError, match=r"actions must have shape \(2, "):
            venv.step(np.zeros(venv.single_action_space.shape))
        with pytest.raises(EnvError, match="a list of 2 seeds"):
            venv.reset(seed=[1, 2, 3])
        with pytest.raises(EnvError, match="reset_mask"):
            venv.reset(options={"reset_mask": np.array([False, False])})
        venv._autoreset[1] = True  # as after an episode's end
        with pytest.raises(EnvError, match=r"sub-environment\(s\) \[1\] ended"):
            venv.step(venv.action_space.sample())
    finally:
        venv.close()
