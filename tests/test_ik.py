"""Inverse kinematics (mjchar.bvh.kinematics.ik): CCD, Jacobian transpose and damped least squares.

Every scenario runs on two skeletons: a synthetic humanoid built here (with a zero-length bone,
so IK is covered without ../shared) and the shared walk60.bvh clip (skipped when absent).
Distances are measured with bvh.forward_kinematics / bvh.end_site_positions, independently of
the IK module's own kinematics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from conftest import shared_clip
from hypothesis import given, settings
from hypothesis import strategies as st

from mjchar import bvh
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.kinematics.ik import (
    METHODS,
    Effector,
    IKError,
    IKProblem,
    Pose,
    solve,
    solve_ccd,
    solve_dls,
    solve_frames,
)
from mjchar.bvh.rotations import quat_from_rotvec

N_FRAMES = 20
MAX_ANGLE = 0.5
# generous iteration budgets for the first-order methods (DLS gets at most 50)
BUDGET = {"dls": 50, "ccd": 500, "jacobian_transpose": 3000}


@dataclass
class Case:
    """A motion and the names the scenarios need."""

    motion: bvh.Motion
    hands: dict[str, str]  # hand end site -> its shoulder joint
    feet: dict[str, str]  # foot end site -> its hip joint
    arm: list[str]  # joints of the left arm, shoulder first (moved for the beyond-reach test)
    elbow: str


def synthetic_motion(n_frames: int = 30, seed: int = 0) -> bvh.Motion:
    """A small humanoid in metres (Y up) with random poses; lTwist is a zero-length bone."""
    joints = [  # name, parent, offset
        ("hips", None, (0.0, 0.95, 0.0)),
        ("spine", "hips", (0.0, 0.12, 0.0)),
        ("chest", "spine", (0.0, 0.2, 0.0)),
        ("lShoulder", "chest", (0.18, 0.15, 0.0)),
        ("lTwist", "lShoulder", (0.0, 0.0, 0.0)),
        ("lElbow", "lTwist", (0.28, 0.0, 0.0)),
        ("lWrist", "lElbow", (0.25, 0.0, 0.0)),
        ("rShoulder", "chest", (-0.18, 0.15, 0.0)),
        ("rElbow", "rShoulder", (-0.28, 0.0, 0.0)),
        ("rWrist", "rElbow", (-0.25, 0.0, 0.0)),
        ("neck", "chest", (0.0, 0.2, 0.0)),
        ("lHip", "hips", (0.1, -0.05, 0.0)),
        ("lKnee", "lHip", (0.0, -0.42, 0.0)),
        ("lAnkle", "lKnee", (0.0, -0.4, 0.0)),
        ("rHip", "hips", (-0.1, -0.05, 0.0)),
        ("rKnee", "rHip", (0.0, -0.42, 0.0)),
        ("rAnkle", "rKnee", (0.0, -0.4, 0.0)),
    ]
    names = [j[0] for j in joints]
    parents = [-1 if p is None else names.index(p) for _, p, _ in joints]
    rot = ("Zrotation", "Xrotation", "Yrotation")
    channels = [("Xposition", "Yposition", "Zposition", *rot)] + [rot] * (len(names) - 1)
    ends = {"lWrist": (0.08, 0.0, 0.0), "rWrist": (-0.08, 0.0, 0.0), "neck": (0.0, 0.15, 0.0),
            "lAnkle": (0.0, -0.05, 0.12), "rAnkle": (0.0, -0.05, 0.12)}
    sk = Skeleton(names, parents, [j[2] for j in joints], channels,
                  [names.index(n) for n in ends], list(ends.values()))
    rng = np.random.default_rng(seed)
    rotvec = rng.normal(size=(n_frames, len(names), 3))
    rotvec *= rng.uniform(0.0, 0.6, size=(n_frames, len(names), 1)) / np.linalg.norm(
        rotvec, axis=-1, keepdims=True)
    rotvec[:, 0] *= 0.3  # mostly upright
    pos = np.broadcast_to(sk.offsets, (n_frames, len(names), 3)).copy()
    pos[:, 0] += rng.normal(scale=0.05, size=(n_frames, 3))
    return bvh.Motion(sk, 1 / 30, pos, quat_from_rotvec(rotvec))


@pytest.fixture(params=["synthetic", "walk60"])
def case(request) -> Case:
    if request.param == "synthetic":
        return Case(synthetic_motion(), {"lWrist_end": "lShoulder", "rWrist_end": "rShoulder"},
                    {"lAnkle_end": "lHip", "rAnkle_end": "rHip"},
                    ["lShoulder", "lTwist", "lElbow", "lWrist"], "lElbow")
    motion = bvh.load(shared_clip("walk60.bvh"))
    return Case(motion, {"lWrist_end": "lShoulder", "rWrist_end": "rShoulder"},
                {"lToeJoint_end": "lHip", "rToeJoint_end": "rHip"},
                ["lShoulder", "lElbow", "lWrist"], "lElbow")


# -- measuring, independently of mjchar.bvh.kinematics.ik
# ----------------------------------------------------------
def joint_positions(pose: Pose) -> np.ndarray:
    return bvh.forward_kinematics(pose.to_motion()).positions[0]


def site_position(pose: Pose, name: str) -> np.ndarray:
    m = pose.to_motion()
    if name in m.skeleton.names:
        return bvh.forward_kinematics(m).positions[0, m.skeleton.index(name)]
    return bvh.end_site_positions(m)[0, m.skeleton.end_site_names.index(name)]


def reach(sk: Skeleton, site: str, base: str) -> float:
    """Sum of bone lengths from joint ``base`` down to end site ``site``."""
    s = sk.end_site_names.index(site)
    total = float(np.linalg.norm(sk.end_site_offsets[s]))
    j = int(sk.end_site_parents[s])
    while j != sk.index(base):
        total += float(np.linalg.norm(sk.offsets[j]))
        j = int(sk.parents[j])
    return total


def rotation_angles(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Angle (rad) between two arrays of unit quaternions, ``(J,)``."""
    dot = np.abs(np.sum(q0 * q1, axis=-1))
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


