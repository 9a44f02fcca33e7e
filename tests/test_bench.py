"""``mjchar bench``: the matrix as data, reproducibility (same seeds, same physics), the JSON
document against its documented schema, the exit status CI gates on, the replay rows and the
plots (the measurements themselves: tests/test_perf.py)."""

from __future__ import annotations

import json
import re
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mjchar import bench as B
from mjchar import cli
from mjchar.bench.config import SHARED_BVH
from mjchar.controllers.core import registry
from mjchar.controllers.core.scenarios import registry as scenario_registry

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def main():
    """``mjchar`` (its bench subcommand)."""
    return cli.main


def tiny(**over) -> B.BenchConfig:
    """A configuration whose runs take a fraction of a second each."""
    cfg = replace(
        B.quick_config(1), stand_duration=0.4, random_push_duration=0.6,
        push_phases=1, push_seeds=1, push_standing_cap=100.0, push_walking_cap=50.0,
        push_resolution=100.0, push_after=0.5, push_warmup=1.0,
        push_directions=("forward",), track_duration=0.4, walk_duration=0.8, steady_window=0.4,
        slope_duration=0.6, slope_distance=0.3,
        perf=B.PerfConfig(raw_steps=100, raw_repeats=1, cost_steps=100, cost_repeats=1,
                          rollout_samples=2, rollout_steps=5, rollout_repeats=1,
                          rollout_threads=(1,), env_steps=5, env_repeats=1, bvh_budget_s=0.01,
                          envelope_duration_s=1.5, envelope_grid=(60,), envelope_finer=(),
                          envelope_kps=(1000.0,)))
    return replace(cfg, **over)


# -- the matrix as data ---------------------------------------------------------------------------
def test_matrix_expectations_and_cli_choices_agree(capsys):
    matrix = B.matrix()
    for name, scenarios in matrix.items():
        assert scenarios and set(scenarios) <= set(scenario_registry.names()), name
    for cell in B.expected_cells():
        assert cell[1] in matrix[cell[0]], cell  # every expectation is a cell of the matrix
    # the brief's gates: static balance stands and survives random pushes, the walkers walk
    for cell in [("static_balance", "stand"), ("static_balance", "random-push"),
                 ("simbicon", "walk"), ("ipm", "walk")]:
        assert cell in B.expected_cells()
    with pytest.raises(SystemExit):
        cli.main(["bench", "--help"])
    text = capsys.readouterr().out
    assert all(name in text for name in matrix)
    assert all(s in text for s in scenario_registry.names())


def test_select_cells_follows_the_matrix_and_rejects_unknown_names():
    cells = B.select_cells(["static_balance", "simbicon"], ["stand", "walk"])
    assert cells == [("static_balance", "stand"), ("simbicon", "walk")]
    assert len(B.select_cells()) == sum(len(v) for v in B.matrix().values())
    with pytest.raises(B.BenchError, match="unknown controller"):
        B.select_cells(["bogus"])
    with pytest.raises(B.BenchError, match="unknown scenario"):
        B.select_cells(None, ["fly"])
    with pytest.raises(B.BenchError, match="no cell"):
        B.select_cells(["hand_of_god"], ["slopes"])


def test_config_checks():
    with pytest.raises(B.BenchError, match="seeds"):
        replace(B.quick_config(), seeds=()).check()
    with pytest.raises(B.BenchError, match="push_phases"):
        replace(B.quick_config(), push_phases=0).check()
    with pytest.raises(B.BenchError, match="push_resolution"):
        replace(B.quick_config(), push_resolution=-5.0).check()
    with pytest.raises(B.BenchError, match="directions"):
        replace(B.quick_config(), push_directions=("up",)).check()
    with pytest.raises(B.BenchError):
        B.quick_config(0)
    q, f = B.quick_config(), B.full_config()
    assert q.quick and not f.quick and q.seeds == (0, 1) and f.seeds == (0, 1, 2)
    assert B.full_config(5).seeds == (0, 1, 2, 3, 4)
    # the push protocol: quick 4 phases x 2 seeds, full 8 phases x 5 seeds; survival judged 5 s
    # after the push (quick walkers: 3 s, past every fall of the quick protocol's runs; standing
    # stays 5 s, the window in which the PD trackers fall unpushed; docs/bench.md)
    qp, fp = q.push_protocol("walking"), f.push_protocol("standing")
    assert (qp.phases, len(qp.seeds), fp.phases, len(fp.seeds)) == (4, 2, 8, 5)
    assert qp.after >= 3.0 and q.push_protocol("standing").after >= 5.0 and fp.after >= 5.0
    assert f.push_protocol("walking").after >= 5.0
    assert fp.full_curves and not qp.full_curves


