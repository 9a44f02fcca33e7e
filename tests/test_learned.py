"""Learned tracking policies: the policy file, numpy inference, the ``policy`` controller, the
observation shared with ``mjchar/Imitation-v0``, and ``mjchar learn``."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from mjchar.cli import main
from mjchar.controllers.core.builder import RunSpec, load_reference
from mjchar.controllers.core.character import Character
from mjchar.controllers.learned import (
    MLP,
    PolicyError,
    TrackingObserver,
    clip_hash,
    load_policy,
    save_policy,
)


def _random_mlp(n_in: int, n_out: int, hidden=(32, 16), seed: int = 0, scale: float = 0.05):
    rng = np.random.default_rng(seed)
    sizes = [n_in, *hidden, n_out]
    W = [rng.normal(0, scale, (b, a)) for a, b in zip(sizes[:-1], sizes[1:], strict=True)]
    b = [rng.normal(0, scale, (n,)) for n in sizes[1:]]
    return MLP(W, b, rng.normal(0, 1, n_in), rng.uniform(0.5, 2.0, n_in))


@pytest.fixture(scope="module")
def walk_policy(tmp_path_factory):
    """A policy file for the bundled walk, looped, with small random weights (close to the zero
    action: plain PD)."""
    from mjchar.learn.collect import LearnSetup, make_env
    from mjchar.learn.dagger import policy_metadata

    setup = LearnSetup(clip="walk", loop=True)
    env = make_env(setup)
    meta = policy_metadata(setup, env)
    n_in, nu = env.observation_space.shape[0], env.action_space.shape[0]
    env.close()
    path = tmp_path_factory.mktemp("policy") / "walk.npz"
    save_policy(path, _random_mlp(n_in, nu, scale=0.01), meta)
    return path


def test_mlp_numpy_equals_torch():
    torch = pytest.importorskip("torch")
    from mjchar.learn.train import Trainer

    tr = Trainer(7, 3, (16, 8), seed=1)
    X = np.random.default_rng(0).normal(size=(50, 7))
    tr.fit(X, np.random.default_rng(1).normal(size=(50, 3)), epochs=2)
    with torch.no_grad():
        ref = tr.net(torch.from_numpy((X - tr.mean) / tr.std)).numpy()
    np.testing.assert_allclose(tr.mlp()(X), ref, rtol=1e-10, atol=1e-12)


def test_policy_file_round_trips(walk_policy, tmp_path):
    p = load_policy(walk_policy)
    x = np.random.default_rng(0).normal(size=(5, p.net.n_in))
    out = tmp_path / "copy.npz"
    save_policy(out, p.net, p.meta)
    q = load_policy(out)
    np.testing.assert_array_equal(q.net(x), p.net(x))
    assert q.meta == p.meta
    assert q.meta["format"] == "mjchar-policy" and q.meta["clip"]["loop"] is True
    assert [b[0] for b in q.meta["observation"]["layout"]][-1] == "reference_pose_1_ahead"


def test_a_file_that_is_not_a_policy_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    np.savez(bad, x=np.zeros(3))
    with pytest.raises(PolicyError, match="not an mjchar policy file"):
        load_policy(bad)
    assert main(["run", "policy", str(bad), "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_a_mismatched_clip_is_refused_in_one_line(walk_policy, capsys):
    """Trained on the looped walk: the walk once through (another reference) is refused."""
    assert main(["run", "policy", str(walk_policy), "--motion", "idle",
                 "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "was trained on clip walk --loop" in err


def test_a_mismatched_model_is_refused_in_one_line(walk_policy, tmp_path, capsys):
    from mjchar.bvh.bundled.assets import humanoid_path

    xml = tmp_path / "slippery.xml"
    text = humanoid_path().read_text()
    assert 'friction="1 0.005 0.0001"' in text
    xml.write_text(text.replace('friction="1 0.005 0.0001"', 'friction="0.7 0.005 0.0001"'))
    assert main(["run", "policy", str(walk_policy), "--model", str(xml), "--loop",
                 "--motion", "walk", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "trained on another model" in err


def test_the_policy_runs_from_its_own_clip_and_tracks_with_no_root_force(walk_policy, capsys):
    assert main(["run", "policy", str(walk_policy), "--duration", "0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["root_force_max_N"] == 0.0 and not out["diverged"]
    assert out["sim_time_s"] == pytest.approx(0.5, abs=0.02)


def test_a_policy_run_with_no_clip_follows_its_own_clip(walk_policy):
    """With no motion the builder runs a policy on the clip it was trained on, looped as it was
    (``ControllerSpec.own_clip``), from Python as from the CLI; a clip given is used as given."""
    from mjchar.controllers.learned import PolicyError

    spec = RunSpec("policy", "track", options={"policy": str(walk_policy)},
                   scenario_options={"duration": 0.2})
    own = spec.with_own_clip()
    assert (own.motion, own.loop) == ("walk", True)
    r = spec.execute()
    assert not r.fell and r.root_force_max_N == 0.0
    with pytest.raises(PolicyError, match="trained on clip walk --loop"):
        dataclasses.replace(spec, motion="walk").execute()  # given, not looped
    assert RunSpec("mpc", "track").with_own_clip() == RunSpec("mpc", "track")


def test_env_and_controller_observe_the_same_numbers():
    """The env's observation is the shared TrackingObserver's, at the same state and time."""
    from mjchar.envs.imitation import ImitationEnv

    env = ImitationEnv("walk", future_steps=(1, 2))
    obs, _ = env.reset(seed=3)
    for _ in range(3):
        obs, *_ = env.step(env.action_space.sample() * 0.1)
    tob = TrackingObserver(env.character, env.reference, (1, 2), env.control_dt)
    np.testing.assert_allclose(tob.observe(env.character.data, env.reference_time), obs,
                               rtol=1e-6, atol=1e-6)
    env.close()


def test_the_controller_acts_as_the_policy_does_in_the_env(walk_policy):
    """The same policy from phase 0: the controller's run and the env's episode visit the same
    states (the env's and the run's clip are the same looped walk)."""
    from mjchar.controllers.core import scenarios as S
    from mjchar.controllers.core.registry import make_controller
    from mjchar.learn.collect import LearnSetup, make_env

    policy = load_policy(walk_policy)
    env = make_env(LearnSetup(clip="walk", loop=True))
    obs, _ = env.reset(options={"phase": 0.0})
    roots = []
    for _ in range(15):
        obs, _, term, _, _ = env.step(policy(obs))
        roots.append(env.character.data.xpos[env.character.root_body].copy())
        assert not term
    ch = Character()
    ref = load_reference(RunSpec("policy", "track", motion="walk", loop=True), ch)
    c = make_controller("policy", ch, ref, policy=policy)
    seen = []

    def frame(character):
        seen.append((character.time, character.data.xpos[character.root_body].copy()))

    S.track(ch, c, ref, duration=15 * env.control_dt, frame_callback=frame)
    at = {round(t / env.control_dt): x for t, x in seen
          if abs(t / env.control_dt - round(t / env.control_dt)) < 1e-6}  # control steps
    for k in (5, 10, 15):
        np.testing.assert_allclose(at[k], roots[k - 1], atol=1e-4)
    env.close()


def test_clip_hash_tells_clips_apart():
    ch = Character()
    a = load_reference(RunSpec("mpc", "track", motion="walk", loop=True), ch)
    b = load_reference(RunSpec("mpc", "track", motion="walk", loop=False), ch)
    c = load_reference(RunSpec("mpc", "track", motion="walk", loop=True), ch)
    assert clip_hash(a) == clip_hash(c) != clip_hash(b)


def test_learn_refuses_bad_input_in_one_line(tmp_path, capsys):
    for argv in (["learn", str(tmp_path / "none.bvh"), "-o", str(tmp_path / "p.npz")],
                 ["learn", "walk", "-o", str(tmp_path / "p.txt")],
                 ["learn", "walk", "-o", str(tmp_path / "no" / "p.npz")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err


@pytest.mark.slow
def test_a_short_learn_run_lowers_the_loss_and_beats_the_zero_action(tmp_path):
    """Three DAgger iterations on the bundled walk: the training loss falls, and the learner
    scores a higher Imitation-v0 return than the zero action (plain PD) from the same starts."""
    pytest.importorskip("torch")
    from mjchar.learn.collect import Collector, Episode, LearnSetup
    from mjchar.learn.dagger import LearnOptions, learn

    setup = LearnSetup(clip="walk", loop=True, label_samples=8)
    out = tmp_path / "walk.npz"
    opts = LearnOptions(minutes=0.01, workers=2, episodes=2, episode_seconds=1.0,
                        eval_phases=2, eval_seconds=2.0, max_steps=800, rl_share=0.0)
    rows = []
    for i in range(3):
        learn(setup, out, opts, resume=i > 0)
        rows = json.loads(out.with_suffix("").with_name("walk.curve.json").read_text())
    assert len(rows) == 3
    assert rows[-1]["loss_after"] < rows[0]["loss_before"]
    # the file holds the best network evaluated: the last written one, which no later beat
    written = [r for r in rows if r["written"]]
    assert written and written[0]["iteration"] == 1
    policy = load_policy(out)
    assert policy.meta["training"]["iteration"] == written[-1]["iteration"]
    key = [(r["eval_fall_rate"], r.get("disturbed_fall_rate", 0.0), -r["eval_survived_s"],
            r["eval_error_m"]) for r in rows]
    assert key[written[-1]["iteration"] - 1] == min(key[:written[-1]["iteration"]])
    col = Collector(setup)
    learned = [col.run(Episode(seed=i, phase=i / 4, seconds=3.0, policy=policy.net,
                               beta=0.0, label=False)) for i in range(4)]
    zero = [col.run(Episode(seed=i, phase=i / 4, seconds=3.0, beta=0.0, label=False))
            for i in range(4)]
    col.close()
    assert sum(r.episode_return for r in learned) > sum(r.episode_return for r in zero)


def test_the_kept_network_can_be_chosen_on_disturbed_episodes_too():
    """With eval_perturbed and eval_pushes (none by default) the evaluation adds a fixed
    validation set of perturbed starts and pushes (eight different directions); a network that
    falls less there ranks above one that tracks the undisturbed clip a little closer, and a
    fall on the clip ranks below both."""
    from mjchar.learn.dagger import LearnOptions, _eval_jobs, _score

    assert _eval_jobs(LearnOptions(), None)[1] == []
    opts = LearnOptions(eval_perturbed=4, eval_pushes=8)
    clip, disturbed = _eval_jobs(opts, None)
    assert len(clip) == opts.eval_phases and all(j.push is None and j.perturb is None
                                                 for j in clip)
    perturbed = [j for j in disturbed if j.perturb is not None]
    pushes = [j for j in disturbed if j.push is not None]
    assert len(perturbed) == opts.eval_perturbed and len(pushes) == opts.eval_pushes
    directions = {round(math.degrees(math.atan2(j.push[2], j.push[1])) % 360, 3) for j in pushes}
    assert len(directions) == 8
    assert all(math.hypot(j.push[1], j.push[2]) == pytest.approx(opts.eval_push_force)
               for j in pushes)
    assert all(j.beta == 0.0 and j.noise == 0.0 and not j.label for j in clip + disturbed)
    assert [j.seed for j in disturbed] == [j.seed for j in _eval_jobs(opts, None)[1]]

    def row(falls, disturbed, error):
        return {"eval_fall_rate": falls, "disturbed_fall_rate": disturbed,
                "eval_survived_s": 10.0 * (1 - falls), "eval_error_m": error}

    assert _score(row(0.0, 0.25, 0.04)) < _score(row(0.0, 0.5, 0.03))
    assert _score(row(0.0, 1.0, 0.09)) < _score(row(0.25, 0.0, 0.03))
    assert _score(row(0.0, 0.25, 0.03)) < _score(row(0.0, 0.25, 0.04))


def test_fine_tuning_episodes_end_only_on_a_fall_while_recovering():
    """In a fine-tuning episode the tracking-error end is lifted for ``recovery_seconds`` from a
    perturbed start: with a threshold no pose passes (0.1 mm) the episode ends on its first
    step without the window, and on the first step past the window with it. The reset is
    seeded: the zero action falls from this perturbed start at 0.73 s, after the window."""
    from mjchar.learn.collect import LearnSetup, make_env
    from mjchar.learn.dagger import LearnOptions
    from mjchar.learn.finetune import Perturbations

    opts = LearnOptions(perturb_rate=1.0, push_rate=0.0)

    def steps_until_the_end(recovery):
        env = Perturbations(make_env(LearnSetup(clip="walk", loop=True,
                                                max_tracking_error=1e-4), episode_seconds=5.0),
                            opts, 5.0, seed=0, recovery=recovery)
        env.reset(seed=0)
        dt = env.unwrapped.n_substeps * env.unwrapped.character.timestep
        steps, ended = 0, False
        while not ended and steps < 100:
            *_, term, trunc, info = env.step(np.zeros(env.action_space.shape))
            steps, ended = steps + 1, term or trunc
        env.close()
        assert not info["fell"]
        return steps, dt

    assert steps_until_the_end(0.0)[0] == 1
    k, dt = steps_until_the_end(0.35)
    assert k == math.ceil(0.35 / dt) + 1  # the first step that begins past 0.35 s ends it


def test_a_curriculum_grows_the_fine_tuning_disturbances_to_daggers():
    """With a curriculum of 10 steps the first fine-tuning episode's push is a quarter of
    DAgger's force, grows with the env's steps and is DAgger's after 10 of them; without one
    it is DAgger's from the start (the same draws)."""
    from mjchar.learn.collect import LearnSetup, make_env
    from mjchar.learn.dagger import LearnOptions
    from mjchar.learn.finetune import Perturbations

    opts = LearnOptions(perturb_rate=0.0, push_rate=1.0, push_force=(60.0, 150.0))

    def forces(ramp):
        env = Perturbations(make_env(LearnSetup(clip="walk", loop=True)), opts, 4.0, seed=0,
                            ramp=ramp, ramp_start=0.25)
        out = []
        for i in range(4):
            env.reset(seed=i)
            (push,) = env.unwrapped.character.pushes.scheduled
            out.append(float(np.linalg.norm(push.force)))
            for _ in range(5):  # (0.17 s: no push has begun, nothing falls)
                env.step(np.zeros(env.action_space.shape))
        env.close()
        return out

    ramped, plain = forces(10), forces(0)
    assert 15.0 <= ramped[0] <= 37.5  # a quarter of 60-150 N
    assert all(60.0 <= f <= 150.0 for f in ramped[2:] + plain)
    np.testing.assert_allclose(np.array(ramped) / np.array(plain), [0.25, 0.625, 1.0, 1.0])


