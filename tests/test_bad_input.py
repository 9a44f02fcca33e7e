"""Every bad value is one line: a corpus of bad inputs fed to the command line and the BVH reader.

For each case ``mjchar`` must exit with status 2, print exactly one line on standard error (and
no warning, which would be a second line), no traceback, and write nothing: no output file, no
MuJoCo log in the working folder. Each case fails before anything long is simulated.

The inputs are made here from the bundled clip and trajectory (no shared data needed): BVH files
with absurd numbers, replay files with bad fields, a clip on another skeleton, files that are
not models; plus ``--param`` values of every controller that takes them, time steps, durations
and runs past the end of what they follow.
"""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import malformed_export

from mjchar import bvh
from mjchar.bvh.bundled.assets import TRAJECTORIES, motion_path
from mjchar.cli import main

WALK = motion_path("walk")
TRAJECTORY = TRAJECTORIES / "samcon_walk60.npz"
#: another skeleton: a root and one leg (no joint the bundled humanoid was built with)
OTHER_SKELETON = ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition "
                  "Zposition Zrotation Xrotation Yrotation\nJOINT LeftUpLeg\n{\nOFFSET 10 0 0\n"
                  "CHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 -40 0\n}\n}\n"
                  "}\nMOTION\nFrames: 2\nFrame Time: 0.0333333\n0 90 0 0 0 0 0 0 0\n"
                  "0 90 1 0 0 0 0 0 0\n")


def _lines() -> list[str]:
    return WALK.read_text().splitlines()


def _edit(lines: list[str], match: str, new: str, nth: int = 0) -> list[str]:
    """``lines`` with the ``nth`` line containing ``match`` replaced by ``new``."""
    hits = [i for i, ln in enumerate(lines) if match in ln]
    out = list(lines)
    out[hits[nth]] = new
    return out


def _frames(lines: list[str]) -> int:
    """Index of the first frame line."""
    return next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time")) + 1


def _value(lines: list[str], frame: int, column: int, text: str) -> list[str]:
    out = list(lines)
    i = _frames(lines) + frame
    row = out[i].split()
    row[column] = text
    out[i] = " ".join(row)
    return out


def _clip(lines: list[str], n_frames: int, frame_time: str | None = None) -> list[str]:
    """The first ``n_frames`` frames (a clip that no longer loops), optionally retimed."""
    f = _frames(lines)
    head = _edit(lines[:f], "Frames:", f"Frames: {n_frames}")
    if frame_time is not None:
        head = _edit(head, "Frame Time", f"Frame Time: {frame_time}")
    body = lines[f:f + n_frames]
    while len(body) < n_frames:
        body += lines[f:f + min(n_frames - len(body), len(lines) - f)]
    return head + body


def _bvh_files() -> dict[str, str]:
    w = _lines()
    return {
        "offset_1e308.bvh": _edit(w, "OFFSET", "OFFSET 1e308 0 0", nth=1),
        "offset_1e30.bvh": _edit(w, "OFFSET", "OFFSET 0 1e30 0", nth=2),
        "end_site_1e30.bvh": _edit(w, "OFFSET 0.000000 0.210000", "OFFSET 0 1e30 0"),
        "frame_time_1e300.bvh": _edit(w, "Frame Time", "Frame Time: 1e300"),
        "frame_time_0.bvh": _edit(w, "Frame Time", "Frame Time: 0"),
        "rotation_1e6.bvh": _value(w, 3, 5, "1e6"),
        "position_1e8.bvh": _value(w, 2, 0, "1e8"),
        "value_nan.bvh": _value(w, 4, 7, "nan"),
        "no_frames.bvh": _clip(w, 0),
        "hours_long.bvh": _clip(w, 14500, frame_time="0.25"),
        "short.bvh": _clip(w, 40),
        "other_skeleton.bvh": OTHER_SKELETON.splitlines(),
    }