# -- reproducibility ------------------------------------------------------------------------------
CELLS = [("static_balance", "stand"), ("static_balance", "random-push"), ("spd", "push-search"),
         ("hand_of_god", "track"), ("simbicon", "walk"), ("ipm", "walk")]


def _matrix(cfg):
    controllers, cells, _ = B.run_matrix(CELLS, cfg, trajectories={}, progress=False)
    doc = {"controllers": controllers, "cells": cells, "performance": None, "seeds":
           list(cfg.seeds), "config": cfg.to_dict()}
    doc["table"] = B.table_rows(doc)
    doc["expectations"] = B.check_expectations(doc)
    return doc


def test_same_seeds_give_the_same_table_and_other_seeds_differ():
    cfg = tiny(seeds=(0, 1))
    a, b = _matrix(cfg), _matrix(cfg)
    pa, pb = B.physics_view(a), B.physics_view(b)
    assert pa == pb  # every physics number, series included, bit for bit
    assert B.format_table([{**r, "step_cost_ratio": None} for r in a["table"]]) == \
        B.format_table([{**r, "step_cost_ratio": None} for r in b["table"]])
    # the timings are there but are not part of the comparison
    assert all("wall_s" in r["result"] for c in a["cells"] for r in c["runs"])
    # random-push really uses the seeds: the two seeds' runs differ
    rp = next(c for c in a["cells"] if c["scenario"] == "random-push")
    assert [r["seed"] for r in rp["runs"]] == [0, 1]
    s0, s1 = (r["series"]["com_m"] for r in rp["runs"])
    assert s0 != s1
    # the walkers too: both walk cells ran, every run recorded its COM
    walks = [c for c in a["cells"] if c["scenario"] == "walk"]
    assert len(walks) == 2
    for w in walks:
        assert w["status"] == "ok", w["reason"]
        assert w["runs"] and all(r["series"]["com_m"] for r in w["runs"])
    c = _matrix(tiny(seeds=(2,)))
    rp2 = next(x for x in c["cells"] if x["scenario"] == "random-push")
    assert rp2["runs"][0]["series"]["com_m"] != s0


def test_the_job_count_does_not_change_the_results():
    # a push search (runs spread over the pool), the MPC (threads of its own: 2 with one job,
    # 1 with two on a 2-core machine), a walker and a tracker
    cells = [("static_balance", "push-search"), ("mpc", "track"), ("simbicon", "walk"),
             ("hand_of_god", "track")]
    cfg = tiny(push_standing_cap=200.0, push_directions=("forward", "left"))
    views, cpu = [], {}
    for jobs in (1, 2):
        controllers, out, _ = B.run_matrix(cells, cfg, trajectories={}, progress=False,
                                           jobs=jobs, cpu=cpu)
        assert [(c["controller"], c["scenario"]) for c in out] == cells  # the given order
        assert all(c["status"] == "ok" for c in out), [c["reason"] for c in out]
        doc = {"controllers": controllers, "cells": out, "performance": None,
               "seeds": list(cfg.seeds), "config": cfg.to_dict()}
        doc["table"] = B.table_rows(doc)
        doc["expectations"] = B.check_expectations(doc)
        views.append(B.physics_view(doc))
    assert views[0] == views[1]
    assert set(cpu) == {f"{c} / {s}" for c, s in cells} and all(v > 0 for v in cpu.values())
    with pytest.raises(B.BenchError, match="jobs"):
        B.run_matrix(cells[:1], cfg, progress=False, jobs=0)


def test_help_states_what_quick_and_the_full_run_take(main, capsys):
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--jobs" in text
    assert "2-core machine where one core does 30,000 bare mj_step/s" in text
    assert re.search(r"--quick about \d+ minutes", text)
    assert re.search(r"the full run about \d+ (minutes|hours?)", text)


