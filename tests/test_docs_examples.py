"""Every code block of README.md and docs/*.md runs, so an example cannot go stale.

A block says what it is by its fence: ``python`` (a program, run whole in a fresh interpreter),
``python fragment`` (an excerpt such as a signature: compiled and its imports resolved),
``bash`` (commands, each line run), ``console`` (``$ command`` lines, each followed by what it
prints: run, and the printed lines found in its output), ``text``, ``toml`` and ``json``
(output, synopses, file contents: not run). Every block runs in a scratch folder holding the
files the docs name (``walk.bvh`` the bundled walk; ``walk60.bvh``, ``walk_forward.bvh`` and
``my_walk.bvh`` the shared clips), the folder's parent holding ``shared`` as the repository's
parent does.

Tiers: the default tier checks every block's kind, every path docs name, compiles every Python
block and resolves its imports, and runs the commands that take seconds (``info``,
``convert``, ``params``, help, the error examples, ``run``/``gait`` with their ``--duration``
cut to 2 s, 5 s for ``gait``); the ``slow`` tier runs every Python program; the ``docs_full``
tier (``-m docs_full``, hours on two cores: benchmarks and full push searches among them, so
not in CI) runs every command as written (the install and test-suite lines excepted:
tests/test_checkout.py and CI run those).
"""

from __future__ import annotations

import ast
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from markdown_blocks import ROOT, Block, blocks, markdown_files

KINDS = {"python", "bash", "console", "text", "toml", "json"}
SHARED_BVH = ROOT.parent / "shared" / "data" / "bvh"
BIN = Path(sys.executable).parent

ALL = [b for f in markdown_files() for b in blocks(f)]
PYTHON = [b for b in ALL if b.lang == "python"]


def _is_fragment(b: Block) -> bool:
    return (ROOT / b.file).read_text().splitlines()[b.line - 1].split()[1:2] == ["fragment"]


def _commands(b: Block) -> list[tuple[str, list[str]]]:
    """``(command, expected output lines)`` of a bash or console block."""
    text = re.sub(r"\\\n\s*", " ", b.code)
    out: list[tuple[str, list[str]]] = []
    for line in text.splitlines():
        if b.lang == "console" and not line.startswith("$ "):
            if out and line.strip():
                out[-1][1].append(line.strip())
            continue
        line = line.removeprefix("$ ")
        cmd = re.sub(r"\s+#.*$", "", line).strip()
        if cmd and not cmd.startswith("#"):
            out.append((cmd, []))
    return out


def _skipped(cmd: str) -> bool:
    """Installing and running the test suite: tests/test_checkout.py and CI do those."""
    return bool(re.search(r"\bpip install\b|\bpytest\b|\bvenv\b", cmd))


def _quick(cmd: str) -> str | None:
    """The command in a form that takes seconds, or None when it has none."""
    words = shlex.split(cmd)
    if "&&" in words:
        return None
    if words[:1] != ["mjchar"]:
        return None
    if words[1] in ("info", "convert", "params") or "--help" in words:
        return cmd
    if words[1] in ("run", "gait") and "--duration" in words:
        i = words.index("--duration")  # gait analyses from --from on (3 s by default)
        start = float(words[words.index("--from") + 1]) if "--from" in words else 3.0
        short = 2.0 if words[1] == "run" else start + 2.0
        words[i + 1] = str(min(float(words[i + 1]), short))
        return shlex.join(words)
    return None


COMMANDS = [(b, cmd, expected) for b in ALL if b.lang in ("bash", "console")
            for cmd, expected in _commands(b) if not _skipped(cmd)]


def _id(item) -> str:
    b, cmd = item[0], item[1]
    return f"{b.where}: {cmd[:60]}"


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """A scratch folder with the files the docs' examples name."""
    from mjchar import assets
    from mjchar.bvh.bundled.assets import MOTIONS

    base = tmp_path_factory.mktemp("docs")
    work = base / "work"
    for sub in ("docs/gait", "docs/bench"):
        (work / sub).mkdir(parents=True)
    shutil.copy(MOTIONS / "walk.bvh", work / "walk.bvh")
    # a policy file as `mjchar learn` writes it
    shutil.copy(Path(assets.__file__).parent / "policies" / "walk60.npz", work / "walk60.npz")
    if SHARED_BVH.is_dir():
        (base / "shared").symlink_to(SHARED_BVH.parent.parent)
        for name in ("walk60.bvh", "walk_forward.bvh"):
            shutil.copy(SHARED_BVH / name, work / name)
        shutil.copy(SHARED_BVH / "walk60.bvh", work / "my_walk.bvh")
    return work