def _trajectory_files(folder: Path) -> dict[str, dict | str]:
    with np.load(TRAJECTORY, allow_pickle=False) as z:
        good = {k: z[k] for k in z.files}
    nan_targets = good["targets"].copy()
    nan_targets[3, 2] = np.nan
    nan_start = good["initial_qpos"].copy()
    nan_start[0] = np.inf
    long = np.repeat(good["targets"][:1], 200_000, axis=0)
    return {
        "control_dt_1e6.npz": {**good, "control_dt": np.array(1e6)},
        "timestep_1e-9.npz": {**good, "timestep": np.array(1e-9)},
        "timestep_0.5.npz": {**good, "timestep": np.array(0.5), "control_dt": np.array(0.5)},
        "control_dt_text.npz": {**good, "control_dt": np.array("fast")},
        "nan_target.npz": {**good, "targets": nan_targets},
        "inf_start.npz": {**good, "initial_qpos": nan_start},
        "hours_of_controls.npz": {**good, "targets": long,
                                  "reference_qpos": np.zeros((0, good["initial_qpos"].size)),
                                  "warmstart_resets": np.array([0])},
        "no_marker.npz": {k: v for k, v in good.items() if k != "format"},
        "not_an_archive.npz": "this is text, not a trajectory\n",
    }


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("bad_inputs")
    for name, lines in _bvh_files().items():
        (folder / name).write_text("\n".join(lines) + "\n")
    for name, content in _trajectory_files(folder).items():
        if isinstance(content, str):
            (folder / name).write_text(content)
        else:
            np.savez(folder / name, **content)
    (folder / "notes.xml").write_text("<notes>not a model</notes>\n")
    (folder / "README.txt").write_text("plain text\n")
    return folder


