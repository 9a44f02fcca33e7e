"""``mjchar.perf``: the measurements' outcomes and bookkeeping, never their timings (no
thresholds on speed: a shared machine makes any of them flaky).

- The one timing primitive: :func:`timed` returns what the call returned and non-negative times
  on three clocks; :func:`rounds` takes turns in order, repeats, warms up, resets untimed.
- Every timing of the package goes through it: no other module reads a clock itself.
- The measurements report finite, positive numbers and say why an optional part is unavailable.
- The entry points (``python -m mjchar.perf.<name>``) parse their options; ``--write`` rewrites
  only its block of a docs page.
"""

from __future__ import annotations

import ast
import importlib
import math
import sys
from pathlib import Path

import pytest

from mjchar import perf
from mjchar.controllers.core import registry
from mjchar.perf import report
from mjchar.perf.timing import Timing, rounds, timed

PERF = Path(perf.__file__).parent
ENTRY_POINTS = ("pd", "rollouts", "envs", "bvh", "simbicon", "ipm", "mpc", "samcon", "speed")


# -- the timing primitive -----------------------------------------------------------------------
def test_timed_returns_the_result_and_three_clocks():
    out, t = timed(lambda a, b=0: a + b, 2, b=3)
    assert out == 5
    assert all(v >= 0 for v in (t.wall_s, t.cpu_s, t.thread_s))
    assert (t + t).wall_s == 2 * t.wall_s and t.on("cpu_s") == t.cpu_s
    with pytest.raises(perf.PerfError, match="wall_s"):
        t.on("gpu_s")


def test_rounds_take_turns_repeat_warm_up_and_reset_untimed():
    calls: list[str] = []
    resets: list[str] = []
    runs = rounds({"a": lambda: calls.append("a") or 1, "b": lambda: calls.append("b") or 2},
                  repeats=3, calls={"b": 2}, warmup=True, before=resets.append,
                  keep_results=True)
    assert calls == ["a", "b"] + ["a", "b", "b"] * 3
    assert resets == calls
    assert len(runs["a"].timings) == 3 and len(runs["b"].timings) == 6
    assert runs["b"].results == [2] * 6
    best = runs["b"].best("wall_s")
    assert best.wall_s == min(t.wall_s for t in runs["b"].timings)
    assert runs["a"].median("cpu_s") in runs["a"].timings
    assert isinstance(runs["a"].total(), Timing)
    budgeted = rounds({"x": lambda: 1}, repeats=2, budget_s=0.01, max_rounds=5)
    assert 2 <= len(budgeted["x"].timings) <= 5 and budgeted["x"].results == []
    with pytest.raises(perf.PerfError):
        rounds({"x": lambda: None}, repeats=0)


def _clock_reads(path: Path) -> list[str]:
    names = {"perf_counter", "process_time", "thread_time", "monotonic", "time"}
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if (isinstance(node, ast.Attribute) and node.attr in names
                and isinstance(node.value, ast.Name) and node.value.id == "time"):
            found.append(f"{path.name}:{node.lineno} time.{node.attr}")
    return found


def test_every_measurement_times_through_the_one_primitive():
    """Only :mod:`mjchar.perf.timing` reads a clock; the bench's performance section times its
    parts with it too."""
    files = [p for p in PERF.glob("*.py") if p.name != "timing.py"]
    files.append(PERF.parent / "bench" / "performance.py")
    assert not [r for f in files for r in _clock_reads(f)]


def test_no_path_manipulation_in_the_measurements():
    for f in PERF.glob("*.py"):
        assert "sys.path" not in f.read_text(), f.name


# -- the measurements: outcomes, not timings ----------------------------------------------------
def test_envelope_separates_explicit_from_stable_pd():
    env = perf.stability_envelope(kps=(1000.0,), variants=("pd", "spd"), grid=(60,), finer=(),
                                  duration=1.5)
    rows = {r["variant"]: r for r in env["rows"]}
    assert rows["pd"]["status"]["60"] == "diverged" and rows["pd"]["largest_held_hz"] is None
    assert rows["spd"]["status"]["60"] == "held" and rows["spd"]["largest_held_hz"] == 60
    with pytest.raises(perf.PerfError):
        perf.stability_envelope(duration=0.5)
    from mjchar.perf.pd import envelope_table

    text = envelope_table(env, "test")
    assert "| pd | < 1/8000 s |" in text and "| spd | 1/60 s |" in text
    assert "| spd, 1000 | H |" in text


