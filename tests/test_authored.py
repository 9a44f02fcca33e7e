"""The project-authored bundled motions (mjchar.bvh.bundled.authored): idle and walk on the default
skeleton.

Measured figures are printed with ``pytest -s``.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjchar import bvh
from mjchar.bvh.bundled.authored import (
    AuthoringError,
    IdleStyle,
    WalkStyle,
    idle_motion,
    walk_motion,
    write_bundled_motions,
)
from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf import convert
from mjchar.bvh.reference.reference_motion import ReferenceMotion, replay_errors
from mjchar.bvh.rigs.units import transform_motion, up_axis_rotation
from mjchar.bvh.rotations import quat_conj, quat_mul, quat_to_rotvec

_CACHE: dict = {}


def _walk() -> Motion:
    if "walk" not in _CACHE:
        _CACHE["walk"] = walk_motion(humanoid_skeleton())
    return _CACHE["walk"]


def _idle() -> Motion:
    if "idle" not in _CACHE:
        _CACHE["idle"] = idle_motion(humanoid_skeleton())
    return _CACHE["idle"]


def _model(joint_model: str = "hinge"):
    key = ("model", joint_model)
    if key not in _CACHE:
        _CACHE[key] = convert(humanoid_skeleton(), joint_model=joint_model).compile()
    return _CACHE[key]


def _ref(motion: Motion, joint_model: str = "hinge") -> ReferenceMotion:
    return ReferenceMotion(_model(joint_model), motion)


def _angle(ref: ReferenceMotion, joint: str) -> np.ndarray:
    """``(F,)`` degrees of hinge ``joint`` over the frames."""
    j = mujoco.mj_name2id(ref.model, mujoco.mjtObj.mjOBJ_JOINT, joint)
    assert j >= 0, joint
    return np.degrees(ref.frame_qpos[:, ref.model.jnt_qposadr[j]])


def _foot_points(ref: ReferenceMotion, qpos: np.ndarray) -> dict[str, np.ndarray]:
    """Per side, ``(F, 16, 3)`` world corners of the foot and toe boxes for qpos rows."""
    m = ref.model
    d = mujoco.MjData(m)
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    geoms = {s: [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in names]
             for s, names in ref.info.extra["foot_geoms"].items()}
    out = {s: [] for s in geoms}
    for q in qpos:
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        for s, gs in geoms.items():
            out[s].append(np.concatenate([
                d.geom_xpos[g] + (signs * m.geom_size[g]) @ d.geom_xmat[g].reshape(3, 3).T
                for g in gs]))
    return {s: np.array(v) for s, v in out.items()}


# ------------------------------------------------------------------------------------------------
# walk
# ------------------------------------------------------------------------------------------------
def test_walk_is_one_seamless_cycle_at_walking_speed():
    st = WalkStyle()
    w = _walk()
    assert w.n_frames == round(st.period / st.frame_time) + 1
    assert w.frame_time == pytest.approx(st.frame_time)
    assert w.skeleton.names == humanoid_skeleton().names
    seam = np.linalg.norm(quat_to_rotvec(quat_mul(quat_conj(w.rotations[-1]), w.rotations[0])),
                          axis=-1)
    assert seam.max() < 1e-6  # the last frame repeats the first pose...
    d = w.root_positions[-1] - w.root_positions[0]
    np.testing.assert_allclose(d, [0.0, 0.0, st.speed * st.period], atol=1e-9)  # ...a stride on
    speed = d[2] / w.duration
    print(f"\nwalk: {speed:.3f} m/s, stride {d[2]:.3f} m, cycle {w.duration:.3f} s")
    assert 1.0 <= speed <= 1.2


def test_walk_reference_is_cyclic_and_moves_forward():
    ref = _ref(_walk())
    assert ref.cyclic  # detected from the poses
    assert ref.cycle_heading == 0.0
    np.testing.assert_allclose(ref.cycle_displacement, [1.05, 0.0], atol=1e-6)  # +x: forward
    q0, q3 = ref.qpos(0.3), ref.qpos(0.3 + 3 * ref.duration)
    assert q3[0] - q0[0] == pytest.approx(3 * 1.05, abs=1e-6)


def test_walk_loops_c1():
    """Across the seam the joint angles are as smooth as anywhere inside the cycle."""
    ref = _ref(_walk(), "full")
    n = ref.n_frames - 1
    t = np.arange(-n, 2 * n + 1) * ref.frame_time  # three cycles of frames
    q = ref.qpos(t)
    hinge = [ref.model.jnt_qposadr[j] for j in range(ref.model.njnt)
             if ref.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    a = q[:, hinge]
    acc = np.abs(np.diff(a, 2, axis=0))  # second differences, row r is centred on frame r + 1
    seams = [n - 1, 2 * n - 1]
    inside = np.delete(acc, [s + k for s in seams for k in (-1, 0, 1)], axis=0)
    worst_seam = acc[seams].max()
    print(f"\nwalk seam: largest second difference {np.degrees(worst_seam):.3f} deg/frame^2 "
          f"(inside the cycle {np.degrees(inside.max()):.3f})")
    assert worst_seam <= 1.5 * inside.max() + 1e-6
    # velocity continuity (root included): qvel just before and after the seam agree
    v_before, v_after = ref.qvel(ref.duration - 1e-6), ref.qvel(ref.duration + 1e-6)
    assert np.abs(v_before - v_after).max() < 1e-3


def test_walk_feet_alternate_and_do_not_skate():
    ref = _ref(_walk())
    n = ref.n_frames - 1
    times = np.arange(3 * n) * ref.frame_time  # three cycles
    c = ref.foot_contacts(times)
    both, none = (c[:, 0] & c[:, 1]).mean(), (~c[:, 0] & ~c[:, 1]).mean()
    single = np.where(c[:, 0] & ~c[:, 1], 0, np.where(c[:, 1] & ~c[:, 0], 1, -1))
    seq = [s for s in single if s >= 0]
    runs = [seq[0]] + [s for a, s in zip(seq[:-1], seq[1:], strict=True) if s != a]
    print(f"\nwalk contacts: left {c[:, 0].mean():.2f}, right {c[:, 1].mean():.2f}, double "
          f"support {both:.2f}, flight {none:.2f}; single-support runs {len(runs)}")
    assert len(runs) == 6 and all(a != b for a, b in zip(runs[:-1], runs[1:], strict=True))
    assert none == 0.0  # walking: never airborne
    assert 0.05 < both < 0.35
    for k in (0, 1):
        assert 0.5 < c[:, k].mean() < 0.75
    # skating: points of a contact foot touching the floor barely move between frames
    qpos = ref.qpos(np.arange(3 * n + 1) * ref.frame_time)
    pts = _foot_points(ref, qpos)
    worst = 0.0
    for k, side in enumerate(("left", "right")):
        p = pts[side]
        for f in range(3 * n):
            if not c[f, k]:
                continue
            low = p[f, :, 2].min()
            assert low < 0.01  # the stance foot is on the floor (within 1 cm)
            touching = p[f, :, 2] < low + 0.005
            slip = np.linalg.norm(p[f + 1, touching, :2] - p[f, touching, :2], axis=-1).min()
            worst = max(worst, slip)
    print(f"walk: worst slip of a touching stance-foot point {1000 * worst:.2f} mm/frame")
    assert worst < 0.02  # the brief's limit: no big skating (< 2 cm per frame)
    # no penetration: nothing of the feet goes below the floor
    assert min(p[..., 2].min() for p in pts.values()) > -1e-9


def test_walk_joint_angles_are_plausible():
    ref = _ref(_walk())
    hip = -_angle(ref, "lHip_y")  # flexion (thigh forward) is about -y
    knee = _angle(ref, "lKnee_y")
    ankle = _angle(ref, "lAnkle_y")  # plantar flexion (toes down) is +y
    shoulder = _angle(ref, "lShoulder_y")
    elbow = -_angle(ref, "lElbow_z")  # the left elbow flexes about -z
    print(f"\nwalk angles (deg): hip {hip.min():.1f}..{hip.max():.1f}, knee {knee.min():.1f}.."
          f"{knee.max():.1f}, ankle {ankle.min():.1f}..{ankle.max():.1f}, arm swing "
          f"{np.ptp(shoulder):.1f}, elbow {elbow.min():.1f}..{elbow.max():.1f}")
    assert 20 < hip.max() < 40 and -35 < hip.min() < -10
    assert 0 <= knee.min() < 15 and 50 < knee.max() < 70
    assert ankle.min() < -5 and ankle.max() > 5
    assert 20 < np.ptp(shoulder) < 50
    assert 5 < elbow.min() and elbow.max() < 45
    # left and right mirror each other half a cycle apart
    half = (ref.n_frames - 1) // 2
    np.testing.assert_allclose(np.roll(_angle(ref, "rKnee_y")[:-1], -half),
                               _angle(ref, "lKnee_y")[:-1], atol=0.5)


# ------------------------------------------------------------------------------------------------
# idle
# ------------------------------------------------------------------------------------------------
def test_idle_breathes_and_sways_with_planted_feet():
    st = IdleStyle()
    m = _idle()
    assert m.duration == pytest.approx(st.duration)
    ref = _ref(m)
    assert ref.cyclic and np.allclose(ref.cycle_displacement, 0.0, atol=1e-9)
    assert ref.frame_contacts().all()
    pts = _foot_points(ref, ref.frame_qpos)
    drift = max(np.abs(p - p[:1]).max() for p in pts.values())
    root = ref.frame_qpos[:, :3]
    spine = _angle(ref, "pelvis_lowerback_y")
    print(f"\nidle: foot drift {1000 * drift:.3f} mm, pelvis sway {1000 * np.ptp(root[:, 1]):.1f}"
          f" mm, spine breathing {np.ptp(spine):.2f} deg, knees {_angle(ref, 'lKnee_y').mean():.1f}"
          f" deg")
    assert drift < 0.001
    assert 0.01 < np.ptp(root[:, 1]) < 0.05  # lateral sway of a few centimetres
    assert 0.5 < np.ptp(spine) < 5.0
    assert 3 < _angle(ref, "lKnee_y").min() and _angle(ref, "lKnee_y").max() < 20


# ------------------------------------------------------------------------------------------------
# replay in the models
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["idle", "walk"])
def test_bundled_motions_replay_in_the_models(name):
    motion = _walk() if name == "walk" else _idle()
    full = replay_errors(_model("full"), motion)
    hinge = replay_errors(_model("hinge"), motion)
    for tag, e in (("full", full), ("hinge", hinge)):
        print(f"\n{name} {tag}: worst joint {e['max_mm']:.4f} mm ({e['max_joint']}), worst end "
              f"effector {e['end_effector_max_mm']:.4f} mm ({e['end_effector']})")
    assert full["max_mm"] < 1.0 and full["end_effector_max_mm"] < 1.0
    assert hinge["end_effector_max_mm"] < 10.0 and hinge["max_mm"] < 30.0


# ------------------------------------------------------------------------------------------------
# files and generality
# ------------------------------------------------------------------------------------------------
def test_write_bundled_motions_roundtrip(tmp_path):
    sk = humanoid_skeleton()
    paths = write_bundled_motions(sk, tmp_path / "motions")
    assert [p.name for p in paths] == ["idle.bvh", "walk.bvh"]
    for p, made in zip(paths, (_idle(), _walk()), strict=True):
        loaded = bvh.load(p)
        assert loaded.skeleton.names == sk.names
        assert loaded.n_frames == made.n_frames
        assert loaded.frame_time == pytest.approx(made.frame_time, rel=1e-6)
        err = np.abs(bvh.forward_kinematics(loaded).positions
                     - bvh.forward_kinematics(made).positions).max()
        assert err < 1e-4  # BVH text precision
    again = write_bundled_motions(sk, tmp_path / "again")
    for a, b in zip(paths, again, strict=True):
        assert a.read_bytes() == b.read_bytes()  # deterministic


def test_authoring_follows_the_skeletons_axes_and_units():
    """A Z-up skeleton in centimetres gets the same walk, expressed in its own axes/units."""
    sk = humanoid_skeleton()
    q = up_axis_rotation("y", "z")
    zsk = transform_motion(Motion.rest(sk), 100.0, q).skeleton
    zwalk = walk_motion(zsk)
    expected = transform_motion(_walk(), 100.0, q)
    err = np.abs(bvh.forward_kinematics(zwalk).positions
                 - bvh.forward_kinematics(expected).positions).max()
    assert err < 1e-3  # centimetres


def test_bad_skeletons_and_styles_raise():
    no_legs = Skeleton(["Hips", "Spine", "Head"], [-1, 0, 1],
                       [[0, 0, 0], [0, 0.3, 0], [0, 0.4, 0]],
                       [("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation",
                         "Zrotation"), ("Xrotation",), ("Xrotation",)])
    with pytest.raises(AuthoringError):
        walk_motion(no_legs)
    with pytest.raises(AuthoringError):
        walk_motion(humanoid_skeleton(), WalkStyle(period=1.0, frame_time=0.3))
    with pytest.raises(AuthoringError):
        idle_motion(humanoid_skeleton(), IdleStyle(duration=4.0, sway_period=3.0))
    with pytest.raises(AuthoringError):
        walk_motion("not a skeleton")
    assert issubclass(AuthoringError, bvh.MjcharError)
