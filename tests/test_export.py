"""Simulated motion exported as BVH (mjchar.bvh.reference.export, MotionRecorder,
``--export-bvh``).

The bar: the exported clip is on the skeleton the model was converted from (its joint names,
channel orders, units, frame rate), and converting it back with ``joint_model="full"`` and
replaying it reproduces the simulated joint positions within 1 mm, on the bundled humanoid and
on a CMU-style rig (CMU names, ZYX channels, inches) made from a shared clip.
"""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest
from bvh_variants import CMU_NAMES, cmu_style
from conftest import shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.assets import TRAJECTORIES, humanoid_path, motion_path
from mjchar.bvh.mjcf import ConversionError, ModelInfo, convert
from mjchar.bvh.reference.export import ExportError, MotionRecorder, qpos_to_motion, resample_qpos
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.cli import main
from mjchar.controllers import registry
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.character import Character

TOLERANCE_M = 1e-3


def _joint_positions(model: mujoco.MjModel, info: ModelInfo, qpos: np.ndarray) -> dict:
    """``{BVH joint name: (F, 3)}`` world positions of every kept joint's body."""
    data = mujoco.MjData(model)
    ids = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, j.body)
           for n, j in info.joints.items()}
    out = {n: np.empty((len(qpos), 3)) for n in ids}
    for f, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for n, b in ids.items():
            out[n][f] = data.xpos[b]
    return out


def round_trip_error(recorder: MotionRecorder, path, fps=None) -> tuple[float, bvh.Motion]:
    """Save the recording to ``path``, convert that file back with ``joint_model="full"``, replay
    it, and return the largest distance (m) between a replayed and a simulated joint (the
    replay's floor placement taken off: the file's own coordinates, scaled and rotated, are
    compared with the simulation's), and the loaded file."""
    written = recorder.save_bvh(path, fps=fps)
    model = recorder.model
    info = ModelInfo.from_model(model)
    _, sim_q = resample_qpos(model, np.array(recorder.times), np.array(recorder.qpos), written.fps)
    sim = _joint_positions(model, info, sim_q)

    loaded = bvh.load(path)
    back = convert(loaded, joint_model="full", total_mass=50.0)
    model2 = mujoco.MjModel.from_xml_string(back.xml)
    ref = ReferenceMotion(model2, loaded, info=back.info)
    q2 = ref.frame_qpos.copy()
    q2[:, model2.jnt_qposadr[0] + 2] -= ref.z_offset + ref.grounding
    replayed = _joint_positions(model2, back.info, q2)
    assert len(q2) == len(sim_q)
    common = sorted(set(sim) & set(replayed))
    assert len(common) >= 15, common
    err = max(float(np.linalg.norm(replayed[n] - sim[n], axis=1).max()) for n in common)
    return err, loaded


def _track(model, clip, controller="hand_of_god", duration=None) -> MotionRecorder:
    character = Character(model)
    if registry.get(controller).timestep:
        character.set_timestep(registry.get(controller).timestep)
    reference = ReferenceMotion(character.model, bvh.load(clip), info=character.info)
    ctrl = registry.make_controller(controller, character, reference)
    rec = MotionRecorder()
    result = S.run_scenario("track", character, ctrl, reference=reference, duration=duration,
                            frame_callback=rec)
    assert not result.fell
    return rec


def _rig_round_trip(rig: tuple, path) -> tuple[bvh.Motion, bvh.Motion]:
    """Track a second of a converted rig's clip (``rig``: the clip and its model) and check its
    round trip through ``path`` (:func:`round_trip_error` within the tolerance, the clip's joint
    names and channels kept); returns the exported clip and the rig's own."""
    clip, xml = rig
    rec = _track(str(xml), clip, duration=1.0)
    err, loaded = round_trip_error(rec, path)
    assert err < TOLERANCE_M, f"{err * 1000:.3f} mm"
    source = bvh.load(clip)
    assert loaded.skeleton.names == source.skeleton.names
    assert loaded.skeleton.channels == source.skeleton.channels
    return loaded, source


@pytest.fixture(scope="module")
def cmu_rig(tmp_path_factory):
    """A CMU-style rig converted (default options) from walk60 re-expressed in CMU style."""
    clip = tmp_path_factory.mktemp("cmu") / "cmu_walk60.bvh"
    bvh.save(cmu_style(bvh.load(shared_clip("walk60.bvh"))), clip)
    conv = convert(clip)
    xml = clip.with_suffix(".xml")
    conv.save(xml)
    return clip, xml