def test_step_cost_and_raw_rate_report_positive_finite_numbers():
    from mjchar.controllers.core import scenarios as S
    from mjchar.controllers.core.character import Character

    ch = Character()
    pose = S.standing_pose(ch)
    c = perf.step_cost(ch, lambda: registry.make_controller("spd", ch, pose), qpos=pose, steps=50,
                       repeats=1, block=25)
    assert math.isfinite(c.ratio) and c.ratio > 0 and c.resets == 0 and c.steps == 50
    raw = perf.raw_step_rate(ch.model, pose, steps=50, repeats=1)
    assert raw["c_loop_steps_per_s"] > 0 and raw["python_loop_steps_per_s"] > 0
    with pytest.raises(perf.PerfError):
        perf.raw_step_rate(ch.model, steps=0)


def test_run_cost_reports_ratios_to_bare_mj_step_in_the_same_run():
    """What ``mjchar run`` costs per physics step over bare ``mj_step``: a ratio per repeat, the
    median of them, and the run's own facts (never a timing threshold)."""
    from mjchar.controllers.core.builder import RunSpec

    c = perf.run_cost(RunSpec("native_pd", scenario_options={"duration": 0.1}), repeats=2,
                      segment=10)
    assert len(c.ratios) == 2 and c.ratio == pytest.approx(sorted(c.ratios)[0] / 2
                                                           + sorted(c.ratios)[1] / 2)
    assert all(math.isfinite(r) and r > 0 for r in c.ratios)
    assert c.run_us > 0 and c.bare_us > 0 and c.steps == 50 and c.scenario == "stand"
    with pytest.raises(perf.PerfError, match="protocol"):
        perf.run_cost(RunSpec("spd", "push-search", scenario_options={"phases": 1, "seeds": 1}),
                      repeats=1)


def test_laps_time_a_loop_from_inside():
    laps = perf.Laps()
    with pytest.raises(perf.PerfError):
        _ = laps.span
    for _ in range(100):
        laps()
    assert laps.calls == 100 and laps.span >= 0 and perf.Laps.overhead() > 0


def test_speed_tables_state_each_ratio_and_its_spread():
    from mjchar.perf import speed

    costs = speed.controller_run_costs(["native_pd"], repeats=1)
    text = speed.controllers_table(costs, 1)
    assert "| native_pd | stand | 2 ms |" in text and "python -m mjchar.perf.speed" in text


def test_the_learned_policy_is_costed_on_its_own_clip():
    """The policy's default run follows the bundled walk, which its file refuses: the speed
    table runs the bundled policy on the clip it was learned on, as ``mjchar run policy``."""
    from mjchar.perf import speed

    c = speed.controller_run_costs(["policy"], repeats=1)["policy"]
    assert c["scenario"] == "track" and c["steps"] > 0 and c["ratio"] > 1.0
    assert "| policy | track | 1.96 ms |" in speed.controllers_table({"policy": c}, 1)


def test_env_shares_and_the_vectorised_path_report_rates():
    r = perf.env_throughput(("mjchar/Stand-v0",), steps=20, repeats=1, bare=True)
    e = r["envs"]["mjchar/Stand-v0"]
    assert 0 < e["time_in_mj_step"] < 1 and 0 < e["physics_share"] < 1.5
    assert len(e["times_in_mj_step"]) == 1 and e["env_steps_per_s"] > 0
    from mjchar.perf.envs import vector_throughput

    v = vector_throughput(("mjchar/Stand-v0",), num_envs=2, steps=8, repeats=1)
    s = v["envs"]["mjchar/Stand-v0"]
    assert v["num_envs"] == 2 and s["single_steps_per_s"] > 0 and s["vector_steps_per_s"] > 0
    assert s["speedup"] == pytest.approx(s["vector_steps_per_s"] / s["single_steps_per_s"])


def test_threaded_throughput_reports_each_count_against_one_env():
    from mjchar.perf.envs import threaded_table, threaded_throughput

    r = perf.threaded_throughput("mjchar/Stand-v0", counts=(1, 3), steps=6, repeats=1,
                                 num_threads=2)
    assert [c["num_envs"] for c in r["cases"]] == [1, 3]
    assert [c["num_threads"] for c in r["cases"]] == [1, 2]
    assert all(c["speedup"] == pytest.approx(c["steps_per_s"] / r["single_steps_per_s"])
               for c in r["cases"])
    assert all(c["cores_busy"] > 0 and c["cpu_per_step_vs_one"] > 0 for c in r["cases"])
    assert "| 3 | 2 |" in threaded_table(r) and threaded_throughput is perf.threaded_throughput


