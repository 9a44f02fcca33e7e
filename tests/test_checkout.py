"""A fresh checkout works from any folder: the repository is copied to a folder named ``mjchar``
(what ``git clone`` names it), installed editable into a new environment as the README says,
and ``import mjchar``, ``python -m mjchar`` and the README's Python and RL examples run from the
checkout's parent folder (where the folder ``mjchar`` comes first on ``sys.path``) and from an
empty folder. A failing command shows its standard error.

The new environment borrows this one's dependencies (a ``.pth`` line naming its
site-packages, whose own ``.pth`` files, this checkout's editable install among them, are not
read), so only the checkout itself is installed: ``pip install --no-deps -e``."""

from __future__ import annotations

import shutil
import site
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from markdown_blocks import ROOT, blocks

VERSION = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


def _checkout_files() -> list[str]:
    """The files a clone has: git's tracked and new (not ignored) files, or every file outside
    ``.git``, ``.venv`` and caches when this is not a git checkout."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                              "--exclude-standard"], cwd=ROOT, capture_output=True, check=True,
                             timeout=60).stdout.decode()
        return [f for f in out.split("\0") if f and (ROOT / f).is_file()]
    except (OSError, subprocess.SubprocessError):
        skip = {".git", ".venv", "__pycache__", ".pytest_cache", ".ruff_cache"}
        return [p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*")
                if p.is_file() and not skip & set(p.relative_to(ROOT).parts)]


def _check(cmd: list[str], cwd: Path, timeout: float = 600) -> str:
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, (f"{' '.join(map(str, cmd))} in {cwd} exited {r.returncode}; "
                               f"stderr:\n{r.stderr}")
    return r.stdout


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    """``(python, checkout)``: a copy of the repository named ``mjchar``, installed editable
    into its own environment."""
    base = tmp_path_factory.mktemp("clone")
    checkout = base / "mjchar"
    for f in _checkout_files():
        (checkout / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / f, checkout / f)
    venv = base / "venv"
    _check([sys.executable, "-m", "venv", "--without-pip", str(venv)], base)
    python = venv / "bin" / "python"
    new_site = Path(_check([str(python), "-c", "import site; print(site.getsitepackages()[0])"],
                           base).strip())
    (new_site / "borrowed_dependencies.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    _check([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps",
            "-e", str(checkout)], base)
    return python, checkout


def _readme_python(section: str) -> str:
    return next(b.code for b in blocks("README.md") if b.lang == "python" and b.section == section)


@pytest.fixture(params=["parent", "empty"])
def folder(request, clone, tmp_path) -> Path:
    """The checkout's parent folder, or an empty one."""
    return clone[1].parent if request.param == "parent" else tmp_path


def test_import_mjchar_gives_the_checkouts_package(clone, folder):
    python, checkout = clone
    out = _check([str(python), "-c", "import mjchar, sys; print(mjchar.__version__); "
                  "print(mjchar.__file__); import mjchar.bvh; print(mjchar.bvh.__file__)"],
                 folder).splitlines()
    assert out[0] == VERSION
    assert Path(out[1]) == checkout / "mjchar" / "__init__.py"
    assert Path(out[2]) == checkout / "bvh" / "__init__.py"


def test_python_m_mjchar_runs(clone, folder):
    assert _check([str(clone[0]), "-m", "mjchar", "--version"], folder).strip() == \
        f"mjchar {VERSION}"


def test_the_readme_rl_example_runs(clone, folder):
    code = _readme_python("Reinforcement learning") + "\nprint(env.reset(seed=0)[0].shape)\n"
    out = _check([str(clone[0]), "-c", code], folder)
    assert out.strip().startswith("(")


@pytest.mark.slow
def test_the_readme_python_example_runs(clone, folder):
    out = _check([str(clone[0]), "-c", _readme_python("Python")], folder)
    assert "steps/min" in out