def test_the_bundled_humanoid_keeps_its_source_skeleton():
    from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton

    info = ModelInfo.from_model(mujoco.MjModel.from_xml_path(str(humanoid_path())))
    skeleton, frame_time = info.source()
    ref = humanoid_skeleton()
    assert skeleton.names == ref.names and skeleton.channels == ref.channels
    np.testing.assert_allclose(skeleton.offsets, ref.offsets, atol=1e-9)
    assert frame_time is None                         # converted from a bare skeleton


def test_bundled_track_round_trip(tmp_path):
    rec = _track(None, motion_path("walk"), duration=1.0)
    err, loaded = round_trip_error(rec, tmp_path / "hog.bvh")
    assert err < TOLERANCE_M, f"{err * 1000:.3f} mm"
    assert loaded.frame_time == pytest.approx(1 / 60, rel=1e-6)   # no source clip: 60 fps
    assert loaded.n_frames == 61


def test_cmu_rig_round_trip_keeps_names_channels_units(cmu_rig, tmp_path):
    loaded, source = _rig_round_trip(cmu_rig, tmp_path / "cmu_sim.bvh")
    assert set(loaded.skeleton.names) == set(CMU_NAMES.values())
    assert loaded.skeleton.channels[1] == ("Zrotation", "Yrotation", "Xrotation")
    np.testing.assert_allclose(loaded.skeleton.offsets, source.skeleton.offsets, atol=1e-6)
    assert loaded.frame_time == pytest.approx(source.frame_time, rel=1e-4)
    # inches: the hips stand about 0.93 m / 0.0254 = 37 units above the feet
    assert 30 < loaded.root_positions[:, 1].mean() < 45


def test_export_fps_resamples(tmp_path):
    rec = _track(None, motion_path("walk"), duration=0.5)
    err, loaded = round_trip_error(rec, tmp_path / "a.bvh", fps=24)
    assert loaded.frame_time == pytest.approx(1 / 24, rel=1e-6)
    assert loaded.n_frames == 13                      # 0, 1/24, ..., 12/24 s
    assert err < TOLERANCE_M