def moved_targets(pose: Pose, sites: dict[str, str], rng: np.random.Generator,
                  max_move: float = 0.2) -> dict[str, np.ndarray]:
    """Each site moved by up to ``max_move`` in a random direction, within 0.9 of its reach."""
    sk = pose.skeleton
    pos = joint_positions(pose)
    out = {}
    for site, base in sites.items():
        start, pivot = site_position(pose, site), pos[sk.index(base)]
        limit = 0.9 * reach(sk, site, base)
        for _ in range(1000):
            d = rng.normal(size=3)
            target = start + rng.uniform(0.0, max_move) * d / np.linalg.norm(d)
            if np.linalg.norm(target - pivot) < limit:
                break
        else:
            raise AssertionError(f"no reachable target found for {site}")
        out[site] = target
    return out


def scenarios(case: Case, which: str, seed: int = 105):
    """``N_FRAMES`` (pose, targets) pairs from random frames, fixed seed."""
    rng = np.random.default_rng(seed)
    frames = rng.choice(case.motion.n_frames, N_FRAMES, replace=False)
    sites = {next(iter(case.hands)): case.hands[next(iter(case.hands))]}
    if which == "all":
        sites = {**case.hands, **case.feet}
    for f in frames:
        pose = Pose.from_motion(case.motion, int(f))
        yield pose, moved_targets(pose, sites, rng)


def final_distances(pose: Pose, targets: dict[str, np.ndarray]) -> np.ndarray:
    return np.array([np.linalg.norm(site_position(pose, n) - t) for n, t in targets.items()])


# -- pose representation -------------------------------------------------------------------------
def test_pose_round_trips_a_motion_frame_and_matches_fk(case):
    m = case.motion
    pose = Pose.from_motion(m, 7)
    one = pose.to_motion()
    np.testing.assert_allclose(one.local_positions[0], m.local_positions[7])
    np.testing.assert_allclose(one.rotations[0], m.rotations[7])
    assert one.frame_time == m.frame_time
    pos, orient = pose.forward_kinematics()
    fk = bvh.forward_kinematics(m[[7]])
    np.testing.assert_allclose(pos, fk.positions[0], atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(orient * fk.orientations[0], axis=-1)), 1.0,
                               atol=1e-12)
    np.testing.assert_allclose(pose.end_site_positions(), bvh.end_site_positions(m[[7]])[0],
                               atol=1e-12)
    out = m.copy()
    Pose.from_motion(m, 3).write_to(out, 9)
    np.testing.assert_allclose(out.rotations[9], m.rotations[3])
    np.testing.assert_allclose(out.local_positions[9], m.local_positions[3])
    np.testing.assert_allclose(out.rotations[8], m.rotations[8])