def test_the_ppo_actor_is_the_distilled_network_and_back():
    """The distilled network copied into the PPO actor (the normalisation folded into the first
    layer) and written back as a network gives the network's outputs."""
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")
    from mjchar.learn.collect import LearnSetup, make_env
    from mjchar.learn.dagger import LearnOptions
    from mjchar.learn.finetune import FinetuneOptions, Finetuner

    setup = LearnSetup(clip="walk", loop=True)
    env = make_env(setup)
    n_in, nu = env.observation_space.shape[0], env.action_space.shape[0]
    env.close()
    net = _random_mlp(n_in, nu, hidden=(32, 16), scale=0.1)
    tuner = Finetuner(setup, net, LearnOptions(),
                      FinetuneOptions(critic_warmup=0, envs=1, n_steps=64))
    X = np.random.default_rng(2).normal(size=(20, n_in))
    back = tuner.mlp()
    tuner.close()
    np.testing.assert_allclose(back(X), net(X), rtol=1e-4, atol=1e-5)
    assert back.hidden == net.hidden
    np.testing.assert_array_equal(back.mean, net.mean)


def test_behaviour_cloning_keeps_the_ppo_actor_near_the_labels():
    """With bc_steps, each rollout's end steps the actor mean towards the labels: from the
    same start and seed, the actor ends closer to labels it started 0.3 from than PPO alone
    leaves it; without a data set the option is refused in one line."""
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")
    from mjchar.learn.collect import LearnSetup, make_env
    from mjchar.learn.dagger import LearnOptions
    from mjchar.learn.finetune import FinetuneOptions, Finetuner
    from mjchar.learn.train import LearnError

    setup = LearnSetup(clip="walk", loop=True)
    env = make_env(setup)
    n_in, nu = env.observation_space.shape[0], env.action_space.shape[0]
    X = np.array([env.reset(seed=i)[0] for i in range(64)])
    env.close()
    net = _random_mlp(n_in, nu, hidden=(32, 16), scale=0.1)
    Y = net(X) + 0.3
    losses = {}
    for bc in (0, 50):
        ft = FinetuneOptions(critic_warmup=0, envs=1, n_steps=64, lr=1e-3, bc_steps=bc,
                             bc_batch=32)
        tuner = Finetuner(setup, net, LearnOptions(), ft, data=(X, Y))
        tuner.train(64)
        losses[bc] = float(np.mean((tuner.mlp()(X) - Y) ** 2))
        tuner.close()
    assert losses[50] < 0.5 * losses[0] and losses[0] > 0.05
    with pytest.raises(LearnError, match="bc_steps needs"):
        Finetuner(setup, net, LearnOptions(), FinetuneOptions(critic_warmup=0, envs=1,
                                                               n_steps=64, bc_steps=4))
    with pytest.raises(LearnError, match="curriculum_start 0 "):
        Finetuner(setup, net, LearnOptions(), FinetuneOptions(envs=1, curriculum_start=0.0))


