"""Static balance and SIMBICON on bodies converted from real exports and from the zoo's
structure rigs, at the converter's defaults, with nothing but the model given (as
``mjchar convert FILE -o body.xml`` then ``mjchar run static_balance|simbicon --model body.xml``).

The real exports (``../shared/data/real``) are held out: SIMBICON was not tuned on them. Every run
reports the root force the controller applied; it must be 0 N. The 30 s stands and the 60 s walks
back the README's figures and are in the claims tier (``-m claims``); the structure rigs' 20 s
walks are fast.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_BVH, assert_no_root_help, real_export, shared_clip

from mjchar import bvh
from mjchar.bvh.mjcf import convert
from mjchar.controllers import run

REAL = ("xsens_mvn_walk.bvh", "cmu_daz_02_03.bvh", "emilya_walk.bvh")
#: the README's figures for the real exports: static balance stands, SIMBICON walks (s)
STAND_S, WALK_S = 30.0, 60.0
STRUCTURE_RIGS = ("cmu-asf-yup", "daz-cm-yup-face", "lafan1-anon-cm-yup", "mixamo7-cm-yup-gimbal")


@pytest.fixture(scope="module", params=REAL)
def real_body(request, tmp_path_factory) -> str:
    """The MJCF of a real export converted at the defaults (``mjchar convert FILE -o X.xml``)."""
    path = real_export(request.param)
    xml = tmp_path_factory.mktemp("real") / (path.stem + ".xml")
    convert(bvh.load(path)).save(xml)
    return str(xml)


@pytest.mark.claims
def test_static_balance_stands_30s_on_a_real_export(real_body):
    r = run("static_balance", "stand", model=real_body, duration=STAND_S)
    assert not r.fell, (real_body, r.fall_time_s, r.fall_reason)
    assert_no_root_help(r)


@pytest.mark.claims
def test_simbicon_walks_60s_on_a_real_export(real_body):
    r = run("simbicon", "walk", model=real_body, duration=WALK_S)
    assert not r.fell, (real_body, r.fall_time_s, r.fall_reason)
    assert_no_root_help(r)
    assert r.distance_m > 40.0  # walking (0.9-1.2 m/s), not standing or shuffling


@pytest.fixture(scope="module")
def structure_bodies(tmp_path_factory) -> dict[str, str]:
    """The zoo's structure rigs (CMU ASF rest, Daz names with a face, anonymous LAFAN1 names,
    namespaced Mixamo near gimbal lock) converted at the defaults: {rig name: xml}."""
    shared_clip("walk60.bvh")
    from mjchar.bvh.bundled.zoo import structure_rigs

    folder = tmp_path_factory.mktemp("structure")
    out = {}
    for rig in structure_rigs(bvh.load(SHARED_BVH / "walk60.bvh"), "walk60"):
        xml = folder / f"{rig.name}.xml"
        convert(bvh.loads(bvh.dumps(rig.motion))).save(xml)
        out[rig.name] = str(xml)
    return out


@pytest.mark.parametrize("name", STRUCTURE_RIGS)
def test_simbicon_walks_on_a_structure_rig(structure_bodies, name):
    r = run("simbicon", "walk", model=structure_bodies[name], duration=20.0)
    assert not r.fell, (name, r.fall_time_s, r.fall_reason)
    assert_no_root_help(r)
    assert r.distance_m > 12.0, (name, r.distance_m)


@pytest.mark.parametrize("joint_model, joint", [("ball", "pelvis_lowerback"), ("full", "lKnee")])
def test_simbicon_names_the_joint_it_cannot_read(tmp_path, joint_model, joint):
    """A body SIMBICON cannot drive is a one-line error naming the joint and the fix."""
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.walking.simbicon import SimbiconModelError, make_simbicon

    xml = tmp_path / f"{joint_model}.xml"
    convert(bvh.load(motion_path("walk")), joint_model=joint_model).save(xml)
    ch = Character(str(xml))
    with pytest.raises(SimbiconModelError, match=rf"^{joint}: .*--joint-model hinge") as e:
        make_simbicon(ch).reset(ch)
    assert "\n" not in str(e.value)


def test_simbicon_walks_on_knees_yawed_off_the_lateral_axis(tmp_path):
    """The bundled humanoid with both knees' hinges turned 20 degrees about the vertical, the
    same way (as the converter finds them in the Xsens capture: 13 and 29 degrees): the knees
    flex in the sagittal plane and it walks (with the knees' axes taken as lateral, it falls at
    1.6 s)."""
    from mjchar.bvh.bundled.assets import HUMANOID_XML
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.core.scenarios import walk
    from mjchar.controllers.walking.simbicon import DEFAULT_TIMESTEP, make_simbicon

    text = Path(HUMANOID_XML).read_text()
    for side in "lr":
        old = f'name="{side}Knee_y" type="hinge" axis="0 1 0"'
        assert old in text
        text = text.replace(old, f'name="{side}Knee_y" type="hinge" axis="0.34202 0.93969 0"')
    xml = tmp_path / "yawed_knees.xml"
    xml.write_text(text)
    ch = Character(str(xml), timestep=DEFAULT_TIMESTEP)
    r = walk(ch, make_simbicon(ch), duration=10.0)
    assert not r.fell, r.fall_time_s
    assert_no_root_help(r)
    assert r.distance_m > 8.0


def _bundled_with(tmp_path, name: str, **joints: str) -> str:
    """The bundled humanoid's MJCF with the hinge axes of ``joints`` ({joint: "x y z"})."""
    from mjchar.bvh.bundled.assets import HUMANOID_XML

    text = Path(HUMANOID_XML).read_text()
    for joint, axis in joints.items():
        old = next(a for a in ("0 1 0", "0 0 1") if f'name="{joint}" type="hinge" axis="{a}"'
                   in text)
        text = text.replace(f'name="{joint}" type="hinge" axis="{old}"',
                            f'name="{joint}" type="hinge" axis="{axis}"')
    xml = tmp_path / f"{name}.xml"
    xml.write_text(text)
    return str(xml)


