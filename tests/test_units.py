"""Units and up axis: guessing from the rest pose, and transform_motion commuting with FK."""

from __future__ import annotations

import numpy as np
import pytest
from bvh_variants import all_variants, base_motion
from scipy.spatial.transform import Rotation

from mjchar import bvh
from mjchar.bvh.rigs.units import (
    CMU_UNIT,
    KNOWN_UNITS,
    guess_unit_scale,
    guess_up_axis,
    to_metres,
    transform_motion,
    unit_from_stature,
    unit_name,
    unit_scale,
    up_axis_rotation,
)
from mjchar.bvh.rotations import quat_conj, quat_mul, quat_rotate

GUESSABLE = [v for v in all_variants() if v.unit_scale is not None and not v.format_of]


def test_guesses_on_shared_clip(shared_clip_path):
    sk = bvh.load(shared_clip_path).skeleton
    assert guess_unit_scale(sk) == 1.0
    assert guess_up_axis(sk) == "y"


@pytest.mark.parametrize("variant", GUESSABLE, ids=lambda v: v.name)
def test_guesses_on_generated(variant):
    """cm, inch and Z-up variants of the base clip, CMU-style inches, Mixamo cm (Y- and Z-up)."""
    sk = bvh.loads(variant.text).skeleton
    assert guess_unit_scale(sk) == pytest.approx(variant.unit_scale)
    assert guess_up_axis(sk) == variant.up


def test_generated_set_has_the_unit_and_axis_cases():
    names = {v.name.split("-", 1)[-1] for v in GUESSABLE}
    assert {"cm", "inch", "zup", "zup-cm"} <= names
    assert {v.unit_scale for v in GUESSABLE} >= {1.0, 0.01, 0.0254}


def _random_transforms(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for q in Rotation.random(n, rng=rng).as_quat(scalar_first=True):
        yield float(rng.uniform(0.01, 100.0)), q
    yield 100.0, up_axis_rotation("y", "z")
    yield 1 / 0.0254, None


@pytest.mark.parametrize("source", ["base", "authored"])
def test_transform_motion_commutes_with_fk(source):
    """FK(transform(m, s, R)) = s R FK(m) for positions, R O R^-1 for orientations."""
    motion = base_motion(prefer_shared=source == "base")[0]
    fk = bvh.forward_kinematics(motion)
    sites = bvh.end_site_positions(motion, fk)
    for s, q in _random_transforms(4, seed=11):
        qq = np.array([1.0, 0, 0, 0]) if q is None else q
        moved = transform_motion(motion, s, q)
        fk2 = bvh.forward_kinematics(moved)
        scale = s * max(1.0, float(np.abs(fk.positions).max()))
        np.testing.assert_allclose(fk2.positions, s * quat_rotate(qq, fk.positions),
                                   atol=1e-12 * scale, rtol=0)
        want = quat_mul(quat_mul(qq, fk.orientations), quat_conj(qq))
        np.testing.assert_allclose(np.abs(np.sum(fk2.orientations * want, axis=-1)), 1.0,
                                   atol=1e-12)
        np.testing.assert_allclose(bvh.end_site_positions(moved, fk2),
                                   s * quat_rotate(qq, sites), atol=1e-12 * scale, rtol=0)
        assert moved.source_channels is None  # the file's angles no longer apply


def test_to_metres_undoes_a_cm_zup_file():
    """Reading the Z-up centimetre variant and converting back gives the base clip."""
    variants = {v.name: v for v in all_variants()}
    label = all_variants()[0].name
    base = bvh.loads(variants[label].text)
    zup_cm = bvh.loads(variants[f"{label}-zup-cm"].text)
    back = to_metres(zup_cm, to_up="y")  # units and up axis guessed
    # both files print 6 decimals (of cm, of degrees): they agree to about a micrometre
    np.testing.assert_allclose(bvh.forward_kinematics(back).positions,
                               bvh.forward_kinematics(base).positions, atol=2e-6)
    given = to_metres(zup_cm, unit="cm", up="z", to_up="y")
    np.testing.assert_allclose(bvh.forward_kinematics(given).positions,
                               bvh.forward_kinematics(back).positions, atol=1e-12)


def test_up_axis_rotation():
    q = up_axis_rotation("y", "z")
    np.testing.assert_allclose(quat_rotate(q, [0.0, 1.0, 0.0]), [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(quat_rotate(q, [0.0, 0.0, 1.0]), [0, -1, 0], atol=1e-15)
    np.testing.assert_array_equal(up_axis_rotation("z", "z"), [1, 0, 0, 0])


def test_unit_names():
    assert unit_scale("cm") == 0.01 and unit_scale("IN") == 0.0254 and unit_scale("m") == 1.0
    with pytest.raises(bvh.SkeletonError, match="unknown unit"):
        unit_scale("furlong")


def test_flat_skeleton_has_no_unit_guess():
    sk = bvh.Skeleton(["a", "b"], [-1, 0], [[0, 0, 0], [0, 0, 0]], [(), ()])
    with pytest.raises(bvh.SkeletonError, match="no height"):
        guess_unit_scale(sk)


#: decimetres and the CMU unit are 1.77 apart: a 1.1 m body in CMU units is a 1.95 m adult in
#: decimetres, and a 2.2 m one in decimetres a 1.24 m child in CMU units (the adult, then the
#: common unit wins: test_decimetres_and_cmu_units_told_apart)
AMBIGUOUS = {(1.1, "cmu"), (2.2, "dm")}


@pytest.mark.parametrize("unit", sorted(KNOWN_UNITS))
@pytest.mark.parametrize("height_m", [1.1, 1.4, 1.7, 2.0, 2.2])
def test_units_snap_from_the_body(unit, height_m):
    """A body of 1.1-2.2 m in any known unit (m, dm, cm, mm, in, ft, CMU ASF) is read in it."""
    if (height_m, unit) in AMBIGUOUS:
        pytest.skip("two units fit this stature")
    g = unit_from_stature(height_m / KNOWN_UNITS[unit])
    assert g.name == unit and g.scale == KNOWN_UNITS[unit]
    assert g.height_m == pytest.approx(height_m)


def test_decimetres_and_cmu_units_told_apart():
    """A Blender scene at 0.1 m per unit (a MakeHuman body 15.5 units tall) is read in
    decimetres, not at a fitted 0.11 m per unit; where decimetres and the CMU unit both fit,
    the unit that makes an adult wins, then the common one."""
    g = unit_from_stature(15.5)
    assert g.name == "dm" and g.height_m == pytest.approx(1.55)
    assert unit_from_stature(19.0).name == "dm"      # 1.90 m (dm) against 1.07 m (cmu)
    assert unit_from_stature(22.3).name == "cmu"     # 1.26 m (cmu) against 2.23 m (dm)
    assert unit_from_stature(28.0).name == "cmu"     # the CMU files: 1.58 m


def test_no_known_unit_gives_the_anatomical_scale():
    g = unit_from_stature(8.5)  # 8.5 m, 0.85 m in dm, 2.6 m in ft, 0.48 m in CMU units
    assert g.name is None and g.scale == pytest.approx(1.7 / 8.5)
    assert unit_scale("cmu") == pytest.approx(0.0254 / 0.45) == CMU_UNIT
    assert unit_name(0.0254) == "in" and unit_name(0.05) is None