def test_jacobian_matches_finite_differences():
    m = synthetic_motion()
    pose = Pose.from_motion(m, 4)
    prob = IKProblem(m.skeleton, {"lWrist_end": np.zeros(3), "rAnkle_end": np.zeros(3),
                                  "lElbow": np.zeros(3)}, root_may_move=True)
    state = prob.evaluate(pose)
    jac = prob.jacobian(state)
    assert jac.shape == (9, prob.n_dof)
    h = 1e-6
    numeric = np.empty_like(jac)
    for c in range(prob.n_dof):
        step = np.zeros(prob.n_dof)
        step[c] = h
        moved = prob.evaluate(prob.apply(state, step)).effectors
        numeric[:, c] = (moved - state.effectors).reshape(-1) / h
    np.testing.assert_allclose(jac, numeric, atol=1e-5)


def test_default_movable_joints_are_the_chains_below_the_root():
    sk = synthetic_motion().skeleton
    prob = IKProblem(sk, {"lWrist_end": np.zeros(3), "rKnee": np.zeros(3)})
    assert prob.dof_joint_names == ["spine", "chest", "lShoulder", "lTwist", "lElbow", "lWrist",
                                    "rHip"]
    assert not prob.translate_root
    free = IKProblem(sk, {"lWrist_end": np.zeros(3)}, root_may_move=True, locked=["chest"])
    assert free.dof_joint_names[0] == "hips" and "chest" not in free.dof_joint_names
    assert free.translate_root


# -- acceptance: reachable targets ---------------------------------------------------------------
@pytest.mark.parametrize("which", ["single_hand", "all"])
def test_dls_reaches_targets_within_1mm_in_50_iterations(case, which):
    worst, most = 0.0, 0
    for pose, targets in scenarios(case, which):
        result = solve_dls(IKProblem(pose.skeleton, targets), pose, max_iterations=50)
        dist = final_distances(result.pose, targets)
        assert result.converged
        assert np.all(dist < 1e-3), dist
        assert result.iterations <= 50
        assert np.all(np.diff(result.errors) <= 0)
        worst, most = max(worst, dist.max()), max(most, result.iterations)
    print(f"dls {which}: worst {worst:.2e} m, most iterations {most}")


@pytest.mark.parametrize("method", ["ccd", "jacobian_transpose"])
@pytest.mark.parametrize("which", ["single_hand", "all"])
def test_first_order_methods_decrease_monotonically_below_1cm(case, method, which):
    worst, most = 0.0, 0
    for pose, targets in scenarios(case, which):
        result = solve(IKProblem(pose.skeleton, targets), pose, method,
                       max_iterations=BUDGET[method])
        dist = final_distances(result.pose, targets)
        assert len(result.errors) == result.iterations + 1
        assert np.all(np.diff(result.errors) <= 0), result.errors
        assert np.all(dist < 1e-2), dist
        assert result.max_joint_change.max(initial=0.0) <= MAX_ANGLE + 1e-9
        worst, most = max(worst, dist.max()), max(most, result.iterations)
    print(f"{method} {which}: worst {worst:.2e} m, most iterations {most}")