def test_rollout_throughput_compares_against_the_python_loop():
    r = perf.rollout_throughput(samples=2, steps=3, repeats=1, threads=(1,))
    assert [c["threads"] for c in r["cases"]] == [1, 1]
    assert r["cases"][0]["speedup_vs_python_loop"] == 1.0
    assert all(c["steps_per_s"] > 0 and math.isfinite(c["cores_busy"]) for c in r["cases"])


def test_optional_parts_report_unavailable(monkeypatch):
    monkeypatch.setitem(sys.modules, "bvhio", None)
    with pytest.raises(perf.PerfUnavailable, match="bvhio"):
        perf.bvh_parse_speed([])
    monkeypatch.setitem(sys.modules, "mjchar.envs.imitation", None)  # a broken env module
    with pytest.raises(perf.PerfUnavailable, match="Imitation-v0"):
        perf.env_throughput(steps=1, repeats=1)


def test_the_long_bvh_file_is_cmu_style():
    from mjchar.perf.bvh import long_cmu_style_motion

    m = long_cmu_style_motion(130)
    assert m.n_frames == 130 and m.skeleton.names[0] == "Hips"
    assert {"LHipJoint", "RHipJoint"} <= set(m.skeleton.names)
    assert all(ch[-3:] == ("Zrotation", "Yrotation", "Xrotation") for ch in m.skeleton.channels)


# -- entry points and docs blocks ---------------------------------------------------------------
@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_every_entry_point_parses_its_options(name, capsys):
    module = importlib.import_module(f"mjchar.perf.{name}")
    with pytest.raises(SystemExit) as e:
        module.main(["--help"])
    assert e.value.code == 0
    assert f"python -m mjchar.perf.{name}" in capsys.readouterr().out