@pytest.mark.slow
def test_a_learn_run_fine_tunes_with_ppo_after_dagger_and_resumes(tmp_path):
    """With rl_share, the budget's second part is PPO from the best distilled network: the
    curve's rows are DAgger's then PPO's (steps growing), the PPO model is kept, and --resume
    continues fine-tuning (no more labels)."""
    pytest.importorskip("stable_baselines3", reason="needs the rl extra")
    from mjchar.learn.collect import LearnSetup
    from mjchar.learn.dagger import LearnOptions, learn
    from mjchar.learn.finetune import FinetuneOptions

    setup = LearnSetup(clip="walk", loop=True, label_samples=8)
    out = tmp_path / "walk.npz"
    opts = LearnOptions(minutes=0.5, workers=2, episodes=2, episode_seconds=1.0,
                        eval_phases=2, eval_seconds=2.0, max_steps=300, rl_share=0.5,
                        rl_chunk=512, finetune=FinetuneOptions(critic_warmup=256, n_steps=256,
                                                               envs=1))
    first = learn(setup, out, opts)
    rows = json.loads((tmp_path / "walk.curve.json").read_text())
    stages = [r["stage"] for r in rows]
    assert stages[0] == "dagger" and stages[-1] == "rl"
    assert stages == sorted(stages)  # ("dagger" < "rl"): every DAgger row before the first PPO row
    steps = [r["rl_steps"] for r in rows if r["stage"] == "rl"]
    assert steps == sorted(steps) and steps[0] > 0
    assert (tmp_path / "walk.ppo.zip").is_file() and first["stage"] == "rl"
    written = [r for r in rows if r["written"]][-1]
    assert load_policy(out).meta["training"]["iteration"] == written["iteration"]
    again = learn(setup, out, dataclasses.replace(opts, minutes=0.1), resume=True)
    more = json.loads((tmp_path / "walk.curve.json").read_text())[len(rows):]
    assert more and all(r["stage"] == "rl" for r in more)
    assert more[0]["rl_steps"] > steps[-1] and again["labels"] == first["labels"]


