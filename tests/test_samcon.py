"""SAMCON, the saved-trajectory format and its open-loop replay.

The default run reconstructs half a second of the bundled walk with few samples (seconds); the
full reconstruction of the shared walk60 clip is a slow test (``-m slow``, minutes) and the
benchmark ``python -m mjchar.perf.samcon`` reports its numbers.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import run_command, run_json, shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.assets import motion_path
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.scenarios import simulate
from mjchar.controllers.sampling.executors import LocalExecutor
from mjchar.controllers.sampling.rollout import RolloutRequest
from mjchar.controllers.sampling.samcon import (
    Samcon,
    SamconError,
    SamconOptions,
    select_diverse,
    slice_layout,
)
from mjchar.controllers.sampling.tracking import (
    CostWeights,
    TrackingCost,
    TrackingError,
    sampling_widths,
)
from mjchar.controllers.sampling.trajectory import (
    ReplayController,
    Trajectory,
    TrajectoryError,
    load_trajectory,
    replay,
)


@pytest.fixture(scope="module")
def short_run(walk_ref, executor):
    """SAMCON on the first 0.5 s of the bundled walk, few samples."""
    opt = SamconOptions(samples=64, saved=16, duration=0.5, seed=3)
    with Samcon(walk_ref, options=opt, executor=executor, source_motion="walk.bvh") as s:
        return s, s.run(progress=False)


# -- pieces ----------------------------------------------------------------------------------------
def test_select_diverse_keeps_the_best_and_caps_children():
    rng = np.random.default_rng(0)
    cost = np.arange(100, dtype=float)
    parent = np.zeros(100, dtype=int)
    parent[50:] = np.arange(1, 51)  # the 50 best samples share one parent
    sel = select_diverse(cost, parent, 20, rng, max_children=3)
    assert len(sel) == 20 and len(set(sel.tolist())) == 20
    assert sel[0] == 0  # the best sample is always kept
    assert np.all(np.diff(cost[sel]) >= 0)  # sorted by cost
    assert np.sum(parent[sel] == 0) == 3  # the crowded parent gives at most 3 children
    # fallen (infinite cost) samples only when nothing else is left
    cost2 = np.where(np.arange(10) < 4, np.inf, np.arange(10.0))
    sel2 = select_diverse(cost2, np.arange(10), 8, rng)
    assert np.isfinite(cost2[sel2[:6]]).all() and len(sel2) == 8


def test_sampling_widths_follow_roles(character):
    w = sampling_widths(character)
    names = [character.dof_names[d] for d in character.actuator_dof]
    assert w[names.index("lHip_y")] > w[names.index("lToeJoint_y")] > 0
    w2 = sampling_widths(character, {"knee": 0.7}, scale=2.0)
    assert w2[names.index("rKnee_y")] == pytest.approx(1.4)
    with pytest.raises(TrackingError, match="unknown joint role"):
        sampling_widths(character, {"tail": 0.1})


def test_slice_layout_covers_the_clip():
    s = slice_layout(1.03, 0.1, 0.02)
    assert s[0] == (0, 5) and s[-1][1] == 52
    assert all(b > a for a, b in s) and all(s[i][1] == s[i + 1][0] for i in range(len(s) - 1))


class _Labelled:
    """``walk_ref`` with its contact labels replaced (records the thresholds asked for)."""

    def __init__(self, ref, labels=None):
        self.ref, self.labels, self.asked = ref, labels, []
        self.frame_time, self.times = ref.frame_time, ref.times

    def qpos(self, t):
        return self.ref.qpos(t)

    def qvel(self, t):
        return self.ref.qvel(t)

    def foot_contacts(self, t, height=0.1, speed=0.5):
        self.asked.append((height, speed))
        if self.labels is None:
            return self.ref.foot_contacts(t, height, speed)
        return self.labels(np.asarray(t))


def test_stance_labels_scale_with_the_body(character, walk_ref):
    """The stance feet of the inverse dynamics use the contact floor's Froude-scaled thresholds
    (a fraction of the clip's mean root height, and of sqrt(g x that height))."""
    from mjchar.bvh.reference.foot_points import CONTACT_HEIGHT, CONTACT_SPEED
    from mjchar.controllers.sampling.tracking import stance_labels

    ref = _Labelled(walk_ref)
    t = np.arange(0.0, 0.5, 0.02)
    labels = stance_labels(character, ref, t)
    h = float(np.mean(walk_ref.qpos(walk_ref.times)[:, character.root_qpos[2]]))
    assert ref.asked == [(pytest.approx(CONTACT_HEIGHT * h),
                          pytest.approx(CONTACT_SPEED * np.sqrt(9.81 * h)))]
    assert labels.shape == (len(t), 2) and labels.any(axis=1).all()


def test_stance_labels_on_the_contact_floor_are_feet_on_the_floor(character):
    """On a contact-floor reference of real mocap, a labelled foot touches the floor (within
    GROUNDED_STANCE_HEIGHT of the root height); the raw-mocap height would label feet that
    are centimetres up (walk60: a descending swing foot up to 5 cm above the floor)."""
    from mjchar.controllers.sampling.tracking import GROUNDED_STANCE_HEIGHT, stance_labels

    ref = ReferenceMotion(character.model, bvh.load(shared_clip("walk60.bvh")),
                          info=character.info)
    assert ref.floor == "contact"
    t = np.arange(0.0, ref.duration, 0.01)
    frame = np.minimum(np.round(t / ref.frame_time).astype(int), ref.n_frames - 1)
    sole = np.stack([ref._foot_pts[side][frame][..., 2].min(axis=1)
                     for side in ("left", "right")], axis=1)  # (N, 2) lowest foot point
    h = float(np.mean(ref.qpos(ref.times)[:, character.root_qpos[2]]))
    grounded = stance_labels(character, ref, t)
    assert grounded.any(axis=1).mean() > 0.9
    assert sole[grounded].max() <= GROUNDED_STANCE_HEIGHT * h
    raw = stance_labels(character, ref, t, height=0.12)
    assert sole[raw].max() > 0.03


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), "low"])
def test_stance_labels_refuse_a_bad_height(character, walk_ref, bad):
    from mjchar.controllers.sampling.tracking import stance_labels

    with pytest.raises(TrackingError, match="stance height"):
        stance_labels(character, walk_ref, np.zeros(1), height=bad)