def test_write_block_replaces_only_its_block(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# Page\n\n<!-- perf:t -->\nold\n<!-- /perf:t -->\n\nkept\n")
    report.write_block(page, "t", "new table")
    assert page.read_text() == "# Page\n\n<!-- perf:t -->\nnew table\n<!-- /perf:t -->\n\nkept\n"
    report.write_block(page, "u", "other")
    assert page.read_text().endswith("<!-- perf:u -->\nother\n<!-- /perf:u -->\n")
    assert not list(tmp_path.glob(".*.tmp"))
    with pytest.raises(perf.PerfError, match="not found"):
        report.write_block(tmp_path / "missing.md", "t", "x")


def test_the_docs_hold_every_block_an_entry_point_writes():
    blocks = {"controllers.md": ("pd-envelope", "pd-cost"), "rollouts.md": ("rollouts",),
              "envs.md": ("envs",), "bvh.md": ("bvh",), "sampling.md": ("samcon",)}
    for page, names in blocks.items():
        text = (report.DOCS / page).read_text()
        for n in names:
            assert f"<!-- perf:{n} -->" in text and f"<!-- /perf:{n} -->" in text, (page, n)


def test_write_json_is_strict_json(tmp_path):
    import json

    import numpy as np

    path = report.write_json(tmp_path / "x.json", {"a": np.float64(1.5), "b": math.nan,
                                                   "c": (1, np.int64(2)), "d": tmp_path})
    assert json.loads(path.read_text()) == {"a": 1.5, "b": None, "c": [1, 2], "d": str(tmp_path)}


def test_the_tour_reads_the_time_every_readme_line_states():
    """``python -m mjchar.perf.tour`` compares each line with its README comment: every line of
    the tour states a time (one figure or a range), read as seconds, and a measurement holds
    within 25 % of it (of a range's ends)."""
    from mjchar.perf.tour import _tour_block, holds, stated_seconds

    lines = _tour_block(report.ROOT / "README.md")
    stated = [stated_seconds(line) for line in lines]
    assert lines and all(s is not None and 0 < s[0] <= s[1] for s in stated), stated
    assert stated_seconds("mjchar x  # 9-12 s (6 s on 2 cores): mpc") == (9.0, 12.0)
    assert stated_seconds("mjchar x  # 0.8 s: a replay") == (0.8, 0.8)
    assert stated_seconds("mjchar x  # no time") is None
    assert holds(1.25, (1.0, 1.0)) and holds(0.75, (1.0, 1.0)) and not holds(1.3, (1.0, 1.0))
    assert holds(14.9, (9.0, 12.0)) and not holds(15.1, (9.0, 12.0))
    assert not holds(6.7, (9.0, 12.0)) and holds(6.75, (9.0, 12.0))
    assert holds(1.0, None) is None


def test_envelope_tables_count_falls_and_say_what_a_calibration_changed():
    """``python -m mjchar.perf.envelopes`` prints per body and walker the falls of the runs at
    each speed (with the mean steady speed of those that stood) and the failed chest pushes,
    and per calibration the defaults' check, its cost and the knobs it moved."""
    from mjchar.controllers.walking.calibration import Calibration, candidate_overrides
    from mjchar.perf.envelopes import bar_table, calibration_table, changes, table

    rows = [{"kind": "walk", "body": "b", "walker": "ipm", "speed": 1.0, "fell": f,
             "steady_speed_mps": s} for f, s in ((False, 0.9), (False, 1.1), (True, None))]
    rows += [{"kind": "push", "body": "b", "walker": "ipm", "fell": f, "walking_after": w}
             for f, w in ((False, True), (False, False), (True, False), (False, True))]
    text = table(rows, [1.0])
    assert "| b | ipm | 1/3 fell, 1.00 | 2/4 |" in text
    x = [0.0] * 9
    x[0], x[6] = 1.0, -2.0  # sagittal scale up one step, hip gains down two
    over = candidate_overrides("ipm", x)
    cal = Calibration("ipm", "f" * 64, overrides=over, status="optimised",
                      check=[{"speed": 1.0, "fell": True, "fall_time_s": 3.25,
                              "steady_speed_mps": None}],
                      calibrated=[{"speed": 1.0, "fell": False, "fall_time_s": None,
                                   "steady_speed_mps": 0.98}],
                      cost_defaults=9.0, cost=0.1, evaluations=12, cpu_seconds=80.4)
    said = changes(cal)
    assert said == (f"placement.sagittal_scale 1 -> {math.exp(0.15):.3g}; "
                    f"tracking.hip gains x{math.exp(-0.5):.2f}")
    cal.confirmed = [{"speed": v, "fell": False, "fall_time_s": None, "steady_speed_mps": v}
                     for v in (0.9, 1.1)]
    cal.rejected = [cal.confirmed]
    line = calibration_table([("b", cal)]).splitlines()[-1]
    assert line == (f"| b | ipm | 1: fell 3.2 s | optimised (cost 9.00 -> 0.10) | 12 | 80 | "
                    f"1: 0.98 | 0.9: 0.90, 1.1: 1.10 (1 ruled out) | {said} |")
    assert changes(Calibration("simbicon", "f" * 64)) == "-"
    bar = [{"kind": "bar", "body": "b", "run": "static_balance", "fell": False,
            "sim_time_s": 30.0},
           {"kind": "bar", "body": "b", "run": "simbicon", "fell": False, "sim_time_s": 60.0,
            "distance_m": 61.6},
           {"kind": "bar", "body": "b", "run": "ipm", "fell": True, "fall_time_s": 13.64}]
    assert bar_table(bar).splitlines()[-1] == "| b | 30 s | 60 s, 62 m | fell 13.6 s |"


def test_envelopes_main_prints_the_bar_table(monkeypatch, capsys):
    """``python -m mjchar.perf.envelopes FILE --what bar``: one line per run on standard error
    and the bar's table (the runs stand in here; the conversion is real)."""
    import contextlib

    from conftest import real_export

    from mjchar.perf import envelopes

    f = real_export("xsens_mvn_walk.bvh")

    @contextlib.contextmanager
    def here(jobs):
        yield type("Pool", (), {"map": staticmethod(map)})()

    def fake(job):
        body, xml, what = job[1:]
        return {"kind": "bar", "body": body, "run": what, "fell": what == "ipm",
                "fall_time_s": 2.5, "sim_time_s": 30.0 if what == "static_balance" else 60.0,
                "distance_m": 59.0, "steady_speed_mps": None, "root_force_max_N": 0.0}

    monkeypatch.setattr(envelopes, "process_pool", here)
    monkeypatch.setattr(envelopes, "_run", fake)
    monkeypatch.setattr(envelopes, "calibrate_first", lambda bodies: [])
    assert envelopes.main([str(f), "--what", "bar"]) == 0
    out, err = capsys.readouterr()
    assert "| xsens_mvn_walk | 30 s | 60 s, 59 m | fell 2.5 s |" in out
    assert "xsens_mvn_walk simbicon: up" in err and "xsens_mvn_walk ipm: fell" in err
