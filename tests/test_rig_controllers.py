"""Every controller on humanoids converted from other rigs (the zoo rigs).

Fast: a rig whose joint, body, geom, site and actuator names share nothing with the bundled
humanoid (the bundled walk's skeleton with opaque names ``seg00``..., roles found from the
hierarchy's shape, scaled to 1.75 m, centimetres, Z-up) runs every registered controller through
``mjchar run`` (and ``mjchar samcon`` / ``mjchar trajopt`` for the replays), so no code path
depends on the bundled names. Re-rested rigs stand on their hips' width.

Slow: the issue's bars on every rig of the zoo (:mod:`mjchar.bench.skeletons`).
"""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest
from conftest import SHARED_BVH, run_command, shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.assets import HUMANOID_XML, motion_path
from mjchar.bvh.bundled.zoo import all_channels, rename
from mjchar.bvh.mjcf import convert
from mjchar.controllers import registry

OPAQUE_HEIGHT_M = 1.75


def _names(model: mujoco.MjModel) -> set[str]:
    """Body, joint, geom and actuator names (the role sites, ``left_foot``..., are the model
    contract's names, written by the converter on every rig: docs/model-contract.md)."""
    out = set()
    for kind, n in ((mujoco.mjtObj.mjOBJ_BODY, model.nbody), (mujoco.mjtObj.mjOBJ_JOINT,
                    model.njnt), (mujoco.mjtObj.mjOBJ_GEOM, model.ngeom),
                    (mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu)):
        out |= {mujoco.mj_id2name(model, kind, i) for i in range(n)}
    return out - {None, ""}


@pytest.fixture(scope="module")
def opaque_rig(tmp_path_factory):
    """``(bvh path, xml path)`` of the opaque-named rig."""
    from mjchar.bvh.bundled.zoo import _units_axes, stature

    m = bvh.load(motion_path("walk"))
    m = rename(m, {n: f"seg{i:02d}" for i, n in enumerate(m.skeleton.names)})
    m = all_channels(_units_axes(m, OPAQUE_HEIGHT_M / stature(m.skeleton), "cm", "z"), "ZYX")
    folder = tmp_path_factory.mktemp("opaque")
    path = folder / "opaque.bvh"
    bvh.save(m, path)
    c = convert(bvh.load(path), total_mass=80.0)
    xml = folder / "opaque.xml"
    c.save(xml)
    return path, xml


def test_opaque_rig_shares_no_name_with_the_bundled_humanoid(opaque_rig):
    _, xml = opaque_rig
    ours = _names(mujoco.MjModel.from_xml_path(str(xml)))
    bundled = _names(mujoco.MjModel.from_xml_path(str(HUMANOID_XML)))
    # the scene's world and floor, and the free joint "root" the converter names on every rig
    shared = ours & bundled - {"world", "floor", "root"}
    assert not shared, shared
    assert any(n.startswith("seg") for n in ours)


def _run(capsys, argv) -> dict:
    assert run_command(argv) == 0
    return json.loads(capsys.readouterr().out.strip().splitlines()[-1])


# (controller, extra arguments, what must hold): every registered non-replay controller
CASES = {
    "pd": (["--duration", "2"], {}),
    "spd": (["--duration", "2"], {}),
    "native_pd": (["--duration", "2"], {}),
    "hand_of_god": (["--motion", "{bvh}"], {"tracking_error_m": 0.03}),
    "static_balance": (["--scenario", "push", "--push", "50", "--direction", "90",
                        "--duration", "3"], {}),
    "simbicon": (["--duration", "4"], {"distance_m": -1.0}),
    "ipm": (["--duration", "4", "--speed", "1.0"], {"distance_m": -1.5}),
    "mpc": (["--motion", "{bvh}", "--duration", "0.2"], {}),
}


def test_every_controller_is_covered():
    # a learned policy belongs to the model it was trained on (its refusal of another model:
    # tests/test_learned.py)
    runs = set(registry.names()) - set(registry.names("replay")) - {"policy"}
    assert runs == set(CASES)


@pytest.mark.parametrize("name", list(CASES))
def test_every_controller_runs_on_the_opaque_rig(name, opaque_rig, capsys):
    path, xml = opaque_rig
    extra, bars = CASES[name]
    argv = ["run", name, "--model", str(xml), "--json",
            *[a.format(bvh=path) for a in extra]]
    out = _run(capsys, argv)
    assert out["fell"] is False, out
    assert out["root_force_max_N"] == 0.0 or name == "hand_of_god"
    for key, bound in bars.items():
        if bound < 0:  # at least -bound
            assert out[key] >= -bound, (key, out[key])
        else:
            assert out[key] < bound, (key, out[key])