def test_cells_measure_what_the_table_reports():
    doc = _matrix(tiny())
    cells = {(c["controller"], c["scenario"]): c for c in doc["cells"]}
    sb = cells[("static_balance", "stand")]
    assert sb["status"] == "ok" and sb["runs"][0]["survived"]
    assert sb["runs"][0]["result"]["sim_time_s"] == pytest.approx(0.4, abs=0.01)
    ps = cells[("spd", "push-search")]["summary"]
    assert set(ps["max_push_by_direction_N"]) == {"forward"}
    assert "on the pelvis" in ps["push_protocol"] and "1 x 1 seeds" in ps["push_protocol"]
    assert ps["falls_unpushed"] is False and ps["push_at_cap"] == {"forward": True}
    push = cells[("spd", "push-search")]["runs"][0]["push"]
    assert len(push["runs"]) == 1 and push["runs"][0]["force_N"] == 100.0  # every run recorded
    hog = cells[("hand_of_god", "track")]["runs"][0]
    assert hog["series"]["tracking_error_m"] is not None
    assert len(hog["series"]["tracking_error_m"]) == len(hog["series"]["t_s"])
    # the per-time errors average to about the Result's mean error (20 Hz vs 120 Hz sampling)
    assert np.mean(hog["series"]["tracking_error_m"]) == pytest.approx(
        hog["result"]["tracking_error_m"], rel=0.5)
    rows = {r["controller"]: r for r in doc["table"]}
    assert rows["hand_of_god"]["root_force_mean_N"] > 100  # the string carries the weight
    assert rows["static_balance"]["root_force_mean_N"] == 0.0
    assert rows["static_balance"]["survived"] == rows["static_balance"]["runs"] == 2
    assert rows["hand_of_god"]["motion_source"] == "track"


# -- expectations and exit status -----------------------------------------------------------------
def test_expectations_fail_on_a_fall_and_skip_unavailable():
    cfg = tiny(track_duration=1.6)
    controllers, cells, _ = B.run_matrix([("spd", "track"), ("samcon_replay", "track")], cfg,
                                         trajectories={}, progress=False)
    doc = {"controllers": controllers, "cells": cells}
    spd = cells[0]
    assert spd["runs"][0]["result"]["fell"]  # stable PD alone falls tracking a walk (~0.9 s)
    expected = B.expected_cells() + (("spd", "track"), ("samcon_replay", "track"))
    ex = {(e["controller"], e["scenario"]): e for e in B.check_expectations(doc, expected)}
    assert ex[("spd", "track")]["status"] == "fail" and "fell at" in ex[("spd", "track")]["detail"]
    assert ex[("samcon_replay", "track")]["status"] == "skipped"
    assert "not available" in ex[("samcon_replay", "track")]["detail"]
    assert ex[("static_balance", "stand")]["status"] == "skipped"  # not selected
    assert B.exit_status({"expectations": list(ex.values())}) == 1
    assert B.exit_status({"expectations": [e for e in ex.values()
                                           if e["status"] != "fail"]}) == 0


def test_cli_exit_status_gates_on_falls(main, tmp_path, monkeypatch, capsys):
    small, failing = tiny(), tiny(track_duration=1.6)
    monkeypatch.setattr(B, "quick_config", lambda seeds=None: small)
    out = tmp_path / "ok"
    code = main(["bench", "--quick", "--controllers", "static_balance", "--scenarios", "stand",
                 "--out", str(out), "--no-perf", "--quiet"])
    text = capsys.readouterr().out
    assert code == 0
    assert "static_balance" in text and "PASS" in text
    doc = json.loads((out / "results.json").read_text())
    assert doc["cells"][0]["runs"][0]["survived"] and doc["config"]["quick"]
    assert (out / "table.md").read_text().startswith("| controller |")
    # spd tracking a walk falls; register it as an expected survivor: exit status 1
    monkeypatch.setattr(B, "quick_config", lambda seeds=None: failing)
    spd = registry.get("spd")
    registry.register(replace(spd, name="spd_expected", bench=("track",),
                             expected=("track",)))
    try:
        code = main(["bench", "--quick", "--controllers", "spd_expected", "--scenarios",
                     "track", "--out", str(tmp_path / "fail"), "--no-perf", "--no-plots",
                     "--quiet"])
    finally:
        registry.unregister("spd_expected")
    captured = capsys.readouterr()
    assert code == 1
    assert "FAIL" in captured.out and "FAILED" in captured.err