def _needs_shared(text: str) -> bool:
    return bool(re.search(r"walk60|walk_forward|my_walk|\.\./shared", text))


def _run(cmd: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


def _skip_without_shared(text: str) -> None:
    if _needs_shared(text) and not SHARED_BVH.is_dir():
        pytest.skip("needs the motion-capture clips (walk60.bvh, walk_forward.bvh) in "
                    "../shared/data/bvh next to the checkout")


def test_every_block_says_what_it_is():
    bad = [f"{b.where}: ```{b.lang}" for b in ALL if b.lang not in KINDS]
    assert not bad, "fence a block as one of " + ", ".join(sorted(KINDS)) + ":\n" + \
        "\n".join(bad)


_PATH = re.compile(r"(?<![\w/.-])((?:bvh|controllers|envs|mjchar|assets|docs|tests|examples)"
                   r"/[\w./*-]*[\w*/])")


def test_every_path_the_docs_name_exists():
    missing = []
    for f in markdown_files():
        text = (ROOT / f).read_text()
        for n, line in enumerate(text.splitlines(), 1):
            for m in _PATH.finditer(line):
                p = m.group(1)
                if re.fullmatch(r"mjchar/[A-Z]\w*-v\d+", p):  # a Gymnasium id
                    continue
                if p.startswith("docs/") and f.startswith("docs/") and p.count("/") > 1:
                    pass
                if not (list(ROOT.glob(p)) or (ROOT / p).exists()):
                    missing.append(f"{f}:{n}: {p}")
            for m in re.finditer(r"\]\(([^)#\s]+)", line):  # Markdown links
                target = m.group(1)
                if "://" in target:
                    continue
                if not ((ROOT / f).parent / target).exists():
                    missing.append(f"{f}:{n}: link {target}")
    assert not missing, "\n".join(missing)


@pytest.mark.parametrize("block", PYTHON, ids=lambda b: b.where)
def test_python_block_compiles_and_its_imports_resolve(block):
    tree = ast.parse(block.code, block.where)
    imports = [node for node in tree.body if isinstance(node, ast.Import | ast.ImportFrom)]
    optional = {"stable_baselines3": "the rl extra"}
    for node in imports:
        top = (node.module if isinstance(node, ast.ImportFrom) else node.names[0].name) or ""
        if top.split(".")[0] in optional:
            pytest.importorskip(top.split(".")[0],
                                reason=f"needs {optional[top.split('.')[0]]}")
    code = compile(ast.Module(body=imports, type_ignores=[]), block.where, "exec")
    exec(code, {})


@pytest.mark.slow
@pytest.mark.parametrize("block", [b for b in PYTHON if not _is_fragment(b)],
                         ids=lambda b: b.where)
def test_python_block_runs(block, folder):
    _skip_without_shared(block.code)
    if "stable_baselines3" in block.code:
        pytest.importorskip("stable_baselines3", reason="needs the rl extra")
    r = _run([sys.executable, "-c", block.code], folder, timeout=3600)
    assert r.returncode == 0, f"{block.where} exited {r.returncode}; stderr:\n{r.stderr}"


def _check_command(b: Block, cmd: str, expected: list[str], folder: Path) -> None:
    _skip_without_shared(cmd)
    r = _run(["bash", "-c", cmd], folder, timeout=3600)
    output = " ".join((r.stdout + r.stderr).split())
    if b.lang == "console":
        for line in expected:
            shown = " ".join(line.split("...")[0].rstrip(" ,(").split())
            assert shown in output, f"{b.where}: `{cmd}` no longer prints\n  {line}\n" \
                                    f"it prints:\n{output}"
    else:
        assert r.returncode == 0, f"{b.where}: `{cmd}` exited {r.returncode}; stderr:\n" \
                                  f"{r.stderr}"


QUICK_BLOCKS = [b for b in ALL if b.lang in ("bash", "console")
                and any(_quick(cmd) or b.lang == "console" for cmd, _ in _commands(b)
                        if not _skipped(cmd))]


@pytest.mark.parametrize("block", QUICK_BLOCKS, ids=lambda b: b.where)
def test_commands_run_quickly(block, folder):
    """A block's quick commands in order (a later line may use what an earlier one wrote)."""
    for cmd, expected in _commands(block):
        if _skipped(cmd):
            continue
        if block.lang == "console":
            _check_command(block, cmd, expected, folder)
        elif _quick(cmd):
            _check_command(block, _quick(cmd), expected, folder)


@pytest.mark.docs_full
@pytest.mark.parametrize("item", [c for c in COMMANDS if c[0].lang != "console"
                                  and _quick(c[1]) != c[1]], ids=_id)
def test_command_runs_as_written(item, folder):
    _check_command(*item, folder)
