"""The installed package is what users run: build the sdist and the wheel, check them with twine,
install the wheel into a fresh virtual environment and use it from a folder outside the checkout.

The environment is created once for the module (about a minute: the build's isolated
environment and the wheel's dependencies come from the package index or pip's cache). Nothing in
it can see the checkout: the commands run from a temporary folder with ``PYTHONPATH`` unset, and
a test checks that the assets they load sit inside the environment.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
import venv
import zipfile
from pathlib import Path

import pytest
from conftest import ROOT, shared_clip
from test_checkout import _checkout_files


def _run(args, cwd, env, timeout=600) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)
    assert proc.returncode == 0, (f"{' '.join(map(str, args))} exited {proc.returncode}\n"
                                  f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return proc


class Installed:
    """A fresh virtual environment with the built wheel installed, and a folder to work in."""

    def __init__(self, root: Path):
        self.dist = root / "dist"
        self.venv = root / "venv"
        self.work = root / "work"
        self.work.mkdir()
        self.env = {k: v for k, v in os.environ.items()
                    if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
        self.env["PATH"] = f"{self.venv / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}"
        self.env["MUJOCO_GL"] = "egl"

    @property
    def python(self) -> Path:
        return self.venv / "bin" / "python"

    def run(self, *args, timeout=600) -> subprocess.CompletedProcess:
        return _run(args, self.work, self.env, timeout)

    def mjchar(self, *args) -> subprocess.CompletedProcess:
        return self.run(self.venv / "bin" / "mjchar", *args)


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Installed:
    pytest.importorskip("build", reason="building the wheel needs `build` (the test extra)")
    inst = Installed(tmp_path_factory.mktemp("wheel"))
    # python -m build: the sdist, then the wheel built from the sdist (so the sdist is complete),
    # from a copy of the checkout: a build writes into its source folder (the sdist's staging
    # tree, egg-info), and another test worker may be building or copying the checkout too
    source = inst.dist.parent / "source"
    for f in _checkout_files():
        (source / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / f, source / f)
    built = _run([sys.executable, "-m", "build", "--outdir", inst.dist, source], inst.work,
                 inst.env)
    inst.build_output = built.stdout + built.stderr
    venv.EnvBuilder(with_pip=True, clear=True).create(inst.venv)
    wheels = sorted(inst.dist.glob("mjchar-*.whl"))
    assert len(wheels) == 1, wheels
    inst.run(inst.python, "-m", "pip", "install", "-q", wheels[0])
    return inst


def test_the_build_prints_no_setuptools_warning(installed):
    """No "Package would be ignored" (data folders), no deprecation: a clean build log."""
    for warning in ("would be ignored", "SetuptoolsDeprecationWarning", "SetuptoolsWarning"):
        assert warning not in installed.build_output, installed.build_output


def test_twine_accepts_the_sdist_and_the_wheel(installed):
    pytest.importorskip("twine", reason="twine check needs twine (the test extra)")
    files = sorted(installed.dist.iterdir())
    assert {f.suffix for f in files} == {".whl", ".gz"}, files
    out = _run([sys.executable, "-m", "twine", "check", "--strict", *files], installed.work,
               installed.env).stdout
    assert out.count("PASSED") == 2, out


def test_the_wheel_ships_the_assets(installed):
    """``pip show -f`` lists the humanoid, the motions and the trajectories; they are loaded from
    the environment, not from the checkout."""
    listed = installed.run(installed.python, "-m", "pip", "show", "-f", "mjchar").stdout
    for f in ("mjchar/assets/mjcf/humanoid.xml", "mjchar/assets/motions/walk.bvh",
              "mjchar/assets/motions/idle.bvh", "mjchar/assets/trajectories/samcon_walk60.npz",
              "mjchar/assets/trajectories/cmaes_walk60_1.5s.npz", "mjchar/bench/schema.json",
              "mjchar/bench/cell_costs.json",
              "mjchar/controllers/sampling/samcon.py", "mjchar/bvh/io/reader.py",
              "mjchar/envs/imitation.py", "mjchar/commands/run.py"):
        assert f in listed, f"{f} not in the installed wheel:\n{listed}"
    where = installed.run(installed.python, "-c", "import mjchar.bvh.bundled.assets as a; "
                          "print(a.humanoid_path()); print(a.TRAJECTORIES)").stdout.split()
    for p in where:
        assert Path(p).is_relative_to(installed.venv), p
        assert not Path(p).is_relative_to(ROOT), p


def test_the_wheel_has_one_top_level_package(installed):
    """The wheel installs ``mjchar`` and nothing else at the top level (no ``bvh``, ``envs``,
    ``controllers`` or ``assets`` to clash with other distributions or a user's folders)."""
    wheel = sorted(installed.dist.glob("mjchar-*.whl"))[0]
    with zipfile.ZipFile(wheel) as z:
        tops = {name.split("/")[0] for name in z.namelist()}
    assert tops == {"mjchar", f"mjchar-{wheel.name.split('-')[1]}.dist-info"}, tops
    with zipfile.ZipFile(wheel) as z:
        licenses = [n for n in z.namelist() if n.endswith("/LICENSE")]
        assert licenses and b"Apache License" in z.read(licenses[0])


def test_pyproject_lists_every_package():
    """pyproject's explicit package list (the folders mapped into ``mjchar``) is complete."""
    with open(ROOT / "pyproject.toml", "rb") as fh:
        tool = tomllib.load(fh)["tool"]["setuptools"]
    found = set()
    for name, folder in tool["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder).parts
            found.add(".".join([name, *rel]))
    data = {f"mjchar.assets.{d.name}" for d in (ROOT / "assets").iterdir()
            if d.is_dir() and d.name != "__pycache__"}  # data folders, listed to ship them
    assert set(tool["packages"]) == found | data


def test_a_users_own_envs_and_bvh_packages_do_not_shadow_mjchar(installed):
    """In a project folder with its own ``envs/`` and ``bvh/`` packages (on ``sys.path`` first,
    as the current folder is for ``python -m`` and ``python -c``), mjchar runs and its envs
    make, and the user's packages stay theirs."""
    for pkg in ("envs", "bvh"):
        (installed.work / pkg).mkdir(exist_ok=True)
        (installed.work / pkg / "__init__.py").write_text(f"OWNER = 'user {pkg}'\n")
    try:
        res = json.loads(installed.run(installed.python, "-m", "mjchar", "run", "static_balance",
                                       "--duration", "1", "--json").stdout)
        assert res["controller"] == "static_balance" and not res["fell"]
        res = json.loads(installed.mjchar("run", "static_balance", "--duration", "1",
                                          "--json").stdout)
        assert not res["fell"]
        code = ("import gymnasium as gym, envs, bvh, mjchar.envs\n"
                "env = gym.make('mjchar/Imitation-v0')\n"
                "obs, _ = env.reset(seed=0)\n"
                "print(envs.OWNER, '/', bvh.OWNER, '/', obs.shape[0])")
        out = installed.run(installed.python, "-c", code).stdout.strip()
        user_envs, user_bvh, n_obs = (s.strip() for s in out.split("/"))
        assert (user_envs, user_bvh) == ("user envs", "user bvh") and int(n_obs) > 0
    finally:
        for pkg in ("envs", "bvh"):
            (installed.work / pkg / "__init__.py").unlink()
            (installed.work / pkg).rmdir()


def test_installed_mujoco_has_the_sparse_solver_fix(installed):
    version = installed.run(installed.python, "-c",
                            "import mujoco; print(mujoco.__version__)").stdout.strip()
    assert tuple(int(x) for x in version.split(".")[:3]) >= (4, 0, 1), version


def test_run_static_balance(installed):
    res = json.loads(installed.mjchar("run", "static_balance", "--duration", "2",
                                      "--json").stdout)
    assert res["controller"] == "static_balance" and not res["fell"]
    assert res["sim_time_s"] == pytest.approx(2.0, abs=0.01)
    assert res["root_force_mean_N"] == 0.0


def test_convert_a_shared_clip_with_verify(installed):
    clip = shared_clip("walk60.bvh")
    out = installed.mjchar("convert", clip, "-o", "walk60.xml", "--verify").stdout
    assert (installed.work / "walk60.xml").is_file()
    assert "mm" in out, out


def test_replay_a_bundled_trajectory(installed):
    traj = installed.run(installed.python, "-c", "import mjchar.bvh.bundled.assets as a; "
                         "print(a.TRAJECTORIES / 'samcon_walk60.npz')").stdout.strip()
    res = json.loads(installed.mjchar("run", "replay", traj, "--json").stdout)
    assert not res["fell"] and res["distance_m"] > 2.0
    assert res["tracking_error_m"] < 0.08


def test_gymnasium_env(installed):
    code = ("import gymnasium as gym, mjchar\n"
            "env = gym.make('mjchar/Imitation-v0')\n"
            "obs, _ = env.reset(seed=0)\n"
            "obs2, r, term, trunc, _ = env.step(env.action_space.sample())\n"
            "assert obs.shape == obs2.shape and env.observation_space.contains(obs2)\n"
            "print(r)")
    reward = float(installed.run(installed.python, "-c", code).stdout.strip())
    assert 0.0 <= reward <= 1.0 + 1e-9
