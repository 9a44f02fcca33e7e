"""Input that cannot hurt: a corpus of hostile inputs run through ``mjchar`` in a real process.

Every case runs ``mjchar`` under a 1 GB address-space limit (``RLIMIT_AS``) with a 60 s alarm
per case, in one worker process for the whole corpus (the cases run one after another through
``mjchar.cli.main``, their standard error captured at the file-descriptor level, so MuJoCo's own
console output counts too). Each case must end as stated: exit status 2 with exactly one line on
standard error naming the problem, no traceback, and nothing written; or succeed when the input
is odd but valid (a UTF-16 file with a byte-order mark). Time and memory are bounded by
construction: a case that needed more than 1 GB would end in a MemoryError (a second line or a
traceback), one that needed more than 60 s in the alarm.

Big inputs are made quickly: sparse files (``truncate``) for size limits, devices for endless
streams. The costly cases (a 5,000-joint chain, a 50 MB clip, interrupting the bench) are marked
``slow``. Signals: Ctrl-C (SIGINT to the process group, as a terminal sends it) and SIGTERM (to
the command alone, as ``kill`` does) end a command with one line, exit 130 and 143, and leave no
partial file.
"""

from __future__ import annotations

import gzip
import json
import os
import re
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from mjchar.bvh.bundled.assets import TRAJECTORIES, humanoid_path, motion_path

WALK = motion_path("walk")
MODEL = humanoid_path()
TRAJECTORY = TRAJECTORIES / "samcon_walk60.npz"
LIMIT_BYTES = 1 << 30
CASE_SECONDS = 60

#: the worker: runs the cases of a JSON file through mjchar.cli.main under the limits
_WORKER = r"""
import io, json, os, resource, signal, sys, tempfile, time
resource.setrlimit(resource.RLIMIT_AS, (%(limit)d, %(limit)d))
cases, out_path = json.load(open(sys.argv[1])), sys.argv[2]
from mjchar.cli import main

class Alarm(BaseException):
    pass

def on_alarm(*a):
    raise Alarm()

signal.signal(signal.SIGALRM, on_alarm)
results = {}
for name, argv, cwd in cases:
    os.chdir(cwd)
    err = tempfile.TemporaryFile()
    out = tempfile.TemporaryFile()
    saved = os.dup(1), os.dup(2)
    sys.stdout.flush(); sys.stderr.flush()
    os.dup2(out.fileno(), 1); os.dup2(err.fileno(), 2)
    t0 = time.perf_counter()
    signal.alarm(%(seconds)d)
    try:
        rc = main(argv)
    except Alarm:
        rc = "timeout"
    except BaseException as e:
        import traceback
        traceback.print_exc()
        rc = "exception " + type(e).__name__
    finally:
        signal.alarm(0)
        sys.stdout.flush(); sys.stderr.flush()
        os.dup2(saved[0], 1); os.dup2(saved[1], 2)
        os.close(saved[0]); os.close(saved[1])
    err.seek(0); out.seek(0)
    results[name] = {"rc": rc, "stderr": err.read().decode("utf-8", "replace"),
                     "stdout": out.read()[:2000].decode("utf-8", "replace"),
                     "seconds": time.perf_counter() - t0}
json.dump(results, open(out_path, "w"))
"""


# -- the corpus's files -------------------------------------------------------------------------
def _header(n_joints: int = 2) -> str:
    """A small valid hierarchy: a root with position channels and a chain below it."""
    text = ("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition "
            "Zrotation Xrotation Yrotation\n")
    for j in range(1, n_joints):
        text += f"JOINT j{j}\n{{\nOFFSET 0 10 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
    text += "End Site\n{\nOFFSET 0 10 0\n}\n" + "}\n" * n_joints
    return text


def _chain(n_joints: int, n_frames: int = 2) -> str:
    n_ch = 6 + 3 * (n_joints - 1)
    return (_header(n_joints) + f"MOTION\nFrames: {n_frames}\nFrame Time: 0.0333333\n"
            + ("0 " * n_ch + "\n") * n_frames)


def _sparse(path: Path, size: int) -> Path:
    with open(path, "wb") as fh:
        fh.truncate(size)
    return path


def _npy_header(shape: tuple[int, ...]) -> bytes:
    import io

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False,
                                               "shape": shape})
    return buf.getvalue()