# -- acceptance: unreachable target --------------------------------------------------------------
@pytest.mark.parametrize("method", sorted(METHODS))
def test_target_beyond_reach_ends_at_closest_reachable_point(case, method):
    sk = case.motion.skeleton
    site, shoulder = next(iter(case.hands.items()))
    arm_reach = reach(sk, site, shoulder)
    rng = np.random.default_rng(11)
    worst = 0.0
    for f in rng.choice(case.motion.n_frames, 5, replace=False):
        pose = Pose.from_motion(case.motion, int(f))
        pivot = joint_positions(pose)[sk.index(shoulder)]
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        target = pivot + (arm_reach + 0.3) * direction
        closest = pivot + arm_reach * direction
        prob = IKProblem(sk, {site: target}, joints=case.arm)
        result = solve(prob, pose, method, max_iterations=BUDGET[method], record_poses=True)
        assert all(np.all(np.isfinite(p.rotations)) for p in result.poses)
        assert np.all(np.isfinite(result.errors))
        # per-iteration joint change: as recorded, and measured independently on the iterates
        assert len(result.max_joint_change) == result.iterations
        assert np.all(result.max_joint_change <= MAX_ANGLE + 1e-9)
        for a, b in zip(result.poses[:-1], result.poses[1:], strict=True):
            assert rotation_angles(a.rotations, b.rotations).max() <= MAX_ANGLE + 1e-9
        assert np.all(np.diff(result.errors) <= 0)
        hand = site_position(result.pose, site)
        assert np.all(np.isfinite(hand))
        assert np.linalg.norm(hand - closest) < 1e-2
        # only the arm moved
        still = [j for j in range(sk.n_joints) if sk.names[j] not in case.arm]
        np.testing.assert_allclose(result.pose.rotations[still], pose.rotations[still])
        worst = max(worst, float(np.linalg.norm(hand - closest)))
    print(f"{method} beyond reach: worst distance to closest reachable point {worst:.2e} m")


def test_max_angle_is_configurable():
    m = synthetic_motion()
    pose = Pose.from_motion(m, 2)
    target = site_position(pose, "lWrist_end") + np.array([0.0, 0.5, 0.3])
    for method in METHODS:
        prob = IKProblem(m.skeleton, {"lWrist_end": target}, max_angle=0.1)
        result = solve(prob, pose, method, max_iterations=40, record_poses=True)
        assert result.iterations > 0
        for a, b in zip(result.poses[:-1], result.poses[1:], strict=True):
            assert rotation_angles(a.rotations, b.rotations).max() <= 0.1 + 1e-9


# -- root may move ---------------------------------------------------------------------------------
@pytest.mark.parametrize("method", sorted(METHODS))
def test_foot_beyond_leg_reach_is_reached_when_the_root_may_move(case, method):
    sk = case.motion.skeleton
    site, hip = next(iter(case.feet.items()))
    pose = Pose.from_motion(case.motion, 12)
    pivot = joint_positions(pose)[sk.index(hip)]
    foot = site_position(pose, site)
    direction = (foot - pivot) / np.linalg.norm(foot - pivot)
    target = pivot + (reach(sk, site, hip) + 0.3) * direction
    fixed = solve(IKProblem(sk, {site: target}), pose, method, max_iterations=BUDGET[method])
    assert np.linalg.norm(site_position(fixed.pose, site) - target) > 0.25
    np.testing.assert_allclose(fixed.pose.root_position, pose.root_position)
    free = solve(IKProblem(sk, {site: target}, root_may_move=True), pose, method,
                 max_iterations=BUDGET[method])
    dist = np.linalg.norm(site_position(free.pose, site) - target)
    assert dist < (1e-3 if method == "dls" else 1e-2)
    assert free.converged
    assert np.linalg.norm(free.pose.root_position - pose.root_position) > 0.2


# -- per-joint weights ---------------------------------------------------------------------------
def test_joint_with_near_zero_weight_barely_moves_in_dls(case):
    sk = case.motion.skeleton
    site, shoulder = next(iter(case.hands.items()))
    elbow = sk.index(case.elbow)
    rng = np.random.default_rng(5)
    for f in rng.choice(case.motion.n_frames, 5, replace=False):
        pose = Pose.from_motion(case.motion, int(f))
        hand = site_position(pose, site)
        pivot = joint_positions(pose)[sk.index(shoulder)]
        target = hand + 0.15 * (pivot - hand) / np.linalg.norm(pivot - hand)  # bend the arm
        free = solve_dls(IKProblem(sk, {site: target}), pose)
        stiff = solve_dls(IKProblem(sk, {site: target}, joint_weights={case.elbow: 1e-6}), pose)
        assert free.converged and stiff.converged
        moved_free = rotation_angles(pose.rotations, free.pose.rotations)[elbow]
        moved_stiff = rotation_angles(pose.rotations, stiff.pose.rotations)[elbow]
        assert moved_free > 0.02
        assert moved_stiff < 1e-3 * moved_free