#: (id, argv with {in} the inputs folder, what the one line must contain)
CASES = [
    # -- --param of every controller that takes tunables
    ("simbicon-text", ["run", "simbicon", "--param", "torso_pitch=abc"],
     "torso_pitch must be a finite number >= -3.14159 and <= 3.14159 (rad), got 'abc'"),
    ("simbicon-absurd", ["run", "simbicon", "--param", "torso_pitch=1e9"],
     "torso_pitch must be a finite number"),
    ("simbicon-state-text", ["run", "simbicon", "--param", 'state1_swing_hip="x"'],
     "state1_swing_hip must be a finite number"),
    ("simbicon-gain-pair", ["run", "simbicon", "--param", "gain_torso=[1, 2, 3]"],
     "gain_torso must be [kp, kd]"),
    ("simbicon-gain-group", ["run", "simbicon", "--param", "gain_tail=[1, 2]"],
     "unknown gain group 'tail'"),
    ("simbicon-flag", ["run", "simbicon", "--param", "feedback=0"],
     "feedback must be true or false"),
    ("simbicon-unknown", ["run", "simbicon", "--param", "torso_pich=0.2"],
     "did you mean torso_pitch?"),
    ("ipm-nan", ["run", "ipm", "--param", "timing.step_time=NaN"],
     "timing.step_time must be a finite number > 0 and <= 10 (s), got nan"),
    ("ipm-nan-text", ["run", "ipm", "--param", "timing.step_time=nan"],
     "got 'nan'"),
    ("ipm-flat-name", ["run", "ipm", "--param", "step_time=nan"],
     "did you mean timing.step_time, human.step_time?"),
    ("ipm-absurd-gain", ["run", "ipm", "--param", "tracking.hip_kp=1e9"],
     "tracking.hip_kp must be a finite number >= 0 and <= 100000 (N m/rad)"),
    ("ipm-choice", ["run", "ipm", "--param", "swing.blend=linear"],
     "one of 'quadratic', 'smooth'"),
    ("mpc-text", ["run", "mpc", "--param", "samples=abc"], "samples must be an integer"),
    ("mpc-absurd", ["run", "mpc", "--param", "horizon=1e9"],
     "horizon must be a finite number > 0 and <= 5 (s)"),
    ("mpc-float-count", ["run", "mpc", "--param", "samples=1e9"], "samples must be an integer"),
    ("mpc-choice", ["run", "mpc", "--param", "update=newton"], "update must be one of"),
    ("mpc-weights", ["run", "mpc", "--param", 'weights={"pose": 1e300}'],
     "weights must be an object"),
    ("mpc-plan-solver", ["run", "mpc", "--param", "plan_solver=quick"],
     "plan_solver must be one of 'fast', 'exact'"),
    ("mpc-keep", ["run", "mpc", "--param", "keep=2"], "keep must be a finite number > 0 and <= 1"),
    ("mpc-near-off-grid", ["run", "mpc", "--param", "near=0.25"],
     "near (0.25 s) must be a whole number of controls"),
    ("mpc-tail-timestep", ["run", "mpc", "--param", "tail_timestep=1"],
     "tail_timestep must be a finite number >= 1e-05 and <= 0.01 (s)"),
    ("params-without-tunables", ["params", "pd"], "invalid choice: 'pd'"),
    # -- time steps, durations, runs past the end
    ("timestep-tiny", ["run", "pd", "--timestep", "1e-9"], "at least 1e-05 s"),
    ("timestep-huge", ["run", "pd", "--timestep", "1"], "at most 0.01 s"),
    ("duration-huge", ["run", "pd", "--duration", "1e9"], "at most 3600"),
    ("control-dt-huge", ["run", "pd", "--control-dt", "1e6"], "at most 0.1 s"),
    ("gait-duration", ["gait", "ipm", "--duration", "1e9"], "at most 3600"),
    ("slope-distance", ["run", "simbicon", "--scenario", "slopes", "--distance", "1e9"],
     "--distance 1e+09 is out of range: at most 1000 m"),
    ("steady-window", ["run", "ipm", "--steady-window", "1e9"], "at most 3600 s"),
    ("replay-past-end", ["run", "samcon_replay", "--duration", "5"],
     "--duration 5 is past the end of the 3.02 s trajectory; give --duration up to 3.02"),
    ("track-past-end", ["run", "hand_of_god", "--motion", "{in}/short.bvh", "--duration", "5"],
     "past the end of the 0.65 s clip; give --duration up to 0.65 or --loop"),
    ("walk-past-end", ["run", "pd", "--scenario", "walk", "--motion", "{in}/short.bvh",
                       "--duration", "5"], "past the end of the 0.65 s clip"),
    ("clip-hours-long", ["run", "hand_of_god", "--motion", "{in}/hours_long.bvh"],
     "the clip lasts 3624.75 s, longer than a run may (3600 s): give --duration"),
    # -- BVH files with absurd numbers (the reader names the line)
    ("bvh-offset-1e308", ["convert", "{in}/offset_1e308.bvh", "-o", "out.xml"],
     "line 8: OFFSET of joint 'pelvis_lowerback': 1e308 cannot be a length"),
    ("bvh-offset-1e30", ["convert", "{in}/offset_1e30.bvh", "-o", "out.xml"], "line 12: OFFSET"),
    ("bvh-end-site-1e30", ["info", "{in}/end_site_1e30.bvh"], "OFFSET of the End Site"),
    ("bvh-frame-time", ["run", "hand_of_god", "--motion", "{in}/frame_time_1e300.bvh"],
     "line 124: Frame Time 1e300 s is not a frame time (expected at most 10 s"),
    ("bvh-frame-time-0", ["info", "{in}/frame_time_0.bvh"], "positive number of seconds"),
    ("bvh-rotation", ["info", "{in}/rotation_1e6.bvh"],
     "line 128: value 6 of frame 4 (Zrotation of joint 'RootJoint') is 1e+06 degrees"),
    ("bvh-position", ["run", "pd", "--scenario", "track", "--motion", "{in}/position_1e8.bvh"],
     "line 127: value 1 of frame 3 (Xposition"),
    ("bvh-nan", ["info", "{in}/value_nan.bvh"], "line 129: expected a finite number"),
    ("bvh-no-frames-as-clip", ["run", "pd", "--scenario", "track", "--motion",
                               "{in}/no_frames.bvh"], "the clip has no frames"),
    # -- replay files with bad fields
    ("replay-control-dt", ["run", "replay", "{in}/control_dt_1e6.npz"],
     "its control_dt must be > 0 and at most 0.1 s"),
    ("replay-timestep-tiny", ["run", "replay", "{in}/timestep_1e-9.npz"],
     "its timestep must be between 1e-05 and 0.01 s"),
    ("replay-timestep-huge", ["run", "replay", "{in}/timestep_0.5.npz"], "its timestep"),
    ("replay-text-field", ["run", "replay", "{in}/control_dt_text.npz"], "damaged trajectory"),
    ("replay-nan-target", ["run", "replay", "{in}/nan_target.npz"], "targets contain NaN"),
    ("replay-inf-start", ["run", "replay", "{in}/inf_start.npz"], "initial_qpos contains NaN"),
    ("replay-hours", ["run", "replay", "{in}/hours_of_controls.npz"],
     "longer than a run may (3600 s)"),
    ("replay-no-marker", ["run", "replay", "{in}/no_marker.npz"], "not a saved mjchar trajectory"),
    ("replay-not-npz", ["run", "replay", "{in}/not_an_archive.npz"], "not an .npz archive"),
    # -- mismatched models and clips
    ("clip-other-skeleton", ["run", "hand_of_god", "--motion", "{in}/other_skeleton.bvh"],
     "the motion lacks 20 of the 20 joints the model was built with (RootJoint, "
     "pelvis_lowerback, lowerback_torso, ...)"),
    ("model-is-bvh", ["run", "pd", "--model", str(WALK)], "is a BVH clip, not an MJCF model"),
    ("model-not-mjcf", ["run", "pd", "--model", "{in}/notes.xml"], "is not an MJCF model"),
    ("model-text", ["gait", "ipm", "--model", "{in}/README.txt"], "is not an MJCF model"),
    ("samcon-model-is-bvh", ["samcon", str(WALK), "-o", "out.npz", "--model", str(WALK)],
     "is a BVH clip"),
    ("samcon-other-skeleton", ["samcon", "{in}/other_skeleton.bvh", "-o", "out.npz"],
     "mjchar convert {in}/other_skeleton.bvh -o model.xml"),
    # -- other commands' absurd values
    ("convert-mass", ["convert", str(WALK), "-o", "out.xml", "--mass", "1e300"],
     "total mass must be a positive number of kg up to 10000"),
    ("convert-unit", ["convert", str(WALK), "-o", "out.xml", "--unit", "1000"],
     "not a body (at most 100 m"),
    ("trajopt-knots", ["trajopt", str(WALK), "-o", "out.npz", "--knot-dt", "1e-9"],
     "knot_dt must be a whole number of controls"),
    ("trajopt-jump", ["trajopt", "--task", "jump", "-o", "out.npz", "--duration", "1e9"],
     "its duration must be positive and at most 10 s"),
]


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