def test_the_bundled_policy_describes_itself():
    from mjchar.controllers.learned import bundled_policies, find_policy
    from mjchar.controllers.sampling.trajectory import model_fingerprint

    assert "walk60" in bundled_policies()
    p = find_policy("walk60")
    assert p.meta["clip"]["name"] == "walk60.bvh" and p.meta["clip"]["loop"] is True
    assert p.meta["model"]["fingerprint"] == model_fingerprint(Character().model)
    assert p.meta["env"]["n_substeps"] == 17 and p.meta["env"]["control_freq"] == \
        pytest.approx(30.0)
    assert p.clip_motion() is not None  # it carries its clip


@pytest.mark.claims
def test_the_bundled_policy_scores_above_the_zero_action_with_no_root_force():
    """docs/learning.md, "PPO from the distilled policy": the bundled walk60 policy's
    Imitation-v0 return (10 s episodes from the same random starts) is above plain PD's, and as
    a controller it pushes nothing on the root."""
    from mjchar.controllers.learned import find_policy
    from mjchar.learn.collect import LearnSetup, make_env
    from mjchar.perf.policy import loop

    policy = find_policy("walk60")
    env = make_env(LearnSetup(clip=policy.clip_motion(), loop=True), episode_seconds=10.0)

    def episode(seed: int, act) -> float:
        obs, _ = env.reset(seed=seed)
        total, done = 0.0, False
        while not done:
            obs, r, term, trunc, _ = env.step(act(obs))
            total, done = total + r, term or trunc
        return total

    zero = np.zeros(env.action_space.shape)
    learned = [episode(s, policy) for s in range(3)]
    plain = [episode(s, lambda o: zero) for s in range(3)]
    env.close()
    assert np.mean(learned) > 1.5 * np.mean(plain), (learned, plain)
    assert loop("walk60", duration=1.0)["root_force_max_N"] == 0.0