def _make_files(d: Path) -> None:
    walk = WALK.read_text()
    model = MODEL.read_text()
    w = lambda name, text: (d / name).write_text(text, encoding="utf-8")  # noqa: E731
    b = lambda name, data: (d / name).write_bytes(data)  # noqa: E731
    # BVH: other formats
    b("fbx_binary.bvh", b"Kaydara FBX Binary  \x00\x1a\x00\xe8\x1c\x00\x00" + bytes(200))
    w("fbx_ascii.bvh", "; FBX 7.4.0 project file\n; Copyright 2001-2014 Autodesk\n")
    b("c3d.bvh", bytes([2, 0x50]) + bytes(510))
    w("gltf.bvh", '{"asset": {"version": "2.0"}, "scenes": []}')
    b("glb.bvh", b"glTF\x02\x00\x00\x00" + bytes(100))
    with zipfile.ZipFile(d / "zip.bvh", "w") as z:
        z.writestr("walk.bvh", walk)
    b("gzip.bvh", gzip.compress(walk.encode()))
    w("json.bvh", '{"frames": [1, 2, 3]}')
    w("html.bvh", "<!DOCTYPE html><html><body>404</body></html>")
    w("lfs.bvh", "version https://git-lfs.github.com/spec/v1\noid sha256:abc\nsize 123\n")
    w("asf.bvh", "# AST/ASF file generated\n:version 1.10\n:name VICON\n")
    b("npy.bvh", b"\x93NUMPY\x01\x00" + bytes(100))
    b("png.bvh", b"\x89PNG\r\n\x1a\n" + bytes(100))
    b("elf.bvh", b"\x7fELF\x02\x01\x01" + bytes(100))
    b("utf16_nobom.bvh", walk.encode("utf-16-le"))
    b("utf16_bom.bvh", walk.encode("utf-16"))
    b("utf8_bom.bvh", b"\xef\xbb\xbf" + walk.encode())
    b("empty.bvh", b"")
    w("blank.bvh", "\n \n\t\n")
    _sparse(d / "sparse_4g.bvh", 4 << 30)
    # BVH: text that would cost too much, or names that cannot be
    head, _, rest = walk.partition("MOTION")
    lines = rest.strip().splitlines()
    w("frames_1e30.bvh", head + "MOTION\nFrames: " + "9" * 30 + "\n" + "\n".join(lines[1:]))
    w("long_line.bvh", head + "MOTION\nFrames: 1\nFrame Time: 0.01\n" + "1" * (10 << 20) + "\n")
    w("no_motion_5mb.bvh", head + ("JOINT x\n" * 700_000))
    w("many_words.bvh", "HIERARCHY\nROOT a\n{\n" + "{ } " * 600_000 + "\n")
    w("nul_name.bvh", walk.replace("JOINT lHip", "JOINT lH\x00ip", 1))
    w("ctrl_name.bvh", walk.replace("JOINT lHip", "JOINT lH\x01ip", 1))
    w("del_name.bvh", walk.replace("JOINT lHip", "JOINT lH\x7fip", 1))
    w("long_name.bvh", walk.replace("JOINT lHip", "JOINT " + "x" * 100_000, 1)
      .replace("JOINT rHip", "JOINT " + "x" * 100_000, 1))
    flat = ["HIERARCHY", "ROOT r", "{", "OFFSET 0 0 0", "CHANNELS 0"]
    flat += [f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n}}" for k in range(20_001)]
    w("joints_20k.bvh", "\n".join(flat + ["}", "MOTION", "Frames: 0", "Frame Time: 0.1", ""]))
    w("braces.bvh", "HIERARCHY\nROOT a\n" + "{\n" * 100_000)
    n_values = len(lines[2].split())
    w("nan_value.bvh", head + "MOTION\nFrames: 1\nFrame Time: 0.01\n"
      + " ".join(["nan"] * n_values) + "\n")
    w("huge_value.bvh", head + "MOTION\nFrames: 1\nFrame Time: 0.01\n"
      + " ".join(["1e308"] * n_values) + "\n")
    w("latin1_name.bvh", "")
    (d / "latin1_name.bvh").write_bytes(walk.replace("JOINT lHip", "JOINT lH\xe9", 1)
                                        .encode("latin-1"))
    w("chain_300.bvh", _chain(300))
    w("frame_time_tiny.bvh", re.sub(r"Frame Time:\s*\S+", "Frame Time: 1e-300", walk))
    os.mkfifo(d / "a_pipe.xml")
    os.mkfifo(d / "a_pipe.bvh")  # nothing ever writes to it
    (d / os.fsdecode(b"w\xff.bvh")).write_text(walk)  # names that are not valid UTF-8
    (d / os.fsdecode(b"m\xff.xml")).write_text(model)
    # roles and gains files
    b("binary.dat", bytes(range(256)) * 40)
    b("roles_utf16_bom.toml", 'left_knee = "lKnee"\n'.encode("utf-16"))
    b("roles_utf16_nobom.toml", 'left_knee = "lKnee"\n'.encode("utf-16-le"))
    w("roles_deep.toml", "a = " + "[" * 100_000)
    w("roles_unknown.toml", 'left_tail = "lKnee"\n')
    w("roles_not_toml.toml", "this is not toml\n")
    w("roles_json.toml", '{"left_knee": "lKnee"}')
    _sparse(d / "roles_sparse.toml", 10 << 20)
    w("gains_deep.json", "[" * 100_000)
    w("gains_list.json", "[1, 2, 3]")
    w("gains_nan.json", '{"default": {"kp": NaN}}')
    w("gains_huge.json", '{"default": {"kp": 1e400}}')
    b("gains_utf16_bom.json", '{"default": {"kp": 300}}'.encode("utf-16"))
    w("gains_toml.json", 'default = "x"\n')
    _sparse(d / "gains_sparse.json", 10 << 20)
    # models
    first_mass = model.index('mass="')
    end = model.index('"', first_mass + 6)

    def with_mass(text: str) -> str:
        return model[:first_mass] + f'mass="{text}"' + model[end + 1:]

    for name, value in (("nan", "nan"), ("inf", "inf"), ("neginf", "-inf"), ("neg", "-3"),
                        ("heavy", "1e9")):
        w(f"model_mass_{name}.xml", with_mass(value))
    w("model_timestep_nan.xml", model.replace("<option ", '<option timestep="NaN" ', 1)
      if 'timestep="' not in model else model.replace('timestep="', 'timestep="nan" x="', 1))
    w("model_timestep_big.xml", model.replace('timestep="0.002"', 'timestep="5"', 1))
    w("model_damping_nan.xml", model.replace("<joint ", '<joint damping="nan" ', 1))
    w("model_truncated.xml", model[:len(model) // 2])
    w("model_include_missing.xml", '<mujoco><include file="no_such_part.xml"/></mujoco>')
    w("model_include_truncated.xml", '<mujoco><include file="model_truncated.xml"/></mujoco>')
    w("model_empty.xml", "")
    b("model_binary.xml", bytes(range(256)) * 4)
    w("model_not_xml.xml", "hello\n")
    _sparse(d / "model_sparse.xml", 100 << 20)
    (d / "a_folder").mkdir()
    # trajectories
    np.savez(d / "traj_other.npz", a=np.zeros(3))
    b("traj_random.npz", bytes(range(256)) * 20)
    with zipfile.ZipFile(d / "traj_bomb.npz", "w") as z:
        z.writestr("targets.npy", _npy_header((10**6, 10**4)))
    b("traj_empty.npz", b"")
    with zipfile.ZipFile(d / "traj_truncated.npz", "w") as z:
        z.writestr("format.npy", _npy_header((4,)) + b"\x00" * 8)
    data = dict(np.load(TRAJECTORY, allow_pickle=False))
    data["targets"] = data["targets"] * np.nan
    np.savez(d / "traj_nan.npz", **data)
    w("traj_bvh.npz", walk)


# -- the cases: (name, argv, expected exit status, text the one line holds) ----------------------
def _cases(d: Path) -> list[tuple[str, list[str], int, str]]:
    walk = str(WALK)
    p = lambda name: str(d / name)  # noqa: E731
    cases = [
        # the issue's list
        ("issue_gains_binary", ["convert", walk, "-o", "o.xml", "--gains", p("binary.dat")],
         2, "binary data"),
        ("issue_roles_binary", ["convert", walk, "-o", "o.xml", "--roles", p("binary.dat")],
         2, "binary data"),
        ("issue_info_roles_utf16", ["info", walk, "--roles", p("roles_utf16_bom.toml")], 0, ""),
        ("issue_info_roles_utf16_nobom",
         ["info", walk, "--roles", p("roles_utf16_nobom.toml")], 2, "binary data"),
        ("issue_info_sparse_4g", ["info", p("sparse_4g.bvh")], 2, "limit for a BVH file"),
        ("issue_info_dev_zero", ["info", "/dev/zero"], 2, "binary data"),
        ("issue_info_dev_urandom", ["info", "/dev/urandom"], 2, "binary data"),
        ("issue_info_nul_name", ["info", p("nul_name.bvh")], 2, "control character"),
        ("issue_convert_nul_name", ["convert", p("nul_name.bvh"), "-o", "o.xml"], 2,
         "control character"),
        ("issue_model_truncated", ["run", "pd", "--model", p("model_truncated.xml"),
                                   "--duration", "0.05"], 2, "not well-formed XML"),
        ("issue_model_include", ["run", "pd", "--model", p("model_include_truncated.xml"),
                                 "--duration", "0.05"], 2, "included file"),
        ("issue_model_mass_nan", ["run", "pd", "--model", p("model_mass_nan.xml"),
                                  "--duration", "0.05"], 2, 'mass="nan"'),
        ("issue_bench_garbage_trajectory",
         ["bench", "--quick", "--controllers", "samcon_replay", "--samcon-trajectory",
          p("traj_random.npz"), "--out", "bench_out"], 2, "not a saved mjchar trajectory"),
        ("issue_gait_reference_dir", ["gait", "simbicon", "--reference", p("a_folder")], 2,
         "a folder"),
        # BVH: other formats, named with what to do
        ("bvh_fbx_binary", ["info", p("fbx_binary.bvh")], 2, "FBX file (binary)"),
        ("bvh_fbx_ascii", ["info", p("fbx_ascii.bvh")], 2, "FBX file (ASCII)"),
        ("bvh_c3d", ["convert", p("c3d.bvh"), "-o", "o.xml"], 2, "C3D"),
        ("bvh_gltf", ["info", p("gltf.bvh")], 2, "glTF"),
        ("bvh_glb", ["info", p("glb.bvh")], 2, "glTF binary"),
        ("bvh_zip", ["info", p("zip.bvh")], 2, "zip archive"),
        ("bvh_gzip", ["info", p("gzip.bvh")], 2, "gunzip"),
        ("bvh_json", ["info", p("json.bvh")], 2, "JSON file"),
        ("bvh_html", ["info", p("html.bvh")], 2, "web page"),
        ("bvh_lfs", ["info", p("lfs.bvh")], 2, "git lfs pull"),
        ("bvh_asf", ["info", p("asf.bvh")], 2, "ASF/AMC"),
        ("bvh_npy", ["info", p("npy.bvh")], 2, "NumPy"),
        ("bvh_png", ["info", p("png.bvh")], 2, "PNG"),
        ("bvh_elf", ["info", p("elf.bvh")], 2, "ELF"),
        ("bvh_utf16_nobom", ["info", p("utf16_nobom.bvh")], 2, "binary data"),
        ("bvh_utf16_bom", ["info", p("utf16_bom.bvh")], 0, ""),
        ("bvh_utf8_bom", ["info", p("utf8_bom.bvh")], 0, ""),
        ("bvh_latin1_name", ["info", p("latin1_name.bvh")], 0, ""),
        ("bvh_empty", ["info", p("empty.bvh")], 2, "HIERARCHY"),
        ("bvh_blank", ["info", p("blank.bvh")], 2, "HIERARCHY"),
        ("bvh_folder", ["info", p("a_folder")], 2, "Is a directory"),
        ("bvh_missing", ["info", p("no_such.bvh")], 2, "No such file"),
        # BVH: text that would cost too much
        ("bvh_frames_1e30", ["info", p("frames_1e30.bvh")], 2, "file ends early"),
        ("bvh_long_line", ["info", p("long_line.bvh")], 2, "too long"),
        ("bvh_no_motion_5mb", ["info", p("no_motion_5mb.bvh")], 2, "line"),
        ("bvh_many_words", ["info", p("many_words.bvh")], 2, "line"),
        ("bvh_20k_joints", ["info", p("joints_20k.bvh")], 2, "10000 joints"),
        ("bvh_braces", ["info", p("braces.bvh")], 2, "line"),
        ("bvh_ctrl_name", ["info", p("ctrl_name.bvh")], 2, "U+0001"),
        ("bvh_del_name", ["convert", p("del_name.bvh"), "-o", "o.xml"], 2, "U+007F"),
        ("bvh_long_name", ["convert", p("long_name.bvh"), "-o", "o.xml"], 2, "more characters"),
        ("bvh_nan_value", ["info", p("nan_value.bvh")], 2, "finite number"),
        ("bvh_huge_value", ["info", p("huge_value.bvh")], 2, "cannot describe a pose"),
        ("bvh_chain_300", ["info", p("chain_300.bvh")], 0, ""),
        ("bvh_frame_time_tiny", ["run", "mpc", "--motion", p("frame_time_tiny.bvh"),
                                 "--duration", "0.1"], 2, "not a frame time"),
        ("output_is_a_pipe", ["convert", walk, "-o", p("a_pipe.xml")], 2, "device or pipe"),
        ("input_is_a_pipe_with_no_writer", ["info", p("a_pipe.bvh")], 2, "nothing writing"),
        ("name_not_utf8_convert", ["convert", p(os.fsdecode(b"w\xff.bvh")), "-o",
                                   os.fsdecode(b"o\xff.xml")], 0, ""),
        ("name_not_utf8_model", ["run", "pd", "--model", p(os.fsdecode(b"m\xff.xml"))], 2,
         "not valid UTF-8"),
        # roles files
        ("roles_deep", ["convert", walk, "-o", "o.xml", "--roles", p("roles_deep.toml")], 2,
         "nests too deeply"),
        ("roles_unknown", ["info", walk, "--roles", p("roles_unknown.toml")], 2,
         "unknown role"),
        ("roles_not_toml", ["info", walk, "--roles", p("roles_not_toml.toml")], 2,
         "not valid TOML"),
        ("roles_json", ["info", walk, "--roles", p("roles_json.toml")], 2, "not valid TOML"),
        ("roles_sparse", ["info", walk, "--roles", p("roles_sparse.toml")], 2, "limit"),
        ("roles_dev_zero", ["info", walk, "--roles", "/dev/zero"], 2, "binary data"),
        ("roles_folder", ["info", walk, "--roles", p("a_folder")], 2, "Is a directory"),
        ("roles_fbx", ["info", walk, "--roles", p("fbx_binary.bvh")], 2, "FBX"),
        # gains files
        ("gains_deep", ["convert", walk, "-o", "o.xml", "--gains", p("gains_deep.json")], 2,
         "nests too deeply"),
        ("gains_list", ["convert", walk, "-o", "o.xml", "--gains", p("gains_list.json")], 2,
         "gains must map"),
        ("gains_nan", ["convert", walk, "-o", "o.xml", "--gains", p("gains_nan.json")], 2,
         "must be a number"),
        ("gains_huge", ["convert", walk, "-o", "o.xml", "--gains", p("gains_huge.json")], 2,
         "must be a number"),
        ("gains_toml", ["convert", walk, "-o", "o.xml", "--gains", p("gains_toml.json")], 2,
         "not valid JSON"),
        ("gains_sparse", ["convert", walk, "-o", "o.xml", "--gains", p("gains_sparse.json")],
         2, "limit"),
        ("gains_urandom", ["convert", walk, "-o", "o.xml", "--gains", "/dev/urandom"], 2,
         "gains file"),
        ("gains_gzip", ["convert", walk, "-o", "o.xml", "--gains", p("gzip.bvh")], 2, "gzip"),
        # models
        ("model_mass_inf", ["run", "pd", "--model", p("model_mass_inf.xml")], 2, 'mass="inf"'),
        ("model_mass_neginf", ["run", "pd", "--model", p("model_mass_neginf.xml")], 2,
         'mass="-inf"'),
        ("model_mass_negative", ["run", "pd", "--model", p("model_mass_neg.xml")], 2,
         "negative"),
        ("model_mass_heavy", ["run", "pd", "--model", p("model_mass_heavy.xml")], 2,
         "not a body's mass"),
        ("model_timestep_nan", ["run", "pd", "--model", p("model_timestep_nan.xml")], 2,
         "not a finite number"),
        ("model_timestep_big", ["run", "pd", "--model", p("model_timestep_big.xml")], 2,
         "time step"),
        ("model_damping_nan", ["run", "pd", "--model", p("model_damping_nan.xml")], 2,
         'damping="nan"'),
        ("model_include_missing", ["run", "pd", "--model", p("model_include_missing.xml")], 2,
         "no_such_part.xml"),
        ("model_empty", ["run", "pd", "--model", p("model_empty.xml")], 2, "model"),
        ("model_binary", ["run", "pd", "--model", p("model_binary.xml")], 2, "model"),
        ("model_not_xml", ["run", "pd", "--model", p("model_not_xml.xml")], 2, "MJCF"),
        ("model_sparse", ["run", "pd", "--model", p("model_sparse.xml")], 2, "model"),
        ("model_is_bvh", ["run", "pd", "--model", walk], 2, "BVH clip"),
        ("model_folder", ["run", "pd", "--model", p("a_folder")], 2, "a_folder"),
        ("model_gait_truncated", ["gait", "simbicon", "--model", p("model_truncated.xml")], 2,
         "not well-formed XML"),
        # trajectories
        ("traj_other_npz", ["run", "replay", p("traj_other.npz")], 2, "not a saved mjchar"),
        ("traj_random", ["run", "replay", p("traj_random.npz")], 2, "not a saved mjchar"),
        ("traj_bomb", ["run", "replay", p("traj_bomb.npz")], 2, "unpack to more than"),
        ("traj_empty", ["run", "replay", p("traj_empty.npz")], 2, "not a saved mjchar"),
        ("traj_truncated", ["run", "replay", p("traj_truncated.npz")], 2, "trajectory"),
        ("traj_nan", ["run", "replay", p("traj_nan.npz")], 2, "NaN"),
        ("traj_bvh", ["run", "replay", p("traj_bvh.npz")], 2, "not a saved mjchar"),
        ("traj_bench_bomb",
         ["bench", "--quick", "--controllers", "samcon_replay", "--samcon-trajectory",
          p("traj_bomb.npz"), "--out", "bench_out"], 2, "unpack to more than"),
        ("traj_bench_other",
         ["bench", "--quick", "--controllers", "cmaes_replay", "--cmaes-trajectory",
          p("traj_other.npz"), "--out", "bench_out"], 2, "not a saved mjchar"),
    ]
    return cases


CASE_NAMES = [c[0] for c in _cases(Path("."))]


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> dict:
    """Every case run once, in one worker under the limits: ``{name: result}``."""
    d = tmp_path_factory.mktemp("hostile")
    _make_files(d)
    cases = _cases(d)
    work = {}
    for name, _, _, _ in cases:
        work[name] = d / "cwd" / name
        work[name].mkdir(parents=True)
    case_file, out_file = d / "cases.json", d / "results.json"
    case_file.write_text(json.dumps([[n, argv, str(work[n])] for n, argv, _, _ in cases]))
    worker = _WORKER % {"limit": LIMIT_BYTES, "seconds": CASE_SECONDS}
    env = {**os.environ, "MUJOCO_GL": "egl"}
    p = subprocess.run([sys.executable, "-c", worker, str(case_file), str(out_file)],
                       capture_output=True, text=True, env=env,
                       timeout=CASE_SECONDS * len(cases))
    assert p.returncode == 0 and out_file.is_file(), p.stderr[-3000:]
    results = json.loads(out_file.read_text())
    expected = {n: (rc, needle) for n, _, rc, needle in cases}
    return {n: {**r, "expected": expected[n], "cwd": work[n]} for n, r in results.items()}


def test_the_corpus_is_large():
    own = [n for n in CASE_NAMES if not n.startswith("issue_")]
    assert len(own) >= 40 and len(set(CASE_NAMES)) == len(CASE_NAMES)


@pytest.mark.parametrize("name", CASE_NAMES)
def test_hostile_input_ends_in_one_line(corpus, name):
    r = corpus[name]
    want_rc, needle = r["expected"]
    err = r["stderr"]
    assert r["rc"] == want_rc, (r["rc"], err[-2000:])
    assert "Traceback" not in err and "MemoryError" not in err, err[-2000:]
    if want_rc == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err[-2000:]
        assert lines[0].startswith("mjchar "), lines[0]
        assert needle.lower() in lines[0].lower(), lines[0]
        assert len(lines[0]) <= 700, len(lines[0])
        # nothing written where the command ran (no output, no partial file, no MuJoCo log)
        assert not list(r["cwd"].iterdir()), list(r["cwd"].iterdir())
    else:
        assert "error" not in err.lower(), err[-2000:]


# -- the reader's chunks, in process --------------------------------------------------------------
@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
def test_frames_read_in_chunks_equal_one_pass(monkeypatch, newline):
    """Frames parsed in small chunks (every boundary case: a CRLF never split) give the same
    values, and an error's line and frame, as one pass over the text."""
    from mjchar import bvh
    from mjchar.bvh.io import reader

    text = WALK.read_text().replace("\n", newline)
    whole = bvh.loads(text).source_channels
    monkeypatch.setattr(reader, "_CHUNK_CHARS", 997)
    np.testing.assert_array_equal(bvh.loads(text).source_channels, whole)
    lines = text.split(newline)
    k = len(lines) - 5
    lines[k] = lines[k].replace(" ", " x", 1)
    with pytest.raises(bvh.BVHError) as e:
        bvh.loads(newline.join(lines))
    assert e.value.line == k + 1, str(e.value)


def test_a_huge_frame_count_does_not_allocate_it():
    """'Frames: 10**12' over two frame lines: the array is sized by the text, not the count."""
    from mjchar import bvh

    text = _chain(2).replace("Frames: 2", "Frames: 1000000000000")
    with pytest.raises(bvh.BVHError, match="found 2: the file ends early"):
        bvh.loads(text)


def test_other_formats_are_named_by_their_first_bytes():
    from mjchar.bvh.io.inputs import sniff

    assert "FBX file (binary)" in sniff(b"Kaydara FBX Binary  \x00")
    assert "C3D" in sniff(bytes([2, 0x50, 0, 0]))
    assert "zip archive" in sniff(b"PK\x03\x04rest")
    assert sniff(b"HIERARCHY\nROOT Hips\n") is None
    assert sniff(b'{"default": {"kp": 1}}', "JSON") is None
    assert sniff(b"\x09P") is None  # a tab then 'P' is text, not C3D


# -- the slow tier: big inputs and signals --------------------------------------------------------
def _limited(argv: list[str], cwd: Path, **kw) -> subprocess.CompletedProcess:
    """``mjchar ARGV`` in a process of its own under the 1 GB limit."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (LIMIT_BYTES, LIMIT_BYTES))

    return subprocess.run([sys.executable, "-m", "mjchar", *argv], cwd=cwd, capture_output=True,
                          text=True, preexec_fn=limit, timeout=CASE_SECONDS,
                          env={**os.environ, "MUJOCO_GL": "egl"}, **kw)


@pytest.mark.slow
def test_a_5000_joint_chain_is_read_in_linear_time(tmp_path):
    """info and convert of a 5,000-joint chain finish within the case's 60 s (they took 54 s
    and 50 s when a trunk walk was quadratic), the error listing 30 of the joints."""
    path = tmp_path / "chain.bvh"
    path.write_text(_chain(5000))
    info = _limited(["info", str(path)], tmp_path)
    assert info.returncode == 0, info.stderr[-2000:]
    conv = _limited(["convert", str(path), "-o", str(tmp_path / "c.xml")], tmp_path)
    assert conv.returncode == 2 and len(conv.stderr.strip().splitlines()) == 1, conv.stderr
    assert len(conv.stderr) <= 700 and "(4970 more)" in conv.stderr


@pytest.mark.slow
def test_a_body_with_a_2000_joint_tail_converts_in_linear_time(tmp_path):
    """The bundled walk with a 2,000-joint chain below its head: the converter's whole path
    (roles, canonical rest, bodies kept, geometry) within the case's 60 s and 1 GB (it took
    50 s with walks up from every joint)."""
    from mjchar.perf.hostile import with_tail

    path = tmp_path / "tail.bvh"
    path.write_text(with_tail(2000))
    for argv in (["info", str(path)], ["convert", str(path), "-o", str(tmp_path / "t.xml")]):
        p = _limited(argv, tmp_path)
        assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr[-2000:]
    assert "dropped: face 2000 joints" in p.stdout  # the dropped tail, summed up in one line


@pytest.mark.slow
def test_a_50_mb_clip_is_read_within_the_memory_limit(tmp_path):
    """A 50 MB file of repeated frames: info and convert under 1 GB (777 MB, 15 times the
    file, before frames were read in chunks)."""
    head, _, rest = WALK.read_text().partition("MOTION")
    frames = rest.strip().splitlines()[2:]
    reps = (50 << 20) // sum(len(f) + 1 for f in frames) + 1
    body = "\n".join(frames) + "\n"
    path = tmp_path / "long.bvh"
    path.write_text(head + f"MOTION\nFrames: {reps * len(frames)}\nFrame Time: 0.0333333\n"
                    + body * reps)
    for argv in (["info", str(path)], ["convert", str(path), "-o", str(tmp_path / "l.xml")]):
        p = _limited(argv, tmp_path)
        assert p.returncode == 0 and "Traceback" not in p.stderr, p.stderr[-2000:]


def _signalled(argv: list[str], cwd: Path, sig: int, after_s: float, group: bool):
    """Start ``mjchar ARGV`` in a session of its own, send ``sig`` after ``after_s`` seconds
    (to the whole group, as a terminal's Ctrl-C does, or to the command alone, as ``kill``)."""
    # a terminal's child gets SIGINT's default action; a test worker may have it ignored (as a
    # background job does), which the child would inherit and keep
    p = subprocess.Popen([sys.executable, "-m", "mjchar", *argv], cwd=cwd,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True, env={**os.environ, "MUJOCO_GL": "egl"},
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(after_s)
    if group:
        os.killpg(p.pid, sig)
    else:
        os.kill(p.pid, sig)
    out, err = p.communicate(timeout=CASE_SECONDS)
    return p.returncode, err


def _last_line(err: str) -> str:
    return err.replace("\r", "\n").strip().splitlines()[-1]


@pytest.mark.parametrize("sig,code,word", [(signal.SIGINT, 130, "interrupted"),
                                           (signal.SIGTERM, 143, "terminated")])
def test_a_signal_ends_a_run_in_one_line(tmp_path, sig, code, word):
    rc, err = _signalled(["run", "static_balance", "--duration", "600", "--json"], tmp_path, sig,
                         10.0,
                         group=sig == signal.SIGINT)
    assert rc == code, err[-2000:]
    assert "Traceback" not in err and err.strip().splitlines() == [f"mjchar run: {word}"], err
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_ends_the_bench_without_worker_tracebacks(tmp_path, sig, code):
    """Ctrl-C (or SIGTERM) during ``bench --quick``: one line from the command, none from its
    workers, the earlier results intact."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text("{}")
    rc, err = _signalled(["bench", "--quick", "--no-perf", "--no-plots", "--out", str(out)],
                         tmp_path, sig, 25.0, group=sig == signal.SIGINT)
    assert rc == code, err[-2000:]
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-3000:]
    assert _last_line(err).startswith("bench:") or _last_line(err).startswith("mjchar bench")
    assert (out / "results.json").read_text() == "{}"
    assert sorted(x.name for x in out.iterdir()) == ["results.json"]


@pytest.mark.slow
def test_sigterm_during_render_leaves_no_partial_video(tmp_path):
    video = tmp_path / "v.mp4"
    video.write_bytes(b"old")
    # a standing run (a PD run falls and ends on its own before the signal on a fast machine)
    rc, err = _signalled(["run", "static_balance", "--duration", "120", "--render", str(video)],
                         tmp_path,
                         signal.SIGTERM, 15.0, group=False)
    assert rc == 143 and "Traceback" not in err, err[-2000:]
    assert video.read_bytes() == b"old"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["v.mp4"]


def test_binary_data_that_starts_with_a_brace_is_binary_not_json(tmp_path):
    """Random bytes start with ``{`` or ``[`` one time in 128 (``info /dev/urandom`` said "a
    JSON file" then): binary data is named as such whatever its first byte."""
    path = tmp_path / "noise.bvh"
    path.write_bytes(b"{" + bytes(range(256)) * 16)
    from mjchar import bvh

    with pytest.raises(bvh.BVHError, match="binary data"):
        bvh.load(path)