def test_cli_export(tmp_path, capsys):
    out = tmp_path / "stand.bvh"
    assert main(["run", "static_balance", "--duration", "0.5", "--export-bvh", str(out),
                 "--export-fps", "30", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["export_bvh"] == str(out) and res["export_frames"] == 16
    loaded = bvh.load(out)
    assert loaded.n_frames == 16 and loaded.frame_time == pytest.approx(1 / 30, rel=1e-6)


def test_cli_replay_export(tmp_path, capsys):
    out = tmp_path / "replay.bvh"
    assert main(["run", "replay", str(TRAJECTORIES / "samcon_walk60.npz"), "--duration", "0.5",
                 "--export-bvh", str(out)]) == 0
    assert "BVH:" in capsys.readouterr().out
    assert bvh.load(out).n_frames == 31


def test_model_without_source_is_a_clear_error(tmp_path):
    info = Character(None).info
    stripped = ModelInfo.from_dict({k: v for k, v in info.to_dict().items() if k != "source"})
    with pytest.raises(ConversionError, match="convert the BVH again"):
        stripped.source()


def test_nothing_recorded_is_a_clear_error():
    with pytest.raises(ExportError, match="nothing was recorded"):
        MotionRecorder().to_motion()


def test_bad_times_are_refused():
    model = Character(None).model
    q = np.tile(model.qpos0, (3, 1))
    with pytest.raises(ExportError, match="increase"):
        qpos_to_motion(model, [0.0, 0.0, 0.1], q)
    with pytest.raises(ExportError, match="positive"):
        qpos_to_motion(model, [0.0, 0.1, 0.2], q, fps=0)


# -- the acceptance runs (slow) ---------------------------------------------------------------
def _walk(model, controller="simbicon", duration=5.0) -> MotionRecorder:
    character = Character(model)
    spec = registry.get(controller)
    if spec.timestep:
        character.set_timestep(spec.timestep)
    ctrl = registry.make_controller(controller, character, None)
    rec = MotionRecorder()
    result = S.run_scenario("walk", character, ctrl, duration=duration, frame_callback=rec)
    assert not result.fell
    return rec


def _replay(trajectory, model=None) -> MotionRecorder:
    from mjchar.controllers.sampling.trajectory import replay

    rec = MotionRecorder()
    result = replay(trajectory, model=model, frame_callback=rec)
    assert not result.fell
    return rec


@pytest.mark.slow
def test_bundled_acceptance_round_trips(tmp_path):
    runs = {"simbicon_5s": _walk(None),
            "hand_of_god_walk60": _track(None, shared_clip("walk60.bvh")),
            "samcon_replay": _replay(TRAJECTORIES / "samcon_walk60.npz")}
    errors = {k: round_trip_error(r, tmp_path / f"{k}.bvh")[0] for k, r in runs.items()}
    assert max(errors.values()) < TOLERANCE_M, errors


@pytest.mark.slow
def test_cmu_rig_acceptance_round_trips(cmu_rig, tmp_path):
    from mjchar.controllers.sampling.samcon import Samcon, SamconOptions

    clip, xml = cmu_rig
    character = Character(str(xml))
    reference = ReferenceMotion(character.model, bvh.load(clip), info=character.info)
    with Samcon(reference, model=str(xml), options=SamconOptions(duration=1.0)) as samcon:
        trajectory = samcon.run(progress=False).trajectory
    runs = {"simbicon_5s": _walk(str(xml)),
            "hand_of_god_walk60": _track(str(xml), clip),
            "samcon_replay": _replay(trajectory, model=str(xml))}
    errors = {k: round_trip_error(r, tmp_path / f"{k}.bvh")[0] for k, r in runs.items()}
    assert max(errors.values()) < TOLERANCE_M, errors


@pytest.fixture(scope="module")
def rerooted_rig(tmp_path_factory):
    """The zoo's Unreal-style rig (a static ``root`` node above ``pelvis``, bones along local
    axes, so the converter folds the root and takes a new rest pose), as a file and its model."""
    from mjchar.bvh.bundled.zoo import zoo_rigs

    shared_clip("walk60.bvh")
    rig = next(r for r in zoo_rigs(shared_clip("walk60.bvh").parent) if r.name.startswith("unreal"))
    clip = tmp_path_factory.mktemp("unreal") / f"{rig.name}.bvh"
    bvh.save(rig.motion, clip)
    conv = convert(clip, total_mass=rig.mass_kg)
    assert conv.info.extra["rig"]["fold"] and conv.info.extra["rig"]["rest"]
    xml = clip.with_suffix(".xml")
    conv.save(xml)
    return clip, xml


def test_a_normalised_rig_exports_on_its_own_skeleton(rerooted_rig, tmp_path):
    """The export undoes the converter's normalisation: the file's static root node, its rest
    pose (bones along local axes) and channels come back, and every joint below the folded node
    is where the simulation had it."""
    loaded, source = _rig_round_trip(rerooted_rig, tmp_path / "unreal_sim.bvh")
    np.testing.assert_allclose(loaded.skeleton.offsets, source.skeleton.offsets, atol=1e-6)
    # the static node stays where the file holds it
    np.testing.assert_allclose(loaded.root_positions - source.root_positions[0], 0.0, atol=1e-6)


def test_export_of_a_normalised_clip_replay_matches_the_clip(rerooted_rig):
    """Replaying the clip itself (``joint_model="full"``) and exporting gives the clip back: every
    joint below the folded node within 0.01 mm, up to one constant floor shift."""
    clip, _ = rerooted_rig
    source = bvh.load(clip)
    conv = convert(source, joint_model="full")
    model = mujoco.MjModel.from_xml_string(conv.xml)
    ref = ReferenceMotion(model, source, info=conv.info, floor="clip")  # one shift for the clip
    n = min(source.n_frames, 40)
    out = qpos_to_motion(model, np.arange(n) * source.frame_time, ref.frame_qpos[:n],
                         fps=1.0 / source.frame_time, info=conv.info)
    below = [i for i, name in enumerate(out.skeleton.names)
             if name not in conv.info.extra["rig"]["fold"]]
    d = (bvh.forward_kinematics(out).positions - bvh.forward_kinematics(source).positions[:n])
    d = d[:, below]
    d -= d.mean(axis=(0, 1))
    assert np.abs(d).max() * conv.info.unit_scale < 1e-5