def _same_results(a, b):
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.obs, y.obs)
        np.testing.assert_array_equal(x.labels, y.labels)
        assert (x.steps, x.fell, x.tracking_error_m, x.episode_return) == (
            y.steps, y.fell, y.tracking_error_m, y.episode_return)


def test_ray_labelling_gives_the_local_pools_episodes():
    """The same labelled episodes (observations and MPC labels bit for bit) from Ray actors as
    from the local worker processes, in the jobs' order."""
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'mjchar[ray]')")
    from mjchar.learn.collect import Episode, LearnSetup
    from mjchar.learn.workers import episode_pool

    setup = LearnSetup(clip="walk", loop=True, label_samples=4)
    jobs = [Episode(seed=i, phase=i / 3, seconds=0.2, noise=0.1,
                    push=(0.05, 80.0, 0.0, 0.1) if i == 1 else None) for i in range(3)]
    with episode_pool(setup, 2) as pool:
        local = pool.map(jobs)
    started = not ray.is_initialized()
    with episode_pool(setup, 2, executor="ray") as pool:
        assert pool.parallelism == 2
        remote = pool.map(jobs)
    assert not (started and ray.is_initialized())  # a Ray instance it started is shut down
    assert all(len(r.labels) == 6 for r in local)
    _same_results(local, remote)