def test_cli_rejects_bad_options(main, capsys):
    with pytest.raises(SystemExit) as e:
        main(["bench", "--controllers", "bogus"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        main(["bench", "--seeds", "0"])
    assert e.value.code == 2
    assert main(["bench", "--samcon-trajectory", "/nonexistent/x.npz", "--no-perf"]) == 2
    assert "not found" in capsys.readouterr().err


# -- replays --------------------------------------------------------------------------------------
def _standing_trajectory(path: Path) -> Path:
    """A trivial saved trajectory: hold the standing pose's targets for 0.6 s."""
    from mjchar.controllers.core import scenarios as S
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.sampling.trajectory import Trajectory

    ch = Character()
    q = S.standing_pose(ch)
    n = 6
    targets = np.repeat(q[ch.actuator_qpos][None], n, axis=0)
    tr = Trajectory.for_model(ch.model, targets, 0.1, q, np.zeros(ch.nv),
                              reference_qpos=np.repeat(q[None], n + 1, axis=0),
                              metadata={"method": "samcon"})
    return tr.save(path)


def test_replay_rows_use_saved_trajectories(tmp_path):
    ok, why = B.availability("samcon_replay", {})
    assert not ok and "no saved trajectory" in why
    assert B.find_trajectories(tmp_path) == {}
    _standing_trajectory(tmp_path / "samcon_stand.npz")
    found = B.find_trajectories(tmp_path)
    assert set(found) == {"samcon_replay"}
    controllers, cells, _ = B.run_matrix([("samcon_replay", "track"), ("cmaes_replay", "track")],
                                         tiny(), trajectories=found, progress=False)
    assert controllers["samcon_replay"]["available"]
    assert not controllers["cmaes_replay"]["available"]
    run = cells[0]["runs"][0]
    assert cells[0]["status"] == "ok" and run["survived"]
    assert run["result"]["controller"] == "samcon_replay"
    assert run["result"]["sim_time_s"] == pytest.approx(0.6, abs=0.01)
    # holding the pose it started in: the stored reference is tracked closely
    assert run["result"]["tracking_error_m"] < 0.01
    assert cells[1]["status"] == "not available" and cells[1]["runs"] == []
    rows = {r["controller"]: r for r in B.table_rows({"controllers": controllers,
                                                      "cells": cells})}
    text = B.format_table(list(rows.values()))
    assert "cmaes_replay: not available: no saved trajectory" in text
    # a damaged file is a "not available" row with the loader's message, not a crash
    bad = tmp_path / "cmaes_broken.npz"
    bad.write_bytes(b"not a zip archive")
    controllers, cells, _ = B.run_matrix([("cmaes_replay", "track")], tiny(),
                                         trajectories={"cmaes_replay": bad}, progress=False)
    assert not controllers["cmaes_replay"]["available"]
    assert "cmaes_broken.npz" in controllers["cmaes_replay"]["reason"]
    assert cells[0]["status"] == "not available"


def test_policy_row_tracks_its_own_looped_clip_for_the_track_runs_length():
    """The bundled policy follows the clip it was trained on, looped as trained, for as long
    as the other rows' track run (``track_duration`` here), and gets a step cost."""
    from mjchar.controllers.learned import find_policy

    assert "track" in B.matrix()["policy"] and B.availability("policy") == (True, None)
    policy = find_policy(None)
    controllers, cells, _ = B.run_matrix([("policy", "track")], tiny(track_duration=0.5),
                                         trajectories={}, progress=False)
    run = cells[0]["runs"][0]
    assert cells[0]["status"] == "ok" and controllers["policy"]["available"]
    assert run["result"]["sim_time_s"] == pytest.approx(0.5, abs=0.01)
    assert run["result"]["root_force_mean_N"] == 0.0
    assert run["variant"] == Path(policy.meta["clip"]["name"]).name + " (looped)"
    doc = B.run_performance(["policy"], tiny(), progress=False, parts=("cost",))
    cost = doc["cost"]["controllers"]["policy"]
    assert cost["available"], cost["reason"]
    assert cost["timestep_s"] == pytest.approx(policy.meta["env"]["timestep"])


# -- the JSON document, its schema, the plots -----------------------------------------------------
@pytest.fixture(scope="module")
def tiny_doc(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    doc = B.run_bench(tiny(), controllers=["spd", "static_balance", "simbicon"],
                      scenarios=["stand", "push-search", "walk"], out_dir=out, progress=False,
                      trajectories={}, command=["mjchar", "bench", "(test)"])
    return out, doc


def test_results_json_matches_the_documented_schema(tiny_doc):
    out, doc = tiny_doc
    written = json.loads((out / "results.json").read_text())
    schema = B.load_schema()
    assert B.validate(written, schema) == []
    assert written["versions"]["mujoco"] and written["versions"]["numpy"]
    assert written["versions"]["mjchar"] != "unknown"
    assert written["seeds"] == [0]
    assert {c["controller"] for c in written["cells"]} == {"spd", "static_balance", "simbicon"}
    # every part of the performance section ran (or says why not)
    for part in ("raw", "cost", "rollout", "envs", "bvh", "envelope"):
        assert part in written["performance"], part
    assert written["performance"]["raw"]["available"]
    cost = written["performance"]["cost"]["controllers"]
    assert set(cost) == {"spd", "static_balance", "simbicon"}
    assert all(c["available"] and c["ratio"] > 0 for c in cost.values())


def test_validator_reports_schema_violations(tiny_doc):
    _, doc = tiny_doc
    good = json.loads(json.dumps(B.json_ready(doc)))
    bad = json.loads(json.dumps(good))
    del bad["versions"]["numpy"]
    bad["cells"][0]["status"] = "great"
    bad["cells"][0]["runs"][0]["result"]["fell"] = "no"
    bad["table"][0]["surprise"] = 1
    errs = B.validate(bad)
    text = "\n".join(errs)
    assert "$.versions: 'numpy' is a required property" in text
    assert "$.cells[0].status: 'great' is not one of" in text
    assert "$.cells[0].runs[0].result.fell: 'no' is not of type 'boolean'" in text
    assert "'surprise' was unexpected" in text


def test_plots_are_written(tiny_doc):
    out, doc = tiny_doc
    assert set(doc["plots"]) == {"push_search.png", "com_trajectories.png",
                                 "stability_envelope.png", "step_cost.png", "gait_cycle.png"}
    for name in doc["plots"]:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000


def test_gait_section(tiny_doc):
    """Every walker's walk and the mocap walks, measured by one probe, in the document and in
    table.md."""
    out, doc = tiny_doc
    labels = [w["label"] for w in doc["gait"]["walks"]] + list(doc["gait"]["skipped"])
    assert {"simbicon walk", "simbicon natural"} <= set(labels)
    assert doc["gait"]["speed_mps"] == 1.2
    if (SHARED_BVH / "walk60.bvh").is_file():
        assert "walk60" in labels
    for w in doc["gait"]["walks"]:  # every walk walked; cycle curves where a stride was seen
        assert w["speed_mps"] > 0.2, w["label"]  # 0.8 s from standing: it set off
        if w["strides"]:
            assert len(w["cycle_mean"]["trunk_lean"]) == 101, w["label"]
        else:
            assert w["cycle_mean"] == {}, w["label"]
    if (SHARED_BVH / "walk60.bvh").is_file():  # the clip has a whole stride: curves
        clip = next(w for w in doc["gait"]["walks"] if w["label"] == "walk60")
        assert clip["strides"] >= 1 and len(clip["cycle_mean"]["trunk_lean"]) == 101
    assert "Gait (walkers at 1.2 m/s:" in (out / "table.md").read_text()


def test_gait_walks_are_issue_14s_comparison():
    """Walkers that take a speed walk at gait_speed (1.2 m/s, the mocap walks' speed); walkers
    with gaits walk once per gait; controllers that do not walk have no gait row."""
    from mjchar.bench.gait import gait_walks

    cfg = B.quick_config()
    walks = gait_walks(cfg, ["static_balance", "simbicon", "ipm"])
    assert walks == [("simbicon walk", "simbicon", {"speed": 1.2, "gait": "walk"}),
                     ("simbicon natural", "simbicon", {"speed": 1.2, "gait": "natural"}),
                     ("ipm", "ipm", {"speed": 1.2})]
    for bad in ((), "walk", ("walk", "no-such-gait"), ("crouch",)):
        with pytest.raises(B.BenchError, match="gait_gaits"):
            replace(cfg, gait_gaits=bad).check()


def test_videos_give_stills_and_a_walk_strip(tmp_path):
    pytest.importorskip("imageio_ffmpeg", reason="videos need the video extra")
    doc = B.run_bench(tiny(walk_duration=1.2), controllers=["ipm", "simbicon"],
                      scenarios=["walk"], out_dir=tmp_path, progress=False, videos=True,
                      performance=False, trajectories={})
    assert {v["file"] for v in doc["videos"]} == {"ipm_walk.mp4", "simbicon_walk.mp4"}
    assert all(v["frames"] >= 30 for v in doc["videos"])  # 1.2 s at 30 fps
    assert {"stills/ipm_walk.png", "stills/simbicon_walk.png", "still.png",
            "walk_strip.png"} <= set(doc["stills"])
    import imageio.v2 as imageio

    strip = imageio.imread(tmp_path / "walk_strip.png")
    assert strip.shape[0] > strip.shape[1] / 8  # two rows of frames, not an empty figure
    assert strip[..., :3].std() > 20  # it shows pictures
    # the gait section's filmstrip: every analysed walk (walkers, mocap) over one stride
    if doc["gait"]["walks"]:
        assert doc["gait"]["filmstrip"] == "gait_filmstrip.png"
        assert "gait_filmstrip.png" in doc["plots"]
        film = imageio.imread(tmp_path / "gait_filmstrip.png")
        assert film[..., :3].std() > 20


def test_missing_matplotlib_is_a_clear_error(monkeypatch):
    from mjchar.bench import plots as bench_plots

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(B.BenchError, match=r"mjchar\[bench\]"):
        bench_plots.require_matplotlib()


def test_skeletons_section(tmp_path, main, capsys):
    """``--skeletons``: rigs written and converted, checks in results.json (schema) and
    table.md; a failed check fails the exit status."""
    from mjchar.bench.skeletons import SkeletonConfig

    cfg = SkeletonConfig(stand_duration=1.0, checks=("stand", "hand_of_god"),
                         rigs=("humanoid-150-m-zup",))
    doc = B.run_bench(tiny(), matrix=False, skeletons=cfg, out_dir=tmp_path, progress=False,
                      plots=False, trajectories={})
    written = json.loads((tmp_path / "results.json").read_text())
    assert B.validate(written, B.load_schema()) == []
    (rig,) = written["skeletons"]["rigs"]
    assert rig["rig"] == "humanoid-150-m-zup" and rig["mass_kg"] == 50.0
    assert rig["conversion"]["model_mass_kg"] == pytest.approx(50.0, rel=1e-3)
    assert rig["checks"]["stand"]["ok"] and rig["checks"]["hand_of_god"]["ok"]
    assert (tmp_path / "skeletons" / "humanoid-150-m-zup.xml").is_file()
    assert "| humanoid-150-m-zup |" in (tmp_path / "table.md").read_text()
    assert written["cells"] == [] and B.exit_status(doc) == 0
    doc["skeletons"]["rigs"][0]["checks"]["stand"]["ok"] = False
    assert B.exit_status(doc) == 1
    with pytest.raises(B.BenchError, match="unknown zoo rig.*humanoid-150-m-zup"):
        B.run_bench(tiny(), matrix=False, skeletons=SkeletonConfig(rigs=("nope",)),
                    progress=False, plots=False)
    assert main(["bench", "--skeletons-only", "--controllers", "spd"]) == 2
    assert "--skeletons-only runs no matrix" in capsys.readouterr().err


def test_skeletons_walker_checks_command_speeds():
    """The walking checks command every configured speed at every seed and report each run;
    the summary names the speeds, and a speed out of the band fails the check."""
    from mjchar.bench.skeletons import SkeletonConfig, run_skeletons

    cfg = SkeletonConfig(checks=("simbicon", "ipm"), rigs=("humanoid-150-m-zup",),
                         walk_duration=4.0, steady_window=2.0, seeds=(0,),
                         simbicon_speeds=(0.9, 1.2), ipm_speed=0.6, speed_tolerance=0.3)
    (rig,) = run_skeletons(cfg, shared_bvh=None)["rigs"]
    sim, ipm = rig["checks"]["simbicon"], rig["checks"]["ipm"]
    assert sorted(sim["runs"]) == ["0.9/0", "1.2/0"] and list(ipm["runs"]) == ["0.6/0"]
    assert "at 0.9, 1.2 m/s" in sim["summary"]
    for check in (sim, ipm):
        assert not any(r["fell"] for r in check["runs"].values())
    assert sim["runs"]["1.2/0"]["steady_speed_mps"] > sim["runs"]["0.9/0"]["steady_speed_mps"]
    strict = run_skeletons(SkeletonConfig(checks=("ipm",), rigs=("humanoid-150-m-zup",),
                                          walk_duration=2.0, steady_window=1.0, seeds=(0,),
                                          ipm_speed=1.2, speed_tolerance=0.01),
                           shared_bvh=None)["rigs"][0]["checks"]["ipm"]
    assert not strict["ok"] and "m/s seed 0 at" in strict["summary"]