def test_samcon_and_cmaes_replays_run_on_the_opaque_rig(opaque_rig, tmp_path, capsys):
    path, xml = opaque_rig
    s = tmp_path / "s.npz"
    out = _run(capsys, ["samcon", str(path), "--model", str(xml), "-o", str(s), "--duration",
                        "0.3", "--samples", "64", "--saved", "16", "--threads", "2", "--json"])
    assert out["replay"]["fell"] is False
    r = _run(capsys, ["run", "samcon_replay", str(s), "--model", str(xml), "--json"])
    assert r["fell"] is False and r["tracking_error_m"] < 0.06
    c = tmp_path / "c.npz"
    out = _run(capsys, ["trajopt", str(path), "--model", str(xml), "-o", str(c), "--duration",
                        "0.2", "--window", "0.2", "--commit", "0.2", "--generations", "2",
                        "--popsize", "6", "--threads", "2", "--json"])
    assert out["replay"]["fell"] is False
    r = _run(capsys, ["run", "cmaes_replay", str(c), "--model", str(xml), "--json"])
    assert r["fell"] is False


# -- re-rested rigs stand -------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["unreal-cm-zup", "gamestudio-cm-yup"])
def test_a_re_rested_rig_stands_on_its_hips_width(name):
    """The converter re-rests a rig whose bones lie along local axes from a walking frame; the
    legs are made to hang straight and the feet flat, so the rest is a standing pose (before:
    one foot 0.6 m ahead of the other, both on the midline, static balance fell at 2.5 s)."""
    shared_clip("walk60.bvh")
    from mjchar.bvh.bundled.zoo import zoo_rigs
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.core.scenarios import standing_pose

    rig = next(r for r in zoo_rigs(SHARED_BVH, humanoid=False) if r.name == name)
    c = convert(bvh.loads(bvh.dumps(rig.motion)))
    ch = Character(c.compile(), info=c.info)
    q = standing_pose(ch)
    d = mujoco.MjData(ch.model)
    d.qpos[:] = q
    mujoco.mj_kinematics(ch.model, d)
    roles = c.info.roles
    ids = {s: mujoco.mj_name2id(ch.model, mujoco.mjtObj.mjOBJ_BODY, roles[f"{s}_ankle"])
           for s in ("left", "right")}
    hips = {s: mujoco.mj_name2id(ch.model, mujoco.mjtObj.mjOBJ_BODY, roles[f"{s}_hip"])
            for s in ("left", "right")}
    a = {s: d.xpos[i] for s, i in ids.items()}
    h = {s: d.xpos[i] for s, i in hips.items()}
    for s in ("left", "right"):  # each ankle below its hip
        assert np.linalg.norm(a[s][:2] - h[s][:2]) < 0.05, s
    width = np.linalg.norm(a["left"][:2] - a["right"][:2])
    assert width > 0.1  # not on the midline
    assert abs(a["left"][2] - a["right"][2]) < 0.01  # level


# -- the bars on every zoo rig (slow) ------------------------------------------------------
#: the zoo's rigs: 8 made from the shared clips, the bundled humanoid's at 1.5 m and 1.95 m
ZOO_SIZE = 10


def test_the_zoo_has_its_rigs():
    shared_clip("walk60.bvh")
    shared_clip("walk_forward.bvh")
    from mjchar.bvh.bundled.zoo import zoo_rigs

    assert len({r.name for r in zoo_rigs(SHARED_BVH)}) == ZOO_SIZE


@pytest.mark.slow
@pytest.mark.parametrize("rig", range(ZOO_SIZE))
@pytest.mark.parametrize("check", ["stand", "push", "hand_of_god", "samcon"])
def test_zoo_rigs_pass_the_skeleton_checks(check, rig):
    """One check on one rig of the zoo (one test each, so the slow tier's workers share
    them)."""
    shared_clip("walk60.bvh")
    shared_clip("walk_forward.bvh")
    from mjchar.bench.skeletons import SkeletonConfig, run_skeletons
    from mjchar.bvh.bundled.zoo import zoo_rigs

    name = [r.name for r in zoo_rigs(SHARED_BVH)][rig]
    section = run_skeletons(SkeletonConfig(checks=(check,), rigs=(name,)))
    (record,) = section["rigs"]
    assert record["checks"][check]["ok"], (name, record["checks"][check]["summary"])