@pytest.mark.parametrize("argv,needle", [pytest.param(a, n, id=i) for i, a, n in CASES])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(argv, needle, inputs, tmp_path,
                                                         monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("{in}", str(inputs)) for a in argv]
    needle = needle.replace("{in}", str(inputs))
    before, inputs_before = _files(tmp_path), _files(inputs)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            code = main(argv)
        except SystemExit as e:  # argparse's own errors
            code = e.code
    captured = capsys.readouterr()
    err = captured.err
    assert code == 2, f"exit {code}: {err}"
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert needle in err, err
    assert not caught, [str(w.message) for w in caught]  # each would be a line on stderr
    assert captured.out == ""
    assert _files(tmp_path) == before, "something was written"
    assert _files(inputs) == inputs_before


def test_the_corpus_is_large():
    assert len(CASES) >= 30


@pytest.mark.parametrize("name,line,needle", [
    ("offset_1e308.bvh", 8, "cannot be a length on a body"),
    ("end_site_1e30.bvh", 20, "OFFSET of the End Site of joint 'torso_head'"),
    ("frame_time_1e300.bvh", 124, "is not a frame time"),
    ("rotation_1e6.bvh", 128, "cannot describe a pose"),
    ("position_1e8.bvh", 127, "file units (expected within +-1e+07"),
    ("value_nan.bvh", 129, "expected a finite number"),
])
def test_the_reader_names_the_line(inputs, name, line, needle):
    with pytest.raises(bvh.BVHError) as e:
        bvh.load(inputs / name)
    assert e.value.line == line and needle in str(e.value)