def test_locked_joint_does_not_move():
    m = synthetic_motion()
    pose = Pose.from_motion(m, 1)
    target = site_position(pose, "lWrist_end") + np.array([0.05, 0.1, 0.05])
    for method in METHODS:
        prob = IKProblem(m.skeleton, {"lWrist_end": target}, locked=["lElbow", "chest"])
        result = solve(prob, pose, method, max_iterations=BUDGET[method])
        for name in ("lElbow", "chest"):
            j = m.skeleton.index(name)
            np.testing.assert_array_equal(result.pose.rotations[j], pose.rotations[j])
        assert np.linalg.norm(site_position(result.pose, "lWrist_end") - target) < 1e-2


# -- degenerate inputs never give NaN ------------------------------------------------------------
@pytest.mark.parametrize("method", sorted(METHODS))
def test_degenerate_targets_never_produce_nan(method):
    m = synthetic_motion()
    sk = m.skeleton
    pose = Pose.from_motion(m, 5)
    pos = joint_positions(pose)
    cases = [
        {"lWrist_end": pos[sk.index("lShoulder")]},  # target at the chain's base joint
        {"lWrist_end": pos[sk.index("lWrist")]},  # target at the effector's own joint
        {"lTwist": pos[sk.index("lTwist")] + 0.1},  # effector at the end of a zero-length bone
        {"lWrist_end": pos[sk.index("lElbow")], "lWrist": pos[sk.index("lElbow")]},
        {"lWrist_end": np.array([1e6, -1e6, 1e6])},  # absurdly far
        {"lWrist_end": site_position(pose, "lWrist_end")},  # already there
    ]
    # the only movable joint sits exactly at the effector (zero-length bone): zero Jacobian
    stuck = IKProblem(sk, {"lTwist": pos[sk.index("lTwist")] + 0.1}, joints=["lShoulder"])
    result = solve(stuck, pose, method, max_iterations=100)
    assert result.iterations == 0 and not result.converged
    np.testing.assert_array_equal(result.pose.rotations, pose.rotations)
    for targets in cases:
        for root in (False, True):
            prob = IKProblem(sk, targets, root_may_move=root)
            result = solve(prob, pose, method, max_iterations=100)
            assert np.all(np.isfinite(result.pose.rotations))
            assert np.all(np.isfinite(result.pose.root_position))
            assert np.all(np.isfinite(result.errors))
            assert np.all(np.diff(result.errors) <= 0)
            assert np.all(result.max_joint_change <= MAX_ANGLE + 1e-9)
            np.testing.assert_allclose(np.linalg.norm(result.pose.rotations, axis=1), 1.0)
    already = solve(IKProblem(sk, cases[-1]), pose, method)
    assert already.converged and already.iterations == 0


def test_effector_weights_trade_off_conflicting_targets():
    m = synthetic_motion()
    pose = Pose.from_motion(m, 0)
    hand = site_position(pose, "lWrist_end")
    wrist = site_position(pose, "lWrist")
    # the wrist and its end site (0.08 m apart) are asked to be 0.3 m apart: no exact solution
    heavy_site = [Effector("lWrist_end", hand + [0.0, 0.1, 0.0], 4.0),
                  Effector("lWrist", wrist + [0.0, -0.2, 0.0], 1.0)]
    result = solve_dls(IKProblem(m.skeleton, heavy_site), pose)
    assert not result.converged
    assert result.distances[0] < 0.5 * result.distances[1]
    # a zero-weight effector is ignored, even when its target is unreachable
    ignored = [Effector("lWrist_end", hand + [0.0, 0.1, 0.0], 1.0),
               Effector("lWrist", wrist + [5.0, 0.0, 0.0], 0.0)]
    result = solve_dls(IKProblem(m.skeleton, ignored), pose)
    assert result.converged and result.distances[0] <= 1e-4