def test_inverse_dynamics_without_labels_loads_the_lowest_foot(character, walk_ref):
    """Where no foot is labelled, the root wrench goes to the foot whose sole is lowest (not
    half to a swing foot in the air): the same targets as labelling that foot."""
    import mujoco

    from mjchar.controllers.sampling.tracking import inverse_dynamics_targets

    t = np.arange(0.0, 0.6, 0.02) + 0.01
    m, d = character.model, mujoco.MjData(character.model)
    feet = [character.site_id("left_foot"), character.site_id("right_foot")]
    lowest = np.zeros((len(t), 2), dtype=bool)
    for n, q in enumerate(walk_ref.qpos(t)):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        lowest[n, int(d.site_xpos[feet[1], 2] < d.site_xpos[feet[0], 2])] = True
    none = inverse_dynamics_targets(
        character, _Labelled(walk_ref, lambda x: np.zeros(x.shape + (2,), bool)), t)
    low = inverse_dynamics_targets(
        character, _Labelled(walk_ref, lambda x: lowest[np.searchsorted(t, x)]), t)
    np.testing.assert_allclose(none, low, atol=1e-9)
    # unlabelled="both" (the MPC's choice) is the same as labelling both feet, and differs
    both = inverse_dynamics_targets(
        character, _Labelled(walk_ref, lambda x: np.zeros(x.shape + (2,), bool)), t,
        unlabelled="both")
    two = inverse_dynamics_targets(
        character, _Labelled(walk_ref, lambda x: np.ones(x.shape + (2,), bool)), t)
    np.testing.assert_allclose(both, two, atol=1e-9)
    assert np.abs(both - low).max() > 0.01


def test_inverse_dynamics_does_not_read_a_clip_start_as_a_jump_from_rest(character):
    """Near the ends of a non-cyclic clip the accelerations are one-sided differences inside the
    clip: differencing across the start (where the reference's velocity is zero) would read the
    walk's 1.05 m/s as a 30 m/s^2 forward acceleration of the root."""
    from mjchar.controllers.sampling.tracking import _reference_acceleration

    ref = ReferenceMotion(character.model, bvh.load(motion_path("walk")), info=character.info,
                          cyclic=False)
    h, T = ref.frame_time, ref.duration
    inner = _reference_acceleration(ref, np.arange(0.1, T - 0.1, 0.01), h)
    ends = _reference_acceleration(ref, np.array([0.0, 0.01, T - 0.01, T]), h)
    limit = np.abs(inner[:, :3]).max(axis=0) + 1e-6
    assert (np.abs(ends[:, :3]) <= limit).all(), (ends[:, :3], limit)
    assert np.abs(_reference_acceleration(ref, np.array([-0.5, T + 0.5]), h)).max() == 0.0
    # a cyclic clip differences across its seam, as before
    loop = ReferenceMotion(character.model, bvh.load(motion_path("walk")), info=character.info)
    t = np.array([0.0, 0.01, T - 0.01])
    np.testing.assert_allclose(_reference_acceleration(loop, t, h),
                               (loop.qvel(t + h) - loop.qvel(t - h)) / (2 * h))


