"""Tests of the mjchar.bvh.rotations helpers, checked against scipy's Rotation
(scalar_first=True)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from mjchar.bvh.errors import MjcharError
from mjchar.bvh.rotations import (
    decompose_facing,
    from_rotation,
    heading_angle,
    quat_conj,
    quat_fix_continuity,
    quat_from_rotvec,
    quat_identity,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_slerp,
    quat_to_rotvec,
    to_rotation,
)


def _random_quats(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return quat_normalize(rng.normal(size=(*shape, 4)))


def _same_rotation(a: np.ndarray, b: np.ndarray, atol: float = 1e-12) -> bool:
    """``a`` and ``b`` equal up to sign, element-wise over ``(..., 4)``."""
    return bool(np.all(np.abs(np.abs(np.sum(a * b, axis=-1)) - 1.0) < atol))


def _about(axis: str, angle: np.ndarray | float) -> np.ndarray:
    v = np.zeros(np.shape(angle) + (3,))
    v[..., "xyz".index(axis)] = angle
    return quat_from_rotvec(v)


# -- basics against scipy --------------------------------------------------------------------------
def test_conversions_keep_the_scalar_first():
    q = np.array([np.cos(0.5), np.sin(0.5), 0.0, 0.0])  # 1 rad about x
    r = to_rotation(q)
    np.testing.assert_allclose(r.as_rotvec(), [[1.0, 0.0, 0.0]], atol=1e-15)
    np.testing.assert_allclose(from_rotation(r, ()), q)
    rng = np.random.default_rng(0)
    qs = _random_quats(rng, (4, 5))
    assert from_rotation(to_rotation(qs), (4, 5)).shape == (4, 5, 4)
    assert _same_rotation(from_rotation(to_rotation(qs), (4, 5)), qs)


def test_mul_rotate_conj_match_scipy():
    rng = np.random.default_rng(1)
    a, b = _random_quats(rng, (50,)), _random_quats(rng, (50,))
    v = rng.normal(size=(50, 3))
    ra, rb = to_rotation(a), to_rotation(b)
    assert _same_rotation(quat_mul(a, b), (ra * rb).as_quat(scalar_first=True))
    np.testing.assert_allclose(quat_rotate(a, v), ra.apply(v), atol=1e-12)
    np.testing.assert_allclose(quat_mul(a, quat_conj(a)), quat_identity((50,)), atol=1e-12)
    # broadcasting: one rotation applied to many vectors
    np.testing.assert_allclose(quat_rotate(a[0], v), ra[0].apply(v), atol=1e-12)


# -- continuity ------------------------------------------------------------------------------------
def test_fix_continuity_removes_sign_flips_along_frames():
    rng = np.random.default_rng(2)
    steps = quat_from_rotvec(rng.normal(scale=0.2, size=(100, 3, 3)))
    q = np.empty_like(steps)
    q[0] = steps[0]
    for f in range(1, 100):
        q[f] = quat_mul(q[f - 1], steps[f])
    flipped = q * rng.choice([-1.0, 1.0], size=(100, 3, 1))
    fixed = quat_fix_continuity(flipped, axis=0)
    assert fixed.shape == q.shape
    assert np.all(np.sum(fixed[1:] * fixed[:-1], axis=-1) >= 0)  # no sign jumps
    assert np.all(np.abs(np.abs(fixed) - np.abs(flipped)) == 0)  # only signs changed
    np.testing.assert_array_equal(fixed[0], flipped[0])  # first frame kept
    # along another axis
    fixed_t = quat_fix_continuity(np.swapaxes(flipped, 0, 1), axis=1)
    np.testing.assert_array_equal(np.swapaxes(fixed_t, 0, 1), fixed)
    # input untouched
    assert not np.array_equal(flipped, fixed)


# -- slerp -----------------------------------------------------------------------------------------
def test_slerp_matches_scipy_and_hits_endpoints():
    rng = np.random.default_rng(3)
    q0, q1 = _random_quats(rng, (20,)), _random_quats(rng, (20,))
    t = rng.uniform(size=20)
    out = quat_slerp(q0, q1, t)
    for i in range(20):
        ref = Slerp([0.0, 1.0], to_rotation(np.stack([q0[i], q1[i]])))([t[i]])
        assert _same_rotation(out[i], ref.as_quat(scalar_first=True)[0], atol=1e-10)
    assert _same_rotation(quat_slerp(q0, q1, 0.0), q0)
    assert _same_rotation(quat_slerp(q0, q1, 1.0), q1)
    np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-12)


def test_slerp_constant_speed_short_path_and_tiny_angles():
    q0 = _about("y", 0.0)
    q1 = -_about("y", 1.2)  # the other sign: still the 1.2 rad short path
    t = np.linspace(0.0, 1.0, 7)
    out = quat_slerp(q0, q1, t)  # q0, q1 broadcast against t
    angles = np.linalg.norm(quat_to_rotvec(out), axis=-1)
    np.testing.assert_allclose(angles, 1.2 * t, atol=1e-12)
    # nearly equal inputs do not divide by zero
    q2 = quat_normalize(q0 + np.array([0.0, 1e-12, 0.0, 0.0]))
    out = quat_slerp(q0, q2, 0.5)
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(np.linalg.norm(out), 1.0)


# -- rotation vectors ------------------------------------------------------------------------------
def test_rotvec_conversions_match_scipy():
    rng = np.random.default_rng(4)
    q = _random_quats(rng, (200,))
    np.testing.assert_allclose(quat_to_rotvec(q), to_rotation(q).as_rotvec(), atol=1e-12)
    r = rng.normal(scale=1.5, size=(200, 3))
    assert _same_rotation(quat_from_rotvec(r),
                          Rotation.from_rotvec(r).as_quat(scalar_first=True))
    # round trip for angles below pi; the angle is in [0, pi] whatever the sign of q
    r_small = r * (np.minimum(np.linalg.norm(r, axis=1), 3.0) / np.linalg.norm(r, axis=1))[:, None]
    np.testing.assert_allclose(quat_to_rotvec(quat_from_rotvec(r_small)), r_small, atol=1e-12)
    np.testing.assert_allclose(quat_to_rotvec(-q), quat_to_rotvec(q), atol=1e-12)
    assert np.all(np.linalg.norm(quat_to_rotvec(q), axis=-1) <= np.pi + 1e-12)


def test_rotvec_small_and_half_turn_angles():
    tiny = np.array([1e-14, -2e-14, 3e-15])
    np.testing.assert_allclose(quat_to_rotvec(quat_from_rotvec(tiny)), tiny, rtol=1e-6)
    np.testing.assert_allclose(quat_from_rotvec(np.zeros(3)), [1.0, 0.0, 0.0, 0.0])
    half = quat_from_rotvec([0.0, 0.0, np.pi])
    np.testing.assert_allclose(np.abs(quat_to_rotvec(half)), [0.0, 0.0, np.pi], atol=1e-12)
    # shapes broadcast over leading dimensions
    assert quat_to_rotvec(quat_identity((2, 3))).shape == (2, 3, 3)


# -- facing ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("up", ["x", "y", "z"])
def test_decompose_facing_is_a_swing_twist_split(up):
    rng = np.random.default_rng(5)
    q = _random_quats(rng, (100,))
    heading, tilt = decompose_facing(q, up)
    i = "xyz".index(up)
    assert _same_rotation(quat_mul(heading, tilt), q)
    others = [1 + k for k in range(3) if k != i]
    np.testing.assert_allclose(heading[:, others], 0.0, atol=1e-15)  # pure rotation about up
    np.testing.assert_allclose(tilt[:, 1 + i], 0.0, atol=1e-12)  # no twist left about up
    np.testing.assert_allclose(np.linalg.norm(heading, axis=-1), 1.0, atol=1e-12)


def test_heading_of_yaw_then_tilt():
    """``R = R_up(a) R_tilt``: the heading is ``a`` for tilts about the lateral or forward axis."""
    a = np.linspace(-3.0, 3.0, 13)
    for tilt_axis in ("x", "z"):
        q = quat_mul(_about("y", a), _about(tilt_axis, 0.4))
        np.testing.assert_allclose(heading_angle(q, "y"), a, atol=1e-12)
        heading, tilt = decompose_facing(q, "y")
        assert _same_rotation(tilt, np.broadcast_to(_about(tilt_axis, 0.4), tilt.shape))
    # Z-up
    q = quat_mul(_about("z", a), _about("y", -0.3))
    np.testing.assert_allclose(heading_angle(q, "z"), a, atol=1e-12)


def test_heading_of_a_half_tilt_is_defined():
    q = _about("x", np.pi)  # upside down: no heading, identity chosen
    heading, tilt = decompose_facing(q, "y")
    np.testing.assert_allclose(heading, [1.0, 0.0, 0.0, 0.0])
    assert _same_rotation(tilt, q)
    assert heading_angle(q, "y") == pytest.approx(0.0)


def test_heading_angle_is_sign_invariant_and_wrapped():
    q = _about("y", np.radians([170.0, -170.0, 90.0]))
    for qq in (q, -q):
        h = heading_angle(qq, "y")
        assert np.all(np.abs(h) <= np.pi)
        np.testing.assert_allclose(h, np.radians([170.0, -170.0, 90.0]), atol=1e-12)


def test_facing_with_bad_axis_raises_project_error():
    with pytest.raises(MjcharError):
        heading_angle(quat_identity(), "w")