def test_simbicon_walks_with_an_elbow_hinge_along_the_forearm(tmp_path):
    """An arm's hinge whose sense the rest pose does not tell (the left elbow's axis along the
    forearm, as the namespaced Mixamo export's right forearm) is held at its rest angle: the arm
    never stops the walker (it refused the body before)."""
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.core.scenarios import walk
    from mjchar.controllers.walking.simbicon import DEFAULT_TIMESTEP, make_simbicon

    ch = Character(_bundled_with(tmp_path, "forearm", lElbow_z="0 1 0"),
                   timestep=DEFAULT_TIMESTEP)
    c = make_simbicon(ch)
    r = walk(ch, c, duration=10.0)
    assert not r.fell, r.fall_time_s
    assert r.root_force_max_N == 0.0
    assert r.distance_m > 8.0
    elbow = ch.model.joint("lElbow_z").id
    act = int(np.flatnonzero(ch.model.actuator_trnid[:, 0] == elbow)[0])
    assert c._base[act] == 0.0  # its rest angle


def test_a_knee_hinge_tilted_towards_the_shank_bends_the_leg_by_the_gaits_angle(tmp_path):
    """Both knees' hinges 50 degrees off the lateral axis towards the shank (nearest the vertical:
    refused before as `1 hinge(s) about vertical`): SIMBICON takes the one hinge as the knee and
    turns it so far that the leg bends by the gait's angle."""
    from scipy.spatial.transform import Rotation

    from mjchar.controllers.core.character import Character
    from mjchar.controllers.core.scenarios import walk
    from mjchar.controllers.walking.rig_map import knee_angle
    from mjchar.controllers.walking.simbicon import DEFAULT_TIMESTEP, make_simbicon

    axis = np.array([0.0, 0.64279, 0.76604])
    axis /= np.linalg.norm(axis)
    ch = Character(_bundled_with(tmp_path, "tilted", lKnee_y="0 0.64279 0.76604",
                                 rKnee_y="0 0.64279 0.76604"), timestep=DEFAULT_TIMESTEP)
    c = make_simbicon(ch)
    c.reset(ch)
    across = c._legs[0].knee_across
    assert across == pytest.approx(1 - 0.76604 ** 2, abs=1e-4)
    shank = np.array([0.0, 0.0, -1.0])
    for bend in (0.05, 0.6, 1.1):
        q = knee_angle(bend, across)
        turned = Rotation.from_rotvec(q * axis).apply(shank)
        assert math.acos(turned @ shank) == pytest.approx(bend, abs=1e-5)
    assert knee_angle(0.6, None) == 0.6
    r = walk(ch, c, duration=1.0)
    assert r.root_force_max_N == 0.0