def test_inverse_dynamics_refuses_an_unknown_fallback(character, walk_ref):
    from mjchar.controllers.sampling.tracking import TrackingError, inverse_dynamics_targets

    with pytest.raises(TrackingError, match="unlabelled must be 'lowest' or 'both', not 'none'"):
        inverse_dynamics_targets(character, walk_ref, np.array([0.1]), unlabelled="none")


def test_inverse_dynamics_targets_hold_the_standing_pose_better_than_the_pose(character):
    """Static inverse dynamics adds the gravity compensation plain PD lacks: held open loop
    (no root force), the joints stay much closer to the pose (arms out in the T-pose sag)."""
    from mjchar.controllers.sampling.trajopt import (
        standing_targets,  # inverse dynamics of the standing pose
    )

    q, u_id = standing_targets(character)
    u_raw = q[character.actuator_qpos]
    err = {}
    for name, u in (("id", u_id), ("raw", u_raw)):
        tr = Trajectory.for_model(character.model, np.tile(u, (100, 1)), 0.02, q,
                                  np.zeros(character.nv))
        ch = Character()
        r = simulate(ch, ReplayController(tr), duration=2.0, scenario="hold", qpos=q,
                     control_dt=0.02)
        assert not r.fell
        e = ch.state.qpos[character.actuator_qpos] - q[character.actuator_qpos]
        err[name] = float(np.sqrt(np.mean(e ** 2)))
    assert err["id"] < 0.5 * err["raw"]


def test_cost_is_zero_on_the_reference_and_grows_with_error(character, walk_ref):
    from mjchar.bvh.bundled.assets import humanoid_path
    from mjchar.controllers.sampling.tracking import reference_features, tracking_rollout_model

    rm = tracking_rollout_model(humanoid_path(), character)
    feats = reference_features(rm, walk_ref, [0.3])
    cost = TrackingCost(character, CostWeights(joints=100.0), site_names=rm.site_names)
    q = feats.qpos.copy()
    c0 = cost(q, feats.qvel, feats.com, feats.com_vel, feats.sites, feats, 0)
    assert c0[0] == pytest.approx(0.0, abs=1e-9)
    q2 = q.copy()
    q2[0, character.actuator_qpos[0]] += 0.3
    c1 = cost(q2, feats.qvel, feats.com, feats.com_vel, feats.sites, feats, 0)
    assert c1[0] > 0.5


# -- SAMCON end to end (short) ------------------------------------------------------------------
def test_short_samcon_replay_stands_tracks_and_reproduces_the_optimised_path(short_run,
                                                                            executor):
    s, res = short_run
    tr = res.trajectory
    assert tr.n_controls == 25 and tr.targets.shape == (25, s.character.nu)
    assert not res.fell and np.isfinite(res.total_cost)
    assert res.samples_simulated == 64 * 5
    r1 = replay(tr)
    assert not r1.fell and r1.root_force_mean_N == 0.0
    assert r1.tracking_error_m < 0.05
    assert r1.extra["final_root_error_m"] < 0.1
    # deterministic replay
    r2 = replay(tr)
    assert r2.tracking_error_m == r1.tracking_error_m
    assert r2.extra["final_root_error_m"] == r1.extra["final_root_error_m"]
    # the Character replay lands exactly where the chain of SAMCON rollouts did
    state = s.state0
    for a, b in s.slices:
        out = executor.evaluate(RolloutRequest(s.rmodel, state, tr.targets[None, a:b], s.k))
        state = out.final_states[0]
    ch = Character()
    simulate(ch, ReplayController(tr), duration=tr.duration, scenario="replay",
             qpos=tr.initial_qpos, qvel=tr.initial_qvel, control_dt=tr.control_dt)
    qs = s.rmodel.model.nq
    np.testing.assert_array_equal(ch.state.qpos, state[1:1 + qs])


