"""Forward kinematics against an independent 4x4 homogeneous-matrix chain.

The reference below is written from the BVH definition alone: per joint, a translation (the
OFFSET, with any position channels replacing its components) times the product of elemental
rotation matrices in the order the rotation channels are listed, chained from the root.
It reads the raw channel values with bvh.read_channels and shares no code with
mjchar.bvh.kinematics.fk or mjchar.bvh.rotations.
"""

from __future__ import annotations

import numpy as np
import pytest
from bvh_variants import all_variants

from mjchar import bvh

VARIANTS = all_variants()


def elemental(axis: str, degrees: np.ndarray) -> np.ndarray:
    """``(F, 3, 3)`` rotation matrices about ``axis`` ('X', 'Y' or 'Z') by ``degrees``."""
    a = np.deg2rad(degrees)
    c, s = np.cos(a), np.sin(a)
    one, zero = np.ones_like(a), np.zeros_like(a)
    rows = {
        "X": [[one, zero, zero], [zero, c, -s], [zero, s, c]],
        "Y": [[c, zero, s], [zero, one, zero], [-s, zero, c]],
        "Z": [[c, -s, zero], [s, c, zero], [zero, zero, one]],
    }[axis]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def matrix_chain(skeleton, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Global 4x4 transforms ``(F, J, 4, 4)`` and end-site positions ``(F, E, 3)``."""
    n_f = len(values)
    glob = np.zeros((n_f, skeleton.n_joints, 4, 4))
    col = 0
    for j in range(skeleton.n_joints):
        translation = np.tile(np.asarray(skeleton.offsets[j], dtype=float), (n_f, 1))
        rotation = np.tile(np.eye(3), (n_f, 1, 1))
        for name in skeleton.channels[j]:
            v = values[:, col]
            col += 1
            if name.endswith("position"):
                translation[:, "XYZ".index(name[0])] = v
            else:
                rotation = rotation @ elemental(name[0], v)
        local = np.tile(np.eye(4), (n_f, 1, 1))
        local[:, :3, :3] = rotation
        local[:, :3, 3] = translation
        p = skeleton.parents[j]
        glob[:, j] = local if p < 0 else glob[:, p] @ local
    sites = np.zeros((n_f, len(skeleton.end_site_parents), 3))
    for e, (p, off) in enumerate(zip(skeleton.end_site_parents, skeleton.end_site_offsets,
                                     strict=True)):
        sites[:, e] = (glob[:, p] @ np.append(off, 1.0))[:, :3]
    return glob, sites


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` from unit wxyz quaternions (textbook formula)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _check_against_chain(path) -> None:
    skeleton, _, values = bvh.read_channels(path)
    glob, sites = matrix_chain(skeleton, values)
    motion = bvh.load(path)
    fk = bvh.forward_kinematics(motion)
    scale = max(1.0, float(np.abs(glob[..., :3, 3]).max()))
    np.testing.assert_allclose(fk.positions, glob[..., :3, 3], atol=1e-9 * scale, rtol=0)
    np.testing.assert_allclose(quat_to_matrix(fk.orientations), glob[..., :3, :3], atol=1e-9,
                               rtol=0)
    np.testing.assert_allclose(bvh.end_site_positions(motion, fk), sites, atol=1e-9 * scale,
                               rtol=0)


def test_fk_matches_matrix_chain_on_shared_clip(shared_clip_path):
    _check_against_chain(shared_clip_path)


@pytest.mark.parametrize("variant", [v for v in VARIANTS if not v.format_of],
                         ids=lambda v: v.name)
def test_fk_matches_matrix_chain_on_generated(variant, tmp_path):
    path = tmp_path / "v.bvh"
    path.write_text(variant.text)
    _check_against_chain(path)


def test_reference_chain_sanity():
    """The reference itself: a 90 degree Z turn maps a +X child offset to +Y, and channel order
    matters (X then Y is not Y then X)."""
    sk = bvh.Skeleton(["a", "b"], [-1, 0], [[0, 0, 0], [1, 0, 0]],
                      [("Zrotation",), ()])
    glob, _ = matrix_chain(sk, np.array([[90.0]]))
    np.testing.assert_allclose(glob[0, 1, :3, 3], [0, 1, 0], atol=1e-12)
    xy = elemental("X", np.array([30.0])) @ elemental("Y", np.array([40.0]))
    yx = elemental("Y", np.array([40.0])) @ elemental("X", np.array([30.0]))
    assert np.abs(xy - yx).max() > 0.1


def _bone_length_check(motion: bvh.Motion) -> None:
    sk = motion.skeleton
    fk = bvh.forward_kinematics(motion)
    moving = sk.has_position_channels()
    scale = max(1.0, float(np.abs(fk.positions).max()))
    for j in range(1, sk.n_joints):
        if moving[j]:
            continue  # a translated joint's bone may stretch by design
        d = np.linalg.norm(fk.positions[:, j] - fk.positions[:, sk.parents[j]], axis=-1)
        np.testing.assert_allclose(d, np.linalg.norm(sk.offsets[j]), atol=1e-9 * scale, rtol=0)
    sites = bvh.end_site_positions(motion, fk)
    for e, p in enumerate(sk.end_site_parents):
        d = np.linalg.norm(sites[:, e] - fk.positions[:, p], axis=-1)
        np.testing.assert_allclose(d, np.linalg.norm(sk.end_site_offsets[e]), atol=1e-9 * scale,
                                   rtol=0)


def test_bone_lengths_constant_on_shared_clip(shared_clip_path):
    _bone_length_check(bvh.load(shared_clip_path))


@pytest.mark.parametrize("variant", [v for v in VARIANTS if not v.format_of],
                         ids=lambda v: v.name)
def test_bone_lengths_constant_on_generated(variant):
    _bone_length_check(bvh.loads(variant.text))


def test_walk60_feet_touch_the_floor(walk60):
    """The lowest end site over the whole clip is within 4 cm of the floor plane y = 0."""
    motion = bvh.load(walk60)
    sites = bvh.end_site_positions(motion)
    lowest = float(sites[..., 1].min())
    assert abs(lowest) <= 0.04, lowest
    # and the lowest point each frame is a foot, near the floor: the clip is grounded
    per_frame = sites[..., 1].min(axis=1)
    assert np.all(per_frame < 0.15)


def test_rest_motion_gives_rest_positions():
    v = VARIANTS[0]
    sk = bvh.loads(v.text).skeleton
    rest = bvh.Motion.rest(sk, n_frames=2)
    fk = bvh.forward_kinematics(rest)
    np.testing.assert_allclose(fk.positions[1], sk.rest_positions(), atol=1e-12)
    np.testing.assert_allclose(bvh.end_site_positions(rest, fk)[0], sk.rest_end_sites(),
                               atol=1e-12)
    np.testing.assert_allclose(fk.orientations[..., 0], 1.0)