def test_plausible_extremes_still_read(inputs, tmp_path):
    """The bounds are generous: millimetre offsets, unwrapped angles, a clip at 4 frames per
    second, a single pose with a 10 s frame time."""
    w = _lines()
    ok = _value(_edit(_edit(w, "OFFSET", "OFFSET 0 99999 0", nth=1), "Frame Time",
                      "Frame Time: 0.25"), 0, 5, "-99999")
    (tmp_path / "ok.bvh").write_text("\n".join(ok) + "\n")
    m = bvh.load(tmp_path / "ok.bvh")
    assert m.frame_time == 0.25 and m.skeleton.offsets[1, 1] == 99999.0
    (tmp_path / "pose.bvh").write_text("\n".join(_clip(w, 1, frame_time="10")) + "\n")
    assert bvh.load(tmp_path / "pose.bvh").frame_time == 10.0


@pytest.mark.parametrize("name, needle", [
    ("frame_time_1s.bvh", "line 144: Frame Time 1 s for 600 frames is a clip of 10 minutes at 1 "
                          "frames per second"),
    ("pn_template_0_frames.bvh", "Frames: 0, a skeleton template with no motion"),
])
def test_the_malformed_real_exports_are_refused_in_one_line(name, needle, tmp_path, capsys):
    """../shared/data/malformed: real files broken as their tools wrote them (a clip whose
    header's frame time is 30 times too long; a skeleton template with no frames). ``mjchar
    convert`` refuses each in one line, exit 2, writing nothing."""
    path = malformed_export(name)
    assert main(["convert", str(path), "-o", str(tmp_path / "body.xml")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err, err
    assert not list(tmp_path.iterdir())


def test_a_skeleton_without_frames_is_described(inputs, capsys):
    assert main(["info", str(inputs / "no_frames.bvh")]) == 0
    assert "no frames (a skeleton without motion" in capsys.readouterr().out


def _mjchar(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mjchar", *args], capture_output=True,
                          text=True, timeout=120, **kw)


def test_one_line_in_a_real_process(inputs, tmp_path):
    """The same in a process of its own (warnings and all go to the real stderr)."""
    for argv in (["convert", str(inputs / "offset_1e308.bvh"), "-o", "out.xml"],
                 ["run", "simbicon", "--param", "torso_pitch=abc"]):
        p = _mjchar(*argv, cwd=tmp_path)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert "Traceback" not in p.stderr
    assert not list(tmp_path.iterdir())


def test_a_closed_pipe_ends_quietly():
    """``mjchar info clip.bvh | head -1``: no BrokenPipeError, exit status 141 (or 0 when the
    output fitted in the pipe before it closed)."""
    p = subprocess.run(f"{sys.executable} -m mjchar info {WALK} | head -c 10; "
                       "echo \" rc=${PIPESTATUS[0]}\"",
                       shell=True, executable="/bin/bash", capture_output=True, text=True,
                       timeout=120)
    assert "Traceback" not in p.stderr and "BrokenPipe" not in p.stderr, p.stderr
    assert p.stdout.rstrip().endswith(("rc=141", "rc=0")), p.stdout


def test_version(capsys):
    import mjchar

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"mjchar {mjchar.__version__}"