def test_samcon_is_deterministic_for_a_seed(walk_ref, executor, short_run):
    _, res = short_run
    opt = SamconOptions(samples=64, saved=16, duration=0.5, seed=3)
    with Samcon(walk_ref, options=opt, executor=executor) as s:
        again = s.run(progress=False)
    np.testing.assert_array_equal(again.trajectory.targets, res.trajectory.targets)


def test_samcon_options_window_and_adapt_run(walk_ref, executor):
    opt = SamconOptions(samples=32, saved=8, duration=0.3, window=2, adapt=True, iterations=2,
                        distribution="gaussian", seed=1)
    with Samcon(walk_ref, options=opt, executor=executor) as s:
        res = s.run(progress=False)
    assert len(res.history) == 2 and len(res.history[0]) == 3
    assert not replay(res.trajectory).fell


@pytest.mark.parametrize("bad,match", [
    ({"saved": 100, "samples": 10}, "cannot exceed"),
    ({"control_dt": 0.003}, "whole number"),
    ({"distribution": "cauchy"}, "distribution"),
    ({"samples": 0}, "positive integer"),
])
def test_bad_options_raise(walk_ref, bad, match):
    with pytest.raises(SamconError, match=match):
        Samcon(walk_ref, options=SamconOptions(**bad), executor=LocalExecutor(1))


def test_a_duration_past_the_end_of_a_clip_is_refused(character):
    """A clip that does not loop cannot be reconstructed past its end (it used to hold the last
    frame: a 2 s SAMCON on a 1 s clip tracked a figure frozen mid-stride, 27-33 cm error)."""
    from mjchar import bvh
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.bvh.reference.reference_motion import ReferenceMotion

    ref = ReferenceMotion(character.model, bvh.load(motion_path("walk")), info=character.info,
                          cyclic=False)
    with pytest.raises(SamconError, match=r"past the end of the clip \(\d+\.\d+ s\): a "
                                          r"duration of at most"):
        Samcon(ref, options=SamconOptions(duration=ref.duration + 0.5),
               executor=LocalExecutor(1))


# -- the file format ---------------------------------------------------------------------------
def test_trajectory_file_round_trip(short_run, tmp_path):
    _, res = short_run
    path = res.trajectory.save(tmp_path / "walk.traj")
    assert path.name == "walk.traj"  # no suffix added
    t = load_trajectory(path)
    np.testing.assert_array_equal(t.targets, res.trajectory.targets)
    assert t.control_dt == res.trajectory.control_dt and t.timestep == 0.002
    assert t.model_name == "humanoid" and t.source_motion == "walk.bvh"
    assert t.metadata["method"] == "samcon" and t.metadata["options"]["samples"] == 64
    np.testing.assert_array_equal(t.warmstart_resets, [0, 5, 10, 15, 20])
    assert replay(t).tracking_error_m == replay(res.trajectory).tracking_error_m


