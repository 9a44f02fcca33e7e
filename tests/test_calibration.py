"""Walker calibration: stored keyed by the body's fingerprint, read back as it was written,
made once for an uncalibrated body (on a tiny budget here), the bundled humanoid's being its
defaults; ``mjchar calibrate`` and ``--calibration``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_command

from mjchar.bvh.bundled.assets import HUMANOID_XML
from mjchar.cli import main
from mjchar.controllers import Character, make_controller
from mjchar.controllers.sampling.trajectory import model_fingerprint
from mjchar.controllers.walking import calibration as cal_mod
from mjchar.controllers.walking.calibration import Calibration, CalibrationError


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """An empty calibration cache, the walkers calibrating as users' runs do."""
    monkeypatch.setenv("MJCHAR_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("MJCHAR_CALIBRATION", raising=False)
    return tmp_path / "cache" / "calibration"


@pytest.fixture
def tiny_calibrations(monkeypatch) -> list[str]:
    """Calibrations on a tiny budget (0.3 s walks, no search); the walkers they were made for,
    in order."""
    calls: list[str] = []
    real = cal_mod.calibrate

    def tiny(model, walker, **kw):
        calls.append(walker)
        return real(model, walker, **{**kw, "budget_s": 0.0, "duration": 0.3, "jobs": 1})

    monkeypatch.setattr(cal_mod, "calibrate", tiny)
    return calls


def heavier_humanoid(tmp_path, kg: float = 5.0) -> str:
    """The bundled humanoid with a heavier pelvis: another body, another fingerprint."""
    text = HUMANOID_XML.read_text()
    i = text.index('mass="', text.index("<geom"))
    j = text.index('"', i + 6)
    text = text[:i] + f'mass="{float(text[i + 6:j]) + kg:g}"' + text[j + 1:]
    xml = tmp_path / f"heavier{kg:g}.xml"
    xml.write_text(text)
    return str(xml)


def test_a_calibration_round_trips_and_is_keyed_by_the_fingerprint(tmp_path, cache):
    a = Character(heavier_humanoid(tmp_path, 5.0))
    b = Character(heavier_humanoid(tmp_path, 6.0))
    assert cal_mod.cache_path(a.model, "ipm") != cal_mod.cache_path(b.model, "ipm")
    assert cal_mod.cache_path(a.model, "ipm") == cal_mod.cache_path(
        Character(heavier_humanoid(tmp_path, 5.0)).model, "ipm")
    assert cal_mod.cache_path(a.model, "ipm").parent == cache
    cal = Calibration("ipm", model_fingerprint(a.model),
                      overrides={"placement.step_width": 0.05, "tracking.hip_kp": 700.0},
                      status="optimised", cost_defaults=3.0, cost=0.4, evaluations=7)
    path = cal_mod.save(cal)
    assert path == cal_mod.cache_path(a.model, "ipm")
    assert cal_mod.load(path) == cal
    assert cal_mod.overrides_for(a, "ipm") == cal.overrides
    assert make_controller("ipm", a).body_params.placement.step_width == 0.05
    # the file given by name: for its body only, and its walker only
    with pytest.raises(CalibrationError, match="made for another body"):
        cal_mod.overrides_for(b, "ipm", str(path))
    with pytest.raises(CalibrationError, match="a calibration of ipm, not simbicon"):
        cal_mod.overrides_for(a, "simbicon", str(path))
    assert cal_mod.overrides_for(a, "ipm", "none") == {}
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(CalibrationError, match="not a calibration file"):
        cal_mod.load(bad)


def test_the_bundled_humanoids_calibration_is_its_defaults(cache):
    ch = Character()
    assert cal_mod.is_bundled(ch.model)
    assert cal_mod.overrides_for(ch, "ipm") == {}
    assert cal_mod.overrides_for(ch, "simbicon") == {}
    assert not cache.exists()  # nothing made, nothing stored


def test_an_uncalibrated_body_is_calibrated_once(tmp_path, cache, tiny_calibrations):
    """The first walker made on a new body calibrates it (saying so in one line) and stores the
    result; the next one reads it. A tiny budget: 0.3 s walks, no search."""
    calls, lines = tiny_calibrations, []
    ch = Character(heavier_humanoid(tmp_path))
    cal_mod.overrides_for(ch, "ipm", announce=lines.append)
    assert calls == ["ipm"] and len(lines) == 1 and "calibrating ipm" in lines[0]
    stored = cal_mod.load(cal_mod.cache_path(ch.model, "ipm"))
    assert stored.fingerprint == model_fingerprint(ch.model)
    assert stored.status in ("defaults", "unimproved") and stored.evaluations == 1
    assert [r["speed"] for r in stored.check] == [0.8, 1.0, 1.2]
    make_controller("ipm", Character(heavier_humanoid(tmp_path)))  # the factory reads it
    assert calls == ["ipm"]


def test_candidates_move_the_knobs_from_the_defaults():
    for walker in cal_mod.WALKERS:
        assert cal_mod.candidate_overrides(walker, None) == {}
        zero = cal_mod.candidate_overrides(walker, [0.0] * len(cal_mod.KNOBS[walker]))
        moved = cal_mod.candidate_overrides(walker, [1.0] * len(cal_mod.KNOBS[walker]))
        assert zero.keys() == moved.keys() and zero != moved
    ipm = cal_mod.candidate_overrides("ipm", [0.0] * len(cal_mod.KNOBS["ipm"]))
    assert ipm["tracking.hip_kp"] == 600.0 and ipm["placement.sagittal_scale"] == 1.0


def test_walk_cost_ranks_a_fall_above_any_speed_error():
    walked = [{"speed": 1.0, "fell": False, "fall_time_s": None, "steady_speed_mps": 0.2,
               "own_speed_mps": None}]
    late = [{"speed": 1.0, "fell": True, "fall_time_s": 19.0, "steady_speed_mps": 1.0,
             "own_speed_mps": None}]
    early = [dict(late[0], fall_time_s=2.0)]
    assert cal_mod.walk_cost(walked, 20.0) < cal_mod.walk_cost(late, 20.0) < cal_mod.walk_cost(
        early, 20.0)
    assert not cal_mod.passes(walked) and cal_mod.passes([dict(walked[0],
                                                                steady_speed_mps=0.95)])


def test_the_calibrate_command_and_the_calibration_flag(tmp_path, cache, capsys):
    model = heavier_humanoid(tmp_path)
    out = tmp_path / "ipm.json"
    run_command(["calibrate", model, "--walker", "ipm", "--budget", "0", "--duration", "0.3",
                 "--jobs", "1", "-o", str(out), "--json"])
    data = json.loads(capsys.readouterr().out)
    assert data["walker"] == "ipm" and Path(data["file"]) == out and out.exists()
    assert not cache.exists()  # -o: not the cache
    run_command(["run", "ipm", "--model", model, "--calibration", str(out), "--duration",
                 "0.2", "--json"])
    assert json.loads(capsys.readouterr().out)["sim_time_s"] > 0
    assert main(["run", "ipm", "--model", str(HUMANOID_XML), "--calibration", str(out),
                 "--duration", "0.2"]) == 2
    assert "made for another body" in capsys.readouterr().err
    assert main(["run", "static_balance", "--calibration", "none"]) == 2
    assert main(["calibrate", model, "-o", str(tmp_path / "x.json")]) == 2
    assert "one walker" in capsys.readouterr().err


def test_the_knobs_start_from_the_walkers_defaults():
    from mjchar.controllers.walking.ipm_params import IPMParams
    from mjchar.controllers.walking.simbicon import simbicon_tunables

    flat = IPMParams().flat()
    for k in cal_mod.KNOBS["ipm"]:
        assert k.default == (1.0 if k.name.endswith("*") else flat[k.name]), k.name
    rows = {t.name: t.default for t in simbicon_tunables("walk")}
    for k in cal_mod.KNOBS["simbicon"]:
        if k.name.endswith("*"):
            assert k.default == 1.0
        elif k.name in rows:
            assert k.default == rows[k.name], k.name
        else:  # a state field, both states
            assert k.default == rows[f"state0_{k.name}"] == rows[f"state1_{k.name}"], k.name


def test_a_candidate_that_falls_in_its_long_walks_is_ruled_out(monkeypatch):
    """A candidate passing the 20 s check walks CONFIRM_DURATION s before it is kept: one that
    falls there is ruled out and the search goes on to one that holds (a stand-in walk here:
    the defaults fall at 5 s, every candidate walks the 20 s with a speed error shrinking as
    its first knob grows, and the first candidate given long walks falls in them at 30 s)."""
    knob = cal_mod.KNOBS["ipm"][0]
    long_walked = []

    def walk(args):
        _, _, _, overrides, speed, seconds, _ = args
        x = (0.0 if not overrides else
             float(np.log(overrides[knob.name] / knob.default) / knob.step))
        if seconds > 20.0 and overrides not in long_walked:
            long_walked.append(overrides)
        fall = (5.0 if not overrides else
                30.0 if seconds > 20.0 and overrides == long_walked[0] else None)
        fell = fall is not None and fall < seconds
        steady = speed - 0.08 + 0.05 * min(max(x, 0.0), 1.6)
        return {"speed": speed, "seed": args[-1], "fell": fell,
                "fall_time_s": fall if fell else None,
                "steady_speed_mps": steady, "own_speed_mps": None, "cpu_s": 0.0}

    monkeypatch.setattr(cal_mod, "_walk_job", walk)
    cal = cal_mod.calibrate(HUMANOID_XML, "ipm", jobs=1, budget_s=1.0)
    assert len(long_walked) == 2
    assert cal.status == "optimised" and len(cal.rejected) == 1
    assert all(r["fell"] and r["fall_time_s"] == 30.0 for r in cal.rejected[0])
    # the long walks: every speed from the seeded start, then every speed from rest
    assert [r["speed"] for r in cal.confirmed] == list(cal_mod.CONFIRM_SPEEDS["ipm"]) * 2
    assert [r["seed"] for r in cal.confirmed] == [0] * 5 + [None] * 5
    assert cal.confirmed and not any(r["fell"] for r in cal.confirmed)
    assert cal.overrides == long_walked[1] and cal_mod.passes(cal.calibrated)
    assert Calibration.from_json(cal.to_json()).rejected == cal.rejected


def _simbicon_stand_in(falls_where, fall_time: float):
    """A stand-in SIMBICON walk for ``_walk_job``: the defaults walk every speed 0.2 m/s too
    slowly; a candidate walks within 0.1 m/s (closer as its first knob grows), and the first
    candidate to walk where ``falls_where(speed, seed)`` falls there at ``fall_time``. Returns
    the walk and the list that receives that candidate's overrides."""
    knob = cal_mod.KNOBS["simbicon"][0]
    marked: list[dict] = []

    def walk(args):
        _, _, _, overrides, speed, seconds, seed = args
        row = {"speed": speed, "seed": seed, "fell": False, "fall_time_s": None,
               "own_speed_mps": 1.0, "cpu_s": 0.0}
        if not overrides:  # the defaults: too slow everywhere
            return {**row, "steady_speed_mps": (speed or 1.0) - 0.2}
        x = (overrides[knob.name] - knob.default) / knob.step
        if falls_where(speed, seed) and not marked:
            marked.append(overrides)
        fell = falls_where(speed, seed) and overrides == marked[0]
        return {**row, "fell": fell, "fall_time_s": fall_time if fell else None,
                "steady_speed_mps": (speed or 1.0) - 0.09 + 0.02 * min(max(x, 0.0), 3.0)}

    return walk, marked


def test_a_candidate_that_falls_between_the_checks_speeds_is_ruled_out(monkeypatch):
    """The long walks cover the check's range 0.1 m/s apart: a candidate that walks 0.8, 1.0
    and 1.2 m/s but falls at 0.9 m/s (as SIMBICON fitted at 0.8 and 1.2 m/s only did on a CMU
    body) is ruled out, and the stored candidate walks every speed of the range."""
    walk, between = _simbicon_stand_in(lambda speed, seed: speed == 0.9, 12.0)
    monkeypatch.setattr(cal_mod, "_walk_job", walk)
    cal = cal_mod.calibrate(HUMANOID_XML, "simbicon", jobs=1, budget_s=1.0)
    assert [r["speed"] for r in cal.check] == [None, 0.8, 1.0, 1.2]
    assert len(cal.rejected) == 1
    assert [r["speed"] for r in cal.rejected[0] if r["fell"]] == [0.9, 0.9]  # both starts
    assert cal.status == "optimised" and cal.overrides != between[0]
    assert [r["speed"] for r in cal.confirmed] == [None, 0.8, 0.9, 1.0, 1.1, 1.2] * 2
    assert cal_mod.passes(cal.confirmed) and cal.protocol == cal_mod.PROTOCOL


def test_defaults_kept_by_an_unchanged_check_are_not_made_again(tmp_path, cache,
                                                                tiny_calibrations):
    """Protocol 3 changed only the long walks an optimised candidate must show: a stored
    calibration that kept the defaults by protocol 2's check is still current; an optimised
    one, or one from before the check changed, is made again."""
    ch = Character(heavier_humanoid(tmp_path))
    path = cal_mod.cache_path(ch.model, "ipm")
    fp = model_fingerprint(ch.model)
    for status, protocol, current in (("defaults", 2, True), ("optimised", 2, False),
                                      ("defaults", 1, False), ("optimised", 3, True)):
        cal = Calibration("ipm", fp, status=status, protocol=protocol)
        assert cal_mod.is_current(cal) == current, (status, protocol)
    cal_mod.save(Calibration("ipm", fp, status="defaults", protocol=2), path)
    assert cal_mod.overrides_for(ch, "ipm") == {} and tiny_calibrations == []


def test_defaults_that_walk_are_kept_over_candidates_that_fall_in_their_long_walks(
        monkeypatch):
    """Defaults that walk every check too slowly but never fall are kept (``unimproved``) when
    every candidate that walks the check at speed falls in its long walks (SIMBICON on the Xia
    body: candidates that walked 0.8-1.2 m/s for 20 s fell at 1.0-1.1 m/s within 60 s)."""
    def walk(args):
        _, _, _, overrides, speed, seconds, seed = args
        fell = bool(overrides) and seconds > 20.0 and speed == 1.0
        return {"speed": speed, "seed": seed, "fell": fell, "fall_time_s": 30.0 if fell else None,
                "steady_speed_mps": (speed or 1.0) - (0.02 if overrides else 0.2),
                "own_speed_mps": 1.0, "cpu_s": 0.01}

    monkeypatch.setattr(cal_mod, "_walk_job", walk)
    cal = cal_mod.calibrate(HUMANOID_XML, "simbicon", jobs=1, budget_s=1.0)
    assert cal.rejected and not cal.confirmed
    assert cal.status == "unimproved" and cal.overrides == {}


def test_a_candidate_that_falls_from_rest_is_ruled_out(monkeypatch):
    """The long walks start from rest as well as from the check's seeded start: a candidate
    that walks every speed from the seeded start but falls from the standing pose at rest (as
    SIMBICON calibrated from the seeded start only did on the Xia body, at 5.0 s) is ruled out,
    and the one stored walks from both starts."""
    walk, from_rest = _simbicon_stand_in(lambda speed, seed: speed is None and seed is None,
                                         5.0)

    monkeypatch.setattr(cal_mod, "_walk_job", walk)
    cal = cal_mod.calibrate(HUMANOID_XML, "simbicon", jobs=1, budget_s=1.0)
    assert len(cal.rejected) == 1
    assert [(r["speed"], r["seed"]) for r in cal.rejected[0] if r["fell"]] == [(None, None)]
    assert cal.status == "optimised" and cal.overrides != from_rest[0]
    assert {r["seed"] for r in cal.confirmed} == {0, None}
    assert cal_mod.passes(cal.confirmed)


def test_a_calibration_stored_by_an_earlier_procedure_is_made_again(tmp_path, cache,
                                                                      tiny_calibrations):
    calls, lines = tiny_calibrations, []
    ch = Character(heavier_humanoid(tmp_path))
    path = cal_mod.cache_path(ch.model, "ipm")
    old = json.loads(Calibration("ipm", model_fingerprint(ch.model),
                                 overrides={"stance.knee": 0.2}).to_json())
    del old["protocol"]  # a file written before the field existed
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(old))
    assert cal_mod.load(path).protocol == 1
    assert cal_mod.overrides_for(ch, "ipm", announce=lines.append) == {}
    assert calls == ["ipm"] and "again" in lines[0]
    assert cal_mod.load(path).protocol == cal_mod.PROTOCOL
    assert cal_mod.overrides_for(ch, "ipm", announce=lines.append) == {} and calls == ["ipm"]