# -- bad input -----------------------------------------------------------------------------------
def test_bad_input_raises_ik_errors():
    m = synthetic_motion()
    sk = m.skeleton
    pose = Pose.from_motion(m, 0)
    with pytest.raises(IKError, match="unknown effector"):
        IKProblem(sk, {"nose": np.zeros(3)})
    with pytest.raises(IKError, match="NaN"):
        IKProblem(sk, {"lWrist_end": np.array([0.0, np.nan, 0.0])})
    with pytest.raises(IKError, match="no movable joint"):
        IKProblem(sk, {"lWrist_end": np.zeros(3)}, locked=sk.names)
    with pytest.raises(IKError, match="max_angle"):
        IKProblem(sk, {"lWrist_end": np.zeros(3)}, max_angle=0.0)
    with pytest.raises(IKError, match="unknown joint"):
        IKProblem(sk, {"lWrist_end": np.zeros(3)}, joint_weights={"tail": 1.0})
    with pytest.raises(IKError, match="unknown IK method"):
        solve(IKProblem(sk, {"lWrist_end": np.zeros(3)}), pose, "magic")
    with pytest.raises(IKError):
        Pose(sk, np.zeros(3), np.zeros((sk.n_joints, 4)))
    with pytest.raises(IKError, match="frame"):
        Pose.from_motion(m, m.n_frames)
    assert issubclass(IKError, bvh.MjcharError)


# -- many frames ---------------------------------------------------------------------------------
def test_solve_frames_moves_only_the_requested_frames(case):
    m = case.motion
    frames = np.array([1, 4, 9])
    site = next(iter(case.hands))
    start = bvh.end_site_positions(m[frames])[:, m.skeleton.end_site_names.index(site)]
    targets = start + np.array([0.05, -0.08, 0.06])
    before = m.rotations.copy()
    out = solve_frames(m, {site: targets}, "dls", frames=frames)
    np.testing.assert_array_equal(m.rotations, before)  # input untouched
    assert out.converged.all() and out.distances.max() < 1e-3
    got = bvh.end_site_positions(out.motion[frames])[:, m.skeleton.end_site_names.index(site)]
    np.testing.assert_allclose(got, targets, atol=1e-3)
    others = np.setdiff1d(np.arange(m.n_frames), frames)
    np.testing.assert_array_equal(out.motion.rotations[others], m.rotations[others])
    ccd = solve_frames(m, {site: targets}, "ccd", frames=frames,
                       solver_options={"max_iterations": 300}, max_angle=0.3)
    assert ccd.distances.max() < 1e-2


def test_ccd_single_effector_takes_the_minimal_rotation():
    """One effector, one joint: CCD turns about a x b (no twist about the bone)."""
    sk = Skeleton(["root", "a", "b"], [-1, 0, 1], [[0, 0, 0], [0, 0, 0], [1, 0, 0]],
                  [("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation",
                    "Zrotation"), ("Xrotation", "Yrotation", "Zrotation"),
                   ("Xrotation", "Yrotation", "Zrotation")])
    pose = Pose.rest(sk)
    prob = IKProblem(sk, {"b": np.array([0.0, 1.0, 0.0])}, joints=["a"], max_angle=3.0)
    result = solve_ccd(prob, pose, max_iterations=1)
    assert result.converged
    expected = quat_from_rotvec(np.array([0.0, 0.0, np.pi / 2]))
    assert rotation_angles(result.pose.rotations[1], expected) < 1e-9


_SYNTH = synthetic_motion()


@settings(max_examples=40, deadline=None)
@given(frame=st.integers(0, _SYNTH.n_frames - 1),
       offset=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
       site=st.sampled_from(["lWrist_end", "rAnkle_end", "lTwist", "neck_end"]),
       method=st.sampled_from(sorted(METHODS)),
       root=st.booleans(),
       max_angle=st.floats(0.05, 3.0))
def test_any_target_gives_finite_monotone_limited_iterates(frame, offset, site, method, root,
                                                           max_angle):
    pose = Pose.from_motion(_SYNTH, frame)
    target = site_position(pose, site) + np.array(offset)
    prob = IKProblem(_SYNTH.skeleton, {site: target}, root_may_move=root, max_angle=max_angle)
    result = solve(prob, pose, method, max_iterations=60, record_poses=True)
    assert np.all(np.isfinite(result.pose.rotations))
    assert np.all(np.isfinite(result.pose.root_position))
    assert np.all(np.diff(result.errors) <= 0)
    for a, b in zip(result.poses[:-1], result.poses[1:], strict=True):
        assert rotation_angles(a.rotations, b.rotations).max() <= max_angle + 1e-9