def test_files_that_are_not_trajectories_are_refused(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("hello")
    other = tmp_path / "other.npz"
    np.savez(other, a=np.zeros(3))
    for path, match in ((text, "not a saved mjchar trajectory"),
                        (other, "not a saved mjchar trajectory"),
                        (tmp_path / "missing.npz", "no such trajectory file")):
        with pytest.raises(TrajectoryError, match=match) as e:
            load_trajectory(path)
        assert "\n" not in str(e.value)


def test_trajectory_for_another_model_or_time_step_is_refused(short_run):
    _, res = short_run
    tr = copy.deepcopy(res.trajectory)
    tr.model_hash = "0" * 64
    with pytest.raises(TrajectoryError, match="another model"):
        replay(tr)
    ch = Character(timestep=0.001)
    with pytest.raises(TrajectoryError, match="time step"):
        ReplayController(res.trajectory).reset(ch)


def test_fingerprint_covers_contact_and_solver_settings():
    """Version 2 of the fingerprint sees what the first left out (the foot contacts' condim, the
    friction cone's impratio, the solver's iterations), and the time step still not."""
    from mjchar.controllers.sampling.trajectory import model_fingerprint

    base = Character().model
    fp, fp1 = model_fingerprint(base), model_fingerprint(base, version=1)
    for edit in (lambda m: m.geom_condim.__setitem__(0, 4),
                 lambda m: setattr(m.opt, "impratio", 10.0),
                 lambda m: setattr(m.opt, "iterations", 50),
                 lambda m: m.jnt_stiffness.__setitem__(1, 5.0)):
        m = copy.deepcopy(base)
        edit(m)
        assert model_fingerprint(m) != fp
        assert model_fingerprint(m, version=1) == fp1  # what version 1 missed
    m = copy.deepcopy(base)
    m.opt.timestep = 0.001
    assert model_fingerprint(m) == fp
    with pytest.raises(ValueError, match="unknown version"):
        model_fingerprint(base, version=3)


def test_trajectory_saved_with_the_first_fingerprint_still_replays(short_run):
    """A file saved before version 2 carries the version-1 digest: accepted on a model whose
    version-1 physics match, with a warning to save it again."""
    from mjchar.controllers.sampling.trajectory import model_fingerprint

    _, res = short_run
    tr = copy.deepcopy(res.trajectory)
    tr.model_hash = model_fingerprint(Character().model, version=1)
    with pytest.warns(UserWarning, match="earlier mjchar.*Save it again"):
        ReplayController(tr).reset(Character())


def test_cli_run_replay_plays_a_saved_trajectory(short_run, tmp_path, capsys):
    _, res = short_run
    path = res.trajectory.save(tmp_path / "t.npz")
    out = run_json(["run", "replay", str(path), "--json"], capsys)
    assert out["controller"] == "replay" and out["fell"] is False
    assert out["trajectory"] == str(path)
    with pytest.raises(MjcharError, match="needs the trajectory file"):
        run_command(["run", "replay"])


# -- the CLI ---------------------------------------------------------------------------------------
def test_cli_samcon_writes_a_replayable_trajectory(tmp_path, capsys):
    out = tmp_path / "walk.npz"
    info = run_json(["samcon", str(motion_path("walk")), "-o", str(out), "--samples", "32",
                     "--saved", "8", "--duration", "0.3", "--iterations", "1", "--threads", "2",
                     "--weight", "root=20", "--json"], capsys)
    # the default sliding window of 2: slices 1 and 2 simulate two slices per sample, the last one
    assert info["replay"]["fell"] is False and info["samples_simulated"] == 32 * (2 + 2 + 1)
    assert not replay(out).fell
    saved = load_trajectory(out).metadata["options"]
    assert saved["weights"]["root"] == 20.0 and saved["adapt"] is True and saved["window"] == 2


def test_cli_errors_are_one_line(tmp_path):
    from mjchar.controllers.sampling.executors import RayConnectionError, RayUnavailableError

    bad = tmp_path / "tiny.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition "
                   "Zposition Zrotation Xrotation Yrotation\n JOINT Head\n {\n  OFFSET 0 1 0\n"
                   "  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 1 0"
                   "\n  }\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n0 0 0 0 0 0 0 0 0\n"
                   "0 0 0 0 0 0 0 0 0\n")
    with pytest.raises(MjcharError, match="cannot follow") as e:
        run_command(["samcon", str(bad), "-o", str(tmp_path / "o.npz")])
    assert "\n" not in str(e.value)
    with pytest.raises((RayConnectionError, RayUnavailableError)) as e:
        run_command(["samcon", str(motion_path("walk")), "-o", str(tmp_path / "o.npz"),
              "--executor", "ray", "--ray-address", "127.0.0.1:9"])
    assert "\n" not in str(e.value)
    with pytest.raises(MjcharError, match="does not exist"):
        run_command(["samcon", str(motion_path("walk")), "-o", str(tmp_path / "no" / "o.npz")])


# -- the long reconstruction ---------------------------------------------------------------------
@pytest.mark.slow
def test_samcon_reconstructs_walk60(character):
    """walk60 (~3 s) with no root force: the open-loop replay never falls, tracks within 5 cm
    and ends within 15 cm of the clip's root (minutes; see ``python -m mjchar.perf.samcon``)."""
    from mjchar.controllers.sampling.samcon import RECONSTRUCTION_OPTIONS

    path = shared_clip("walk60.bvh")
    ref = ReferenceMotion(character.model, bvh.load(path), info=character.info)
    with Samcon(ref, options=SamconOptions(**RECONSTRUCTION_OPTIONS)) as s:
        res = s.run(progress=False)
    r = replay(res.trajectory)
    assert not r.fell
    assert r.tracking_error_m < 0.05
    assert r.extra["final_root_error_m"] < 0.15
    assert replay(res.trajectory).tracking_error_m == r.tracking_error_m
