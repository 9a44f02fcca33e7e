"""Tests of mjchar.bvh.editing.interpolation: position splines, quaternion splines, sampling and
resampling."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_clip

from mjchar import bvh
from mjchar.bvh.editing.interpolation import (
    InterpolationError,
    catmull_rom,
    catmull_rom_tangents,
    finite_difference_tangents,
    hermite,
    keyframes_to_motion,
    linear,
    quat_key_velocities,
    quat_spline,
    resample,
    sample,
    slerp_keys,
)
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.rotations import quat_conj, quat_from_rotvec, quat_mul, quat_to_rotvec

EPS = 1e-6


# -- helpers ---------------------------------------------------------------------------------------
def _random_keys(rng: np.random.Generator, k: int = 7, shape: tuple[int, ...] = (2, 3)):
    times = np.cumsum(rng.uniform(0.2, 1.0, size=k))
    values = rng.normal(size=(k, *shape))
    return times, values


def _random_quat_keys(rng: np.random.Generator, k: int = 6, j: int = 3):
    times = np.cumsum(rng.uniform(0.3, 0.8, size=k))
    # moderately spaced rotations (< ~100 degrees between keys): a realistic key spacing
    steps = rng.normal(scale=0.6, size=(k, j, 3))
    q = quat_from_rotvec(steps[0])
    out = [q]
    for s in steps[1:]:
        q = quat_mul(q, quat_from_rotvec(s))
        out.append(q)
    keys = np.array(out)
    keys[1::2] *= -1.0  # sign flips must not matter
    return times, keys


def _body_velocity(q0: np.ndarray, q1: np.ndarray, dt: float) -> np.ndarray:
    """Finite-difference body angular velocity (rad/s) from q0 to q1."""
    return quat_to_rotvec(quat_mul(quat_conj(q0), q1)) / dt


def _same_rotation(a: np.ndarray, b: np.ndarray) -> float:
    """Largest rotation angle (rad) between corresponding quaternions."""
    return float(np.max(np.linalg.norm(quat_to_rotvec(quat_mul(quat_conj(a), b)), axis=-1)))


def _chain_skeleton(n: int = 4) -> bvh.Skeleton:
    """A root with a chain of ``n`` 0.3 m bones and a side branch: enough to test FK round trips."""
    names = ["root"] + [f"j{i}" for i in range(1, n + 1)] + ["side"]
    parents = [-1] + list(range(n)) + [0]
    offsets = [[0, 0, 0]] + [[0.0, 0.3, 0.05]] * n + [[0.2, -0.1, 0.0]]
    chans = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")]
    chans += [("Zrotation", "Xrotation", "Yrotation")] * (n + 1)
    return bvh.Skeleton(names, parents, offsets, chans, [n], [[0.0, 0.2, 0.0]])


def _smooth_motion(sk: bvh.Skeleton, fps: float, seconds: float, freq: float = 1.0) -> bvh.Motion:
    """Band-limited motion: joint rotation vectors and root path made of low-frequency sines."""
    rng = np.random.default_rng(3)
    n = int(round(seconds * fps)) + 1
    t = np.arange(n)[:, None, None] / fps
    amp = rng.uniform(0.2, 0.8, size=(1, sk.n_joints, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(1, sk.n_joints, 3))
    rot = quat_from_rotvec(amp * np.sin(2 * np.pi * freq * t + phase))
    pos = np.broadcast_to(sk.offsets, (n, sk.n_joints, 3)).copy()
    tt = t[:, 0, 0]
    pos[:, 0] = np.stack([0.1 * np.sin(2 * np.pi * freq * tt), 0.9 + 0.02 * np.cos(4 * np.pi * tt),
                          1.2 * tt], axis=1)
    return bvh.Motion(sk, 1.0 / fps, pos, rot)


# -- position curves -------------------------------------------------------------------------------
def test_linear_hits_keys_and_interpolates_midpoints():
    rng = np.random.default_rng(0)
    times, values = _random_keys(rng)
    np.testing.assert_allclose(linear(times, values, times), values, atol=1e-12)
    mid = 0.5 * (times[:-1] + times[1:])
    np.testing.assert_allclose(linear(times, values, mid), 0.5 * (values[:-1] + values[1:]),
                               atol=1e-12)
    # scalar query -> no leading axis; clamping outside the key range holds the end keys
    assert linear(times, values, float(times[2])).shape == values.shape[1:]
    np.testing.assert_allclose(linear(times, values, [times[0] - 5, times[-1] + 5]),
                               values[[0, -1]], atol=1e-12)


@pytest.mark.parametrize("kind", ["hermite_fd", "hermite_given", "catmull_rom"])
def test_cubic_curves_pass_through_keys_and_are_c1(kind):
    rng = np.random.default_rng(1)
    times, values = _random_keys(rng)
    given = rng.normal(size=values.shape)

    def curve(t, derivative=False):
        if kind == "hermite_fd":
            return hermite(times, values, t, derivative=derivative)
        if kind == "hermite_given":
            return hermite(times, values, t, tangents=given, derivative=derivative)
        return catmull_rom(times, values, t, derivative=derivative)

    np.testing.assert_allclose(curve(times), values, atol=1e-12)
    inner = times[1:-1]
    left = (curve(inner) - curve(inner - EPS)) / EPS
    right = (curve(inner + EPS) - curve(inner)) / EPS
    scale = np.max(np.abs(values)) / np.min(np.diff(times)) ** 2
    assert np.max(np.abs(left - right)) < 20 * EPS * scale  # only the O(eps) curvature term
    # analytic derivative equals the tangent rule at every key
    tangents = {"hermite_fd": finite_difference_tangents(times, values),
                "hermite_given": given,
                "catmull_rom": catmull_rom_tangents(times, values)}[kind]
    _, d = curve(times, derivative=True)
    np.testing.assert_allclose(d, tangents, atol=1e-9)
    # analytic derivative matches the numerical one away from keys
    tq = np.sort(rng.uniform(times[0] + 0.01, times[-1] - 0.01, size=50))
    _, d = curve(tq, derivative=True)
    num = (curve(tq + EPS) - curve(tq - EPS)) / (2 * EPS)
    np.testing.assert_allclose(d, num, atol=1e-5)


def test_c1_check_detects_a_corner():
    """The left/right derivative check above does fail for a C0 curve (piecewise linear)."""
    rng = np.random.default_rng(1)
    times, values = _random_keys(rng)
    inner = times[1:-1]
    left = (linear(times, values, inner) - linear(times, values, inner - EPS)) / EPS
    right = (linear(times, values, inner + EPS) - linear(times, values, inner)) / EPS
    assert np.max(np.abs(left - right)) > 0.1


def test_tangent_rules():
    times = np.array([0.0, 1.0, 3.0])
    values = np.array([0.0, 1.0, 5.0])
    # finite difference: mean of the slopes 1 and 2; Catmull-Rom: (5 - 0) / 3
    np.testing.assert_allclose(finite_difference_tangents(times, values), [1.0, 1.5, 2.0])
    np.testing.assert_allclose(catmull_rom_tangents(times, values), [1.0, 5.0 / 3.0, 2.0])


def test_catmull_rom_reproduces_quadratics_on_uniform_keys():
    times = np.linspace(0.0, 2.0, 9)
    values = 3.0 * times**2 - times + 0.5
    t = np.linspace(times[1], times[-2], 101)  # interior segments: exact central differences
    np.testing.assert_allclose(catmull_rom(times, values, t), 3.0 * t**2 - t + 0.5, atol=1e-12)


def test_cyclic_tangents_are_c1_through_the_seam():
    times = np.array([0.0, 0.7, 1.5, 2.0, 3.0])
    ang = 2 * np.pi * times / 3.0
    values = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    values[-1] = values[0]
    for fn in (finite_difference_tangents, catmull_rom_tangents):
        tang = fn(times, values, cyclic=True)
        np.testing.assert_allclose(tang[0], tang[-1], atol=1e-12)
        _, d = hermite(times, values, [times[0], times[-1]], tangents=tang, derivative=True)
        np.testing.assert_allclose(d[0], d[1], atol=1e-12)
    # without cyclic the seam has a corner
    tang = catmull_rom_tangents(times, values)
    assert np.max(np.abs(tang[0] - tang[-1])) > 0.1


# -- rotation curves -------------------------------------------------------------------------------
def test_slerp_keys_hits_keys_and_is_unit():
    rng = np.random.default_rng(2)
    times, keys = _random_quat_keys(rng)
    assert _same_rotation(slerp_keys(times, keys, times), keys) < 1e-9
    q = slerp_keys(times, keys, np.linspace(times[0], times[-1], 200))
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)


def test_quat_spline_passes_through_keys_unit_and_c1():
    rng = np.random.default_rng(4)
    times, keys = _random_quat_keys(rng)
    for rule in ("catmull_rom", "finite_difference"):
        assert _same_rotation(quat_spline(times, keys, times, rule=rule), keys) < 1e-9
        tq = np.linspace(times[0], times[-1], 500)
        q = quat_spline(times, keys, tq, rule=rule)
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)
        inner = times[1:-1]
        q_l, q_k, q_r = (quat_spline(times, keys, inner + s, rule=rule) for s in (-EPS, 0, EPS))
        w_left = _body_velocity(q_l, q_k, EPS)
        w_right = _body_velocity(q_k, q_r, EPS)
        assert np.max(np.abs(w_left - w_right)) < 1e-3  # C1 angular velocity
        # and they equal the key velocities of the rule
        w_keys = quat_key_velocities(times, keys, rule)[1:-1]
        np.testing.assert_allclose(w_left, w_keys, atol=1e-3)
        np.testing.assert_allclose(w_right, w_keys, atol=1e-3)
    # slerp, for contrast, has angular-velocity jumps at the keys
    inner = times[1:-1]
    q_l, q_k, q_r = (slerp_keys(times, keys, inner + s) for s in (-EPS, 0, EPS))
    assert np.max(np.abs(_body_velocity(q_l, q_k, EPS) - _body_velocity(q_k, q_r, EPS))) > 0.1


def test_quat_spline_analytic_velocity_matches_numerical():
    rng = np.random.default_rng(5)
    times, keys = _random_quat_keys(rng)
    given = rng.normal(size=keys.shape[:-1] + (3,))
    tq = np.sort(rng.uniform(times[0] + 0.01, times[-1] - 0.01, size=40))
    for w_keys in (None, given):
        q, w = quat_spline(times, keys, tq, angular_velocities=w_keys, derivative=True)
        q_a = quat_spline(times, keys, tq - EPS, angular_velocities=w_keys)
        q_b = quat_spline(times, keys, tq + EPS, angular_velocities=w_keys)
        np.testing.assert_allclose(w, _body_velocity(q_a, q_b, 2 * EPS), atol=1e-4)
    # given key velocities are reproduced at the keys
    _, w = quat_spline(times, keys, times, angular_velocities=given, derivative=True)
    np.testing.assert_allclose(w, given, atol=1e-9)


def test_quat_spline_is_exact_for_constant_angular_velocity():
    omega = np.array([0.4, -1.3, 2.0])  # body angular velocity, rad/s
    q0 = quat_from_rotvec([0.3, 0.2, -0.5])
    times = np.linspace(0.0, 2.0, 6)
    keys = quat_mul(q0, quat_from_rotvec(times[:, None] * omega))
    tq = np.linspace(0.0, 2.0, 77)
    truth = quat_mul(q0, quat_from_rotvec(tq[:, None] * omega))
    assert _same_rotation(quat_spline(times, keys, tq), truth) < 1e-9


def test_quat_spline_cyclic_is_c1_through_the_seam():
    rng = np.random.default_rng(6)
    times, keys = _random_quat_keys(rng, k=5, j=2)
    keys[-1] = -keys[0]  # closed loop (sign does not matter)
    q_end = quat_spline(times, keys, [times[-1] - EPS, times[-1]], cyclic=True)
    q_start = quat_spline(times, keys, [times[0], times[0] + EPS], cyclic=True)
    w_end = _body_velocity(q_end[0], q_end[1], EPS)
    w_start = _body_velocity(q_start[0], q_start[1], EPS)
    assert np.max(np.abs(w_end - w_start)) < 1e-3
    q_end = quat_spline(times, keys, [times[-1] - EPS, times[-1]])
    q_start = quat_spline(times, keys, [times[0], times[0] + EPS])
    assert np.max(np.abs(_body_velocity(*q_end, EPS) - _body_velocity(*q_start, EPS))) > 0.1


@pytest.mark.parametrize("bad", [
    dict(key_times=[0.0, 1.0, 1.0]),
    dict(key_times=[0.0, np.nan, 2.0]),
    dict(key_times=[0.0]),
    dict(values=np.ones((2, 3))),
])
def test_bad_keys_raise_project_errors(bad):
    times = np.asarray(bad.get("key_times", [0.0, 1.0, 2.0]))
    values = bad.get("values", np.ones((len(times), 3)))
    with pytest.raises(InterpolationError):
        catmull_rom(times, values, 0.5)
    with pytest.raises(MjcharError):
        hermite(times, values, 0.5)


def test_bad_quaternions_and_tangents_raise():
    times = np.array([0.0, 1.0])
    with pytest.raises(InterpolationError, match="zero-length"):
        quat_spline(times, np.zeros((2, 4)), 0.5)
    with pytest.raises(InterpolationError):
        quat_spline(times, np.ones((2, 3)), 0.5)
    with pytest.raises(InterpolationError, match="tangents"):
        hermite(times, np.ones((2, 3)), 0.5, tangents=np.ones((2, 2)))
    with pytest.raises(InterpolationError):
        linear(times, np.ones((2, 3)), np.ones((2, 2)))


# -- motions ---------------------------------------------------------------------------------------
def test_sample_shapes_and_frames():
    sk = _chain_skeleton()
    m = _smooth_motion(sk, 30, 1.0)
    pos, rot = sample(m, 0.5)
    assert pos.shape == (sk.n_joints, 3) and rot.shape == (sk.n_joints, 4)
    for pm in ("linear", "cubic"):
        for rm in ("slerp", "spline"):
            pos, rot = sample(m, m.times, position_method=pm, rotation_method=rm)
            assert pos.shape == m.local_positions.shape and rot.shape == m.rotations.shape
            np.testing.assert_allclose(pos, m.local_positions, atol=1e-12)
            assert _same_rotation(rot, m.rotations) < 1e-9
    # clamped outside the clip
    pos, rot = sample(m, [-1.0, m.duration + 1.0])
    np.testing.assert_allclose(pos, m.local_positions[[0, -1]], atol=1e-12)
    with pytest.raises(InterpolationError, match="position_method"):
        sample(m, 0.1, position_method="quintic")


def test_resample_frame_count_and_identity():
    sk = _chain_skeleton()
    m = _smooth_motion(sk, 30, 1.0)  # 31 frames, 1 s
    same = resample(m, fps=30)
    assert same.n_frames == m.n_frames
    np.testing.assert_allclose(same.local_positions, m.local_positions, atol=1e-12)
    assert _same_rotation(same.rotations, m.rotations) < 1e-9
    assert resample(m, fps=60).n_frames == 61
    assert resample(m, frame_time=0.3).n_frames == 4  # 0, 0.3, 0.6, 0.9
    with pytest.raises(InterpolationError):
        resample(m)
    with pytest.raises(InterpolationError):
        resample(m, fps=30, frame_time=0.1)
    with pytest.raises(InterpolationError):
        resample(m, fps=-1)


def _round_trip_error(m: bvh.Motion, fps_mid: float, **kw) -> tuple[np.ndarray, bvh.Motion]:
    back = resample(resample(m, fps=fps_mid, **kw), frame_time=m.frame_time, **kw)
    n = back.n_frames
    a = bvh.forward_kinematics(m[:n]).positions
    b = bvh.forward_kinematics(back).positions
    return np.linalg.norm(a - b, axis=-1), back


@pytest.mark.parametrize("freq, kw", [
    (0.5, {}),  # default: linear positions, slerp rotations (measured 0.55 mm)
    (1.0, {"position_method": "cubic", "rotation_method": "spline"}),  # measured 0.28 mm
])
def test_resample_round_trip_synthetic_within_1mm(freq, kw):
    """100 -> 60 -> 100 fps on a smooth motion: a 1.2 m chain, joints swinging +-0.2-0.8 rad."""
    m = _smooth_motion(_chain_skeleton(), 100, 2.0, freq=freq)
    err, back = _round_trip_error(m, 60, **kw)
    assert back.n_frames == m.n_frames  # 2 s is a whole number of frames at both rates
    assert err.max() < 1e-3
    np.testing.assert_allclose(np.linalg.norm(back.rotations, axis=-1), 1.0, atol=1e-12)


def test_spline_resampling_beats_slerp_on_fast_motion():
    m = _smooth_motion(_chain_skeleton(), 100, 2.0, freq=1.0)
    err_default, _ = _round_trip_error(m, 60)
    err_spline, _ = _round_trip_error(m, 60, position_method="cubic", rotation_method="spline")
    assert err_spline.max() < 0.3 * err_default.max()  # measured 0.28 mm vs 1.73 mm


def test_resample_round_trip_walk_forward():
    """walk_forward.bvh, 100 fps -> 60 fps -> 100 fps (cubic positions, spline rotations).

    Measured: max 2.96 mm (right toe), at frames where the two rates do not share a sample; the
    frames they share (every 5th) come back exactly. See the xfail test below for why 1 mm is out
    of reach on this clip.
    """
    m = bvh.load(shared_clip("walk_forward.bvh"))
    assert m.frame_time == pytest.approx(0.01)
    err, back = _round_trip_error(m, 60, position_method="cubic", rotation_method="spline")
    assert back.n_frames == 99  # 0.99 s clip: the 60 fps version ends at 0.9833 s
    np.testing.assert_allclose(np.linalg.norm(back.rotations, axis=-1), 1.0, atol=1e-12)
    assert err[::5].max() < 1e-9  # shared sample times are reproduced exactly
    assert err.max() < 3.5e-3
    assert np.median(err) < 1e-3
    # the default (linear, slerp) is worse but bounded
    err_default, _ = _round_trip_error(m, 60)
    assert err_default.max() < 5e-3


@pytest.mark.xfail(strict=True, reason=(
    "walk_forward.bvh is ~30 Hz key data upsampled to 100 fps: its channels are piecewise linear "
    "with kinks every 1/30 s that fall between 100 fps frames; that content (at and above 30 Hz, "
    "the Nyquist limit of 60 fps) cannot survive a 60 fps copy whatever the interpolation; "
    "measured max 2.96 mm (cubic + spline), 4.3 mm (linear + slerp)"))
def test_resample_round_trip_walk_forward_within_1mm():
    m = bvh.load(shared_clip("walk_forward.bvh"))
    err, _ = _round_trip_error(m, 60, position_method="cubic", rotation_method="spline")
    assert err.max() < 1e-3


def test_walk_forward_has_kinks_between_frames():
    """Evidence for the xfail above: the channels are piecewise linear with 30 Hz kinks.

    Second differences (centred at frame ``f``) are large only near the kink instants, which
    repeat every 0.1 s (three 1/30 s intervals = 10 frames): measured, the large ones sit at
    ``f % 10`` in {1, 4, 5, 7, 8} only, and about half of all frames have near-zero ones.
    """
    _, _, values = bvh.read_channels(shared_clip("walk_forward.bvh"))
    d2 = np.abs(np.diff(values, 2, axis=0)).max(axis=1)
    centre = np.arange(len(d2)) + 1
    active = d2 > 0.1 * d2.max()
    assert len(set(centre[active] % 10)) <= 5
    assert np.mean(d2 < 0.05 * d2.max()) > 0.4


# -- keyframes -------------------------------------------------------------------------------------
def _keys(sk: bvh.Skeleton, rng: np.random.Generator, k: int = 5, cyclic: bool = False):
    times = np.array([0.0, 0.25, 0.5, 0.75, 1.0])[:k]
    rot = quat_from_rotvec(rng.normal(scale=0.5, size=(k, sk.n_joints, 3)))
    root = np.stack([rng.normal(scale=0.05, size=k), 0.9 + rng.normal(scale=0.02, size=k),
                     np.linspace(0.0, 1.0, k)], axis=1)
    if cyclic:
        rot[-1] = rot[0]
        root[-1] = root[0] + np.array([0.0, 0.0, 1.0])  # one metre forward per cycle
    return times, rot, root


@pytest.mark.parametrize("method", ["linear", "hermite", "catmull_rom"])
def test_keyframes_to_motion_passes_through_keys(method):
    sk = _chain_skeleton()
    rng = np.random.default_rng(7)
    times, rot, root = _keys(sk, rng)
    m = keyframes_to_motion(sk, times, rot, root, frame_time=0.05, method=method)
    assert m.n_frames == 21 and m.frame_time == 0.05
    key_frames = np.round(times / 0.05).astype(int)
    assert _same_rotation(m.rotations[key_frames], rot) < 1e-9
    np.testing.assert_allclose(m.root_positions[key_frames], root, atol=1e-12)
    np.testing.assert_allclose(m.local_positions[:, 1:], np.broadcast_to(
        sk.offsets[1:], (m.n_frames, sk.n_joints - 1, 3)))
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0, atol=1e-12)
    # frames are sign-continuous (ready for finite differences)
    assert np.all(np.sum(m.rotations[1:] * m.rotations[:-1], axis=-1) >= 0)


def _seam_velocities(m: bvh.Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    dt = m.frame_time
    w_end = _body_velocity(m.rotations[-2], m.rotations[-1], dt)
    w_start = _body_velocity(m.rotations[0], m.rotations[1], dt)
    v_end = (m.root_positions[-1] - m.root_positions[-2]) / dt
    v_start = (m.root_positions[1] - m.root_positions[0]) / dt
    return w_end, w_start, v_end, v_start


@pytest.mark.parametrize("method", ["hermite", "catmull_rom"])
def test_keyframes_cyclic_loop_is_c1_at_the_seam(method):
    sk = _chain_skeleton()
    rng = np.random.default_rng(8)
    times, rot, root = _keys(sk, rng, cyclic=True)
    dt = 1e-4
    m = keyframes_to_motion(sk, times, rot, root, frame_time=dt, method=method, cyclic=True)
    assert m.n_frames == 10001
    # the loop closes: last frame = first pose, displaced by one cycle
    assert _same_rotation(m.rotations[-1], m.rotations[0]) < 1e-9
    np.testing.assert_allclose(m.root_positions[-1] - m.root_positions[0], [0, 0, 1.0], atol=1e-12)
    w_end, w_start, v_end, v_start = _seam_velocities(m)
    # one-sided differences differ by O(dt * acceleration) only
    assert np.max(np.abs(w_end - w_start)) < 0.02
    assert np.max(np.abs(v_end - v_start)) < 0.01
    # without cyclic the same keys give a velocity jump at the seam
    m2 = keyframes_to_motion(sk, times, rot, root, frame_time=dt, method=method)
    w_end, w_start, v_end, v_start = _seam_velocities(m2)
    assert np.max(np.abs(w_end - w_start)) > 0.5
    assert np.max(np.abs(v_end - v_start)) > 0.1


def test_keyframes_local_positions_for_position_channels():
    sk = _chain_skeleton()
    sk.channels[2] = ("Xposition", "Yposition", "Zposition") + sk.channels[2]
    rng = np.random.default_rng(9)
    times, rot, root = _keys(sk, rng)
    klp = np.broadcast_to(sk.offsets, (5, sk.n_joints, 3)).copy()
    klp[:, 2, 0] = np.linspace(0.0, 0.4, 5)
    m = keyframes_to_motion(sk, times, rot, root, 0.125, key_local_positions=klp)
    np.testing.assert_allclose(m.local_positions[::2, 2], klp[:, 2], atol=1e-12)
    np.testing.assert_allclose(m.local_positions[:, 1], np.broadcast_to(sk.offsets[1], (9, 3)))


def test_keyframes_errors():
    sk = _chain_skeleton()
    rng = np.random.default_rng(10)
    times, rot, root = _keys(sk, rng)
    with pytest.raises(InterpolationError, match="method"):
        keyframes_to_motion(sk, times, rot, root, 0.1, method="bezier")
    with pytest.raises(InterpolationError, match="key_rotations"):
        keyframes_to_motion(sk, times, rot[:, :2], root, 0.1)
    with pytest.raises(InterpolationError, match="key_root_positions"):
        keyframes_to_motion(sk, times, rot, root[:3], 0.1)
    with pytest.raises(InterpolationError, match="frame_time"):
        keyframes_to_motion(sk, times, rot, root, 0.0)
    with pytest.raises(InterpolationError, match="loop"):
        keyframes_to_motion(sk, times, rot, root, 0.1, cyclic=True)  # last key != first
    with pytest.raises(InterpolationError, match="increasing"):
        keyframes_to_motion(sk, times[::-1], rot, root, 0.1)