def test_an_episode_depends_only_on_its_job():
    """A collector gives a job the same episode (observations, MPC labels) whatever it ran
    before: the labeller restarts from the job's seed (its random stream and noise boost)."""
    from mjchar.learn.collect import Collector, Episode, LearnSetup

    col = Collector(LearnSetup(clip="walk", loop=True, label_samples=4))
    job = Episode(seed=5, phase=0.3, seconds=0.2, noise=0.1)
    first = col.run(job)
    col.run(Episode(seed=6, phase=0.7, seconds=0.3, noise=0.2))
    again = col.run(job)
    col.close()
    _same_results([first], [again])


def test_learn_refuses_a_ray_address_without_ray(tmp_path, capsys):
    assert main(["learn", "walk", "-o", str(tmp_path / "p.npz"), "--ray-address",
                 "127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--executor ray" in err, err


def test_learn_passes_its_episode_and_validation_options_on(tmp_path, monkeypatch):
    """The rates of disturbed training episodes and the disturbed validation set reach
    ``LearnOptions`` from the command line (the run itself is stubbed: no torch needed)."""
    import mjchar.learn.dagger as dagger
    import mjchar.learn.finetune as finetune
    import mjchar.learn.train as train

    seen = {}

    def fake_learn(setup, out, opts, **kw):
        seen["opts"] = opts
        return {"iteration": 0, "labels": 0, "outputs": {"curve": "c.png"}}

    monkeypatch.setattr(dagger, "learn", fake_learn)
    monkeypatch.setattr(train, "import_torch", lambda: None)
    monkeypatch.setattr(finetune, "import_sb3", lambda: None)
    out = str(tmp_path / "p.npz")
    assert main(["learn", "walk", "-o", out, "--json"]) == 0
    d, ref = seen["opts"], dagger.LearnOptions()  # the command's defaults are the library's
    fields = ("minutes", "seed", "episode_seconds", "noise", "rl_share", "perturb_rate",
              "push_rate", "eval_perturbed", "eval_pushes")
    assert [getattr(d, f) for f in fields] == [getattr(ref, f) for f in fields]
    assert main(["learn", "walk", "-o", out, "--json", "--perturb-rate", "0.5", "--push-rate",
                 "0.25", "--validate-perturbed", "4", "--validate-pushes", "8",
                 "--rl-share", "0.7"]) == 0
    o = seen["opts"]
    assert (o.perturb_rate, o.push_rate, o.eval_perturbed, o.eval_pushes, o.rl_share) == (
        0.5, 0.25, 4, 8, 0.7)
    with pytest.raises(SystemExit) as e:
        main(["learn", "walk", "-o", out, "--push-rate", "1.5"])
    assert e.value.code == 2


def test_the_curve_numbers_are_written_without_matplotlib(tmp_path, monkeypatch):
    """With matplotlib absent the learning curve's numbers are still written (the picture is
    not) and learning goes on: the curve is not a reason to stop an hour's run."""
    import sys

    from mjchar.learn.dagger import _save_curve

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib: ImportError
    files = {"numbers": tmp_path / "p.curve.json", "curve": tmp_path / "p.curve.png"}
    rows = [{"wall_s": 6.0, "eval_error_m": 0.05, "eval_fall_rate": 0.5}]
    _save_curve(files, rows)
    assert json.loads(files["numbers"].read_text()) == rows
    assert not files["curve"].exists()
